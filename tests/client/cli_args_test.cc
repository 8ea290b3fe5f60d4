#include "client/cli/cli_args.h"
#include "client/cli/flag_terms.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace impostor::cli {
namespace {

TEST(ParseCliArgs, FullBakeCommand) {
  absl::StatusOr<CliArgs> a = ParseCliArgs({"bake", "tree.gltf", "--layout", "hemi-octahedral", "--frames=16",
                                            "--resolution", "1024", "--out", "out/tree", "--server", "h:1", "--json",
                                            "--quiet"},
                                           nullptr);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_EQ(a->command, Command::kBake);
  EXPECT_EQ(a->target, "tree.gltf");
  EXPECT_EQ(a->layout, "hemi-octahedral");
  EXPECT_EQ(a->frames, 16u);
  EXPECT_EQ(a->resolution, 1024u);
  EXPECT_EQ(a->out, "out/tree");
  EXPECT_EQ(a->server, "h:1");
  EXPECT_TRUE(a->json);
  EXPECT_TRUE(a->quiet);
}

TEST(ParseCliArgs, Defaults) {
  absl::StatusOr<CliArgs> a = ParseCliArgs({"bake", "m.glb", "--out", "o"}, nullptr);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_EQ(a->server, "localhost:50051");
  EXPECT_EQ(a->layout, "octahedral");
  EXPECT_EQ(a->frames, 0u);
  EXPECT_EQ(a->resolution, 0u);
  EXPECT_FALSE(a->json);
}

TEST(ParseCliArgs, ServerFromEnvironmentUnlessFlagGiven) {
  EXPECT_EQ(ParseCliArgs({"status", "j1"}, "env:7")->server, "env:7");
  EXPECT_EQ(ParseCliArgs({"status", "j1", "--server", "flag:8"}, "env:7")->server, "flag:8");
  EXPECT_EQ(ParseCliArgs({"status", "j1"}, "")->server, "localhost:50051");
}

TEST(ParseCliArgs, NumbersPassThroughUnchecked) {
  // Ranges are the server's to judge; 0 means "the server's default".
  EXPECT_EQ(ParseCliArgs({"bake", "m.glb", "--out", "o", "--frames", "0"}, nullptr)->frames, 0u);
  EXPECT_EQ(ParseCliArgs({"bake", "m.glb", "--out", "o", "--frames", "1000"}, nullptr)->frames, 1000u);
}

TEST(ParseCliArgs, CardFlags) {
  auto a = ParseCliArgs({"bake", "tree.gltf", "--product", "cards", "--max-planes", "12", "--tolerance", "0.02",
                         "--resolution", "512", "--out", "o"},
                        nullptr);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_EQ(a->product, "cards");
  EXPECT_EQ(a->max_planes, 12u);
  EXPECT_FLOAT_EQ(a->tolerance.value_or(0), 0.02f);
  EXPECT_EQ(a->resolution, 512u);
  auto bad = ParseCliArgs({"bake", "tree.gltf", "--product", "cards", "--tolerance", "tight", "--out", "o"}, nullptr);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("--tolerance"), std::string::npos) << bad.status();
}

TEST(ParseCliArgs, LodChainFlags) {
  auto a = ParseCliArgs({"bake", "tree.gltf", "--product", "lod-chain", "--lod-ratios", "0.6,0.25,0.05", "--out", "o"},
                        nullptr);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_EQ(a->product, "lod-chain");
  EXPECT_EQ(a->lod_ratios, (std::vector<float>{0.6f, 0.25f, 0.05f}));
  EXPECT_EQ(a->layout, "") << "no --layout: the server's lod-chain default (hemi-octahedral)";
  auto with_layout = ParseCliArgs({"bake", "m.glb", "--product", "lod-chain", "--layout", "octahedral", "--out", "o"},
                                  nullptr);
  ASSERT_TRUE(with_layout.ok());
  EXPECT_EQ(with_layout->layout, "octahedral");
  EXPECT_TRUE(with_layout->lod_ratios.empty());
  // Order and range are the server's to judge; the syntax is checked here.
  EXPECT_TRUE(ParseCliArgs({"bake", "m.glb", "--lod-ratios", "0.1,0.5", "--out", "o"}, nullptr).ok());
  for (const char* bad : {"0.5,,0.1", "half", "0.5,", ""}) {
    auto b = ParseCliArgs({"bake", "m.glb", "--product", "lod-chain", "--lod-ratios", bad, "--out", "o"}, nullptr);
    ASSERT_FALSE(b.ok()) << bad;
    EXPECT_NE(b.status().message().find("--lod-ratios"), std::string::npos) << bad << ": " << b.status();
  }
}

TEST(ParseCliArgs, HelpVersionAndOtherCommands) {
  EXPECT_EQ(ParseCliArgs({"--help"}, nullptr)->command, Command::kHelp);
  EXPECT_EQ(ParseCliArgs({"help"}, nullptr)->command, Command::kHelp);
  EXPECT_EQ(ParseCliArgs({"bake", "--bogus", "-h"}, nullptr)->command, Command::kHelp);
  EXPECT_EQ(ParseCliArgs({"version"}, nullptr)->command, Command::kVersion);
  absl::StatusOr<CliArgs> f = ParseCliArgs({"fetch", std::string(64, 'c'), "--out", "d"}, nullptr);
  ASSERT_TRUE(f.ok()) << f.status();
  EXPECT_EQ(f->command, Command::kFetch);
  EXPECT_EQ(f->target, std::string(64, 'c'));
  EXPECT_EQ(ParseCliArgs({"cancel", "j9"}, nullptr)->command, Command::kCancel);
  // "--" ends the flags: a model may start with a dash.
  EXPECT_EQ(ParseCliArgs({"bake", "--out", "o", "--", "-odd.glb"}, nullptr)->target, "-odd.glb");
}

struct UsageCase {
  std::string name;
  std::vector<std::string> args;
  std::string message_part;
};

TEST(ParseCliArgs, UsageErrorsNameTheCulprit) {
  const std::vector<UsageCase> cases = {
      {"no_command", {}, "missing command"},
      {"unknown_command", {"bakee"}, "unknown command \"bakee\""},
      {"unknown_flag", {"bake", "m.glb", "--out", "o", "--colour", "red"}, "unknown flag --colour"},
      {"flag_of_other_command", {"status", "j1", "--out", "o"}, "unknown flag --out"},
      {"missing_out", {"bake", "m.glb"}, "--out"},
      {"missing_out_value", {"bake", "m.glb", "--out"}, "--out: missing value"},
      {"out_value_is_a_flag", {"bake", "m.glb", "--out", "--json"}, "--out: missing value"},
      {"frames_not_a_number", {"bake", "m.glb", "--out", "o", "--frames", "abc"}, "--frames"},
      {"frames_negative", {"bake", "m.glb", "--out", "o", "--frames", "-4"}, "--frames"},
      {"frames_trailing_junk", {"bake", "m.glb", "--out", "o", "--frames=12x"}, "--frames"},
      {"resolution_overflow", {"bake", "m.glb", "--out", "o", "--resolution", "99999999999"}, "--resolution"},
      {"unknown_layout", {"bake", "m.glb", "--out", "o", "--layout", "cube"}, "--layout"},
      {"missing_model", {"bake", "--out", "o"}, "MODEL"},
      {"two_models_without_out", {"bake", "a.glb", "b.glb"}, "needs --out DIR"},
      {"two_keys", {"fetch", std::string(64, 'a'), "k2", "--out", "o"}, "unexpected argument \"k2\""},
      {"key_not_hex", {"fetch", "abc", "--out", "o"}, "cache key \"abc\": expected 64 lowercase hex characters"},
      {"quality_key_upper", {"quality", std::string(64, 'A')}, "expected 64 lowercase hex characters"},
      {"bool_flag_with_value", {"bake", "m.glb", "--out", "o", "--json=yes"}, "--json takes no value"},
      {"missing_job_id", {"status"}, "JOB_ID"},
      {"outage_negative", {"bake", "m.glb", "--out", "o", "--max-outage-seconds", "-1"}, "--max-outage-seconds"},
      {"outage_too_long", {"fetch", std::string(64, 'a'), "--out", "o", "--max-outage-seconds=90000"}, "0..86400"},
      {"outage_not_a_number", {"bake-batch", "s.json", "--out", "o", "--max-outage-seconds", "soon"},
       "--max-outage-seconds"},
      {"outage_nan", {"status", "j1", "--max-outage-seconds", "nan"}, "--max-outage-seconds"},
      {"outage_missing_value", {"fetch", std::string(64, 'a'), "--out", "o", "--max-outage-seconds"}, "missing value"},
      {"outage_on_cache_ls", {"cache", "ls", "--max-outage-seconds", "5"}, "unknown flag --max-outage-seconds"},
      {"keepalive_zero", {"bake", "m.glb", "--out", "o", "--keepalive-seconds", "0"}, "--keepalive-seconds"},
      {"keepalive_too_long", {"status", "j1", "--keepalive-seconds=7201"}, "1..7200"},
      {"keepalive_fraction", {"fetch", std::string(64, 'a'), "--out", "o", "--keepalive-seconds", "1.5"}, "got \"1.5\""},
      {"keepalive_missing_value", {"bake-batch", "s.json", "--out", "o", "--keepalive-seconds"}, "missing value"},
      {"keepalive_on_cache_ls", {"cache", "ls", "--keepalive-seconds", "5"}, "unknown flag --keepalive-seconds"},
  };
  for (const UsageCase& c : cases) {
    absl::StatusOr<CliArgs> a = ParseCliArgs(c.args, nullptr);
    ASSERT_FALSE(a.ok()) << c.name << ": accepted";
    EXPECT_EQ(a.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(a.status().message().find(c.message_part), std::string::npos)
        << c.name << ": message \"" << a.status().message() << "\" lacks \"" << c.message_part << "\"";
  }
}

TEST(ParseCliArgs, MaxOutageSecondsOnEveryCommandThatTalksToTheServer) {
  const std::vector<std::vector<std::string>> commands = {
      {"bake", "m.glb", "--out", "o"}, {"bake-batch", "s.json", "--out", "o"}, {"fetch", std::string(64, 'a'), "--out", "o"},
      {"quality", std::string(64, 'a')},                {"status", "j"},                         {"cancel", "j"},
      {"cache", "get", "k"}};
  for (std::vector<std::string> args : commands) {
    EXPECT_FALSE(ParseCliArgs(args, nullptr)->max_outage_seconds.has_value()) << args[0] << ": unset by default";
    args.push_back("--max-outage-seconds=12.5");
    absl::StatusOr<CliArgs> a = ParseCliArgs(args, nullptr);
    ASSERT_TRUE(a.ok()) << args[0] << ": " << a.status();
    EXPECT_EQ(a->max_outage_seconds, 12.5) << args[0];
  }
  EXPECT_EQ(ParseCliArgs({"fetch", std::string(64, 'a'), "--out", "o", "--max-outage-seconds", "0"}, nullptr)->max_outage_seconds, 0);
  EXPECT_NE(UsageText().find("--max-outage-seconds N"), std::string::npos);
}

TEST(ParseCliArgs, KeepaliveSecondsOnEveryCommandThatTalksToTheServer) {
  const std::vector<std::vector<std::string>> commands = {
      {"bake", "m.glb", "--out", "o"}, {"bake-batch", "s.json", "--out", "o"}, {"fetch", std::string(64, 'a'), "--out", "o"},
      {"quality", std::string(64, 'a')},                {"status", "j"},                         {"cancel", "j"},
      {"cache", "get", "k"},           {"admin", "purge", "--worker", "w"}};
  for (std::vector<std::string> args : commands) {
    EXPECT_FALSE(ParseCliArgs(args, nullptr)->keepalive_seconds.has_value()) << args[0] << ": unset by default";
    args.insert(args.end(), {"--keepalive-seconds", "2"});
    absl::StatusOr<CliArgs> a = ParseCliArgs(args, nullptr);
    ASSERT_TRUE(a.ok()) << args[0] << ": " << a.status();
    EXPECT_EQ(a->keepalive_seconds, 2) << args[0];
  }
  EXPECT_NE(UsageText().find("--keepalive-seconds N"), std::string::npos);
}

TEST(UsageText, DocumentsEveryExitCode) {
  const std::string text = UsageText();
  for (const char* code : {"0  success", "1  the bake failed", "2  usage error", "3  cannot reach the server",
                           "4  local I/O error"}) {
    EXPECT_NE(text.find(code), std::string::npos) << code;
  }
}

}  // namespace
}  // namespace impostor::cli

namespace impostor::cli {
namespace {

// Identity (issue 14): --token-file on every command that talks to the
// server, nowhere else.
TEST(ParseCliArgs, TokenFile) {
  struct Case {
    std::vector<std::string> args;
    bool ok;
    const char* error;
  } cases[] = {
      {{"bake", "m.glb", "--out", "d", "--token-file", "t"}, true, ""},
      {{"bake-batch", "s.json", "--out", "d", "--token-file=t"}, true, ""},
      {{"fetch", std::string(64, 'a'), "--out", "d", "--token-file", "t"}, true, ""},
      {{"status", "j", "--token-file", "t"}, true, ""},
      {{"cache", "get", "k", "--token-file", "t"}, true, ""},
      {{"cache", "ls", "--token-file", "t"}, false, "unknown flag --token-file"},
      {{"status", "j", "--token-file"}, false, "--token-file: missing value"},
      {{"status", "j", "--token-file="}, false, "--token-file: missing value"},
      {{"status", "j", "--token-file", "--json"}, false, "--token-file: missing value"},
  };
  for (const Case& c : cases) {
    auto parsed = ParseCliArgs(c.args, nullptr);
    EXPECT_EQ(parsed.ok(), c.ok) << c.args[0] << " " << c.args.back() << ": " << parsed.status();
    if (parsed.ok()) {
      EXPECT_EQ(parsed->token_file, "t");
    } else {
      EXPECT_NE(parsed.status().message().find(c.error), std::string::npos) << parsed.status();
    }
  }
}

}  // namespace
}  // namespace impostor::cli

namespace impostor::cli {
namespace {

// impostor admin purge --worker NAME (issue 14): the connection flags of
// every server command, --worker required, no positional argument.
TEST(ParseCliArgs, AdminPurge) {
  auto parsed = ParseCliArgs({"admin", "purge", "--worker", "render-node-01", "--json", "--token-file", "a.token",
                              "--server", "farm:50051", "--tls-ca", "ca.pem"},
                             nullptr);
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  EXPECT_EQ(parsed->command, Command::kAdminPurge);
  EXPECT_EQ(parsed->worker, "render-node-01");
  EXPECT_TRUE(parsed->json);
  EXPECT_EQ(parsed->token_file, "a.token");
  EXPECT_EQ(parsed->server, "farm:50051");
  EXPECT_EQ(parsed->tls_ca, "ca.pem");
  struct Case {
    const char* name;
    std::vector<std::string> args;
    const char* error;
  } cases[] = {
      {"no verb", {"admin"}, "'admin' needs a subcommand: purge"},
      {"unknown verb", {"admin", "wipe"}, "unknown command \"admin wipe\""},
      {"no worker", {"admin", "purge"}, "--worker: required"},
      {"empty worker", {"admin", "purge", "--worker="}, "--worker: missing value"},
      {"positional", {"admin", "purge", "--worker", "w", "extra"}, "unexpected argument \"extra\""},
      {"worker elsewhere", {"status", "j", "--worker", "w"}, "unknown flag --worker"},
  };
  for (const Case& c : cases) {
    auto bad = ParseCliArgs(c.args, nullptr);
    ASSERT_FALSE(bad.ok()) << c.name;
    EXPECT_NE(bad.status().message().find(c.error), std::string::npos) << c.name << ": " << bad.status();
  }
  EXPECT_NE(UsageText().find("impostor admin purge --worker NAME"), std::string::npos);
}

TEST(InFlagTerms, TheServersApiNamesReadAsTheFlagsTyped) {
  EXPECT_EQ(InFlagTerms("parameters.ring_views: 2 is out of range 3..64"),
            "--ring (parameters.ring_views): 2 is out of range 3..64");
  EXPECT_EQ(InFlagTerms("parameters.preset: \"prop\" is only for product PRODUCT_SURFELS"),
            "--preset (parameters.preset): \"prop\" is only for product surfels");
  EXPECT_EQ(InFlagTerms("parameters.frames: ring-top derives its grid; LAYOUT_RING_TOP and PRODUCT_LOD_CHAIN"),
            "--frames (parameters.frames): ring-top derives its grid; ring-top and lod-chain");
  // Longer names are not cut: frames_auto is not frames.
  EXPECT_EQ(InFlagTerms("parameters.frames_auto: needs a gate"), "parameters.frames_auto: needs a gate");
  EXPECT_EQ(InFlagTerms("PRODUCT_CARDSX"), "PRODUCT_CARDSX");
  EXPECT_EQ(InFlagTerms(""), "");
  EXPECT_EQ(InFlagTerms("required_tags[1]: \"GPU\" is not 1..64 bytes of [a-z0-9._-]"),
            "--require-tag (required_tags)[1]: \"GPU\" is not 1..64 bytes of [a-z0-9._-]");
}

// --require-tag repeats, in the order typed (the server sorts them).
TEST(ParseCliArgs, RequireTagRepeats) {
  absl::StatusOr<CliArgs> a =
      ParseCliArgs({"bake", "m.glb", "--out", "o", "--require-tag", "gpu", "--require-tag=team-forest"}, nullptr);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_EQ(a->required_tags, (std::vector<std::string>{"gpu", "team-forest"}));
  EXPECT_FALSE(ParseCliArgs({"bake", "m.glb", "--out", "o", "--require-tag"}, nullptr).ok());
}

// Every refusal of a field a bake flag sets, as the server words it
// (common/request/quality_gate.cc, quality_parameters.cc, texture_format_parameters.cc,
// layout_parameters.cc), names the flag typed.
TEST(InFlagTerms, EveryFieldABakeFlagSetsNamesItsFlag) {
  const struct {
    const char* server;
    const char* cli;
  } cases[] = {
      {"gate.min_iou: 1.5 is out of range 0..1", "--min-iou (gate.min_iou): 1.5 is out of range 0..1"},
      {"gate.min_psnr_db: -1 is out of range 0..100", "--min-psnr (gate.min_psnr_db): -1 is out of range 0..100"},
      {"SubmitBake (server h:1): gate: only atlas and lod-chain bakes are gated; this request's product is "
       "PRODUCT_CARDS",
       "SubmitBake (server h:1): --min-iou/--min-psnr (gate): only atlas and lod-chain bakes are gated; this "
       "request's product is cards"},
      {"gate: needs the quality pass, and this request turns it off (parameters.quality_views 0)",
       "--min-iou/--min-psnr (gate): needs the quality pass, and this request turns it off (--quality-views "
       "(parameters.quality_views) 0)"},
      {"parameters.auto_target.min_iou: 2 is out of range 0..1",
       "--min-iou (parameters.auto_target.min_iou): 2 is out of range 0..1"},
      {"parameters.auto_target.min_psnr_db: 200 is out of range 0..100",
       "--min-psnr (parameters.auto_target.min_psnr_db): 200 is out of range 0..100"},
      {"parameters.auto_target: only with frames_auto",
       "--min-iou/--min-psnr (parameters.auto_target): only with --frames auto"},
      {"parameters.texture_format: TEXTURE_FORMAT_KTX2 cannot be combined with texture_array",
       "--texture-format (parameters.texture_format): --texture-format ktx2 cannot be combined with --array"},
      {"parameters.albedo_codec: only with TEXTURE_FORMAT_KTX2",
       "--albedo-codec (parameters.albedo_codec): only with --texture-format ktx2"},
      {"parameters.texture_format: TEXTURE_FORMAT_KTX2 needs an explicit frame count (not frames_auto)",
       "--texture-format (parameters.texture_format): --texture-format ktx2 needs an explicit frame count (not "
       "--frames auto)"},
      {"parameters.texture_format: 7; expected TEXTURE_FORMAT_PNG (1) or TEXTURE_FORMAT_KTX2 (2)",
       "--texture-format (parameters.texture_format): 7; expected --texture-format png (1) or --texture-format ktx2 "
       "(2)"},
      {"parameters.albedo_codec: ALBEDO_CODEC_UASTC_RDO or ALBEDO_CODEC_UASTC",
       "--albedo-codec (parameters.albedo_codec): uastc-rdo or uastc"},
      {"parameters.texture_array: only for products PRODUCT_ATLAS and PRODUCT_LOD_CHAIN",
       "--array (parameters.texture_array): only for products atlas and lod-chain"},
      // Not a field: a job's gate verdict and its measured values stay.
      {"quality gate: silhouette IoU 0.912 < min_iou 0.95", "quality gate: silhouette IoU 0.912 < min_iou 0.95"},
  };
  for (const auto& c : cases) EXPECT_EQ(InFlagTerms(c.server), c.cli) << c.server;
}

}  // namespace

}  // namespace impostor::cli
