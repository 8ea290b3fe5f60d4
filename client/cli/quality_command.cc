// impostor quality KEY: fetch a result and print its quality report.
#include "client/cli/quality_command.h"

#include <cstdio>
#include <fstream>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/cli/commands.h"
#include "client/cli/connection_options.h"
#include "client/cli/output.h"

namespace impostor::cli {
namespace {

namespace fs = std::filesystem;

constexpr char kWorstViewFile[] = "quality_worst_view.png";

double Num(const nlohmann::json& q, const char* key) {
  auto it = q.find(key);
  return it != q.end() && it->is_number() ? it->get<double>() : 0.0;
}

std::string FramesTried(const nlohmann::json& q) {
  auto tried = q.find("frames_tried");
  auto met = q.find("frames_met");
  if (tried == q.end() || !tried->is_array() || tried->empty() || met == q.end() || !met->is_array() ||
      met->size() != tried->size()) {
    return "";
  }
  std::string s;
  for (size_t i = 0; i < tried->size(); ++i) {
    absl::StrAppend(&s, i == 0 ? "" : ", ", (*tried)[i].is_number() ? (*tried)[i].get<int>() : 0,
                    (*met)[i].is_boolean() && (*met)[i].get<bool>() ? " (met)" : " (missed)");
  }
  return s;
}

// "; good up to 140 px on screen" (issue 43), "; misses the good-for targets
// already at 32 px on screen (IoU ..., PSNR ...)", or "" for manifests
// without sizes.
std::string GoodForPhrase(const nlohmann::json& q) {
  auto sizes = q.find("sizes");
  if (sizes == q.end() || !sizes->is_array() || sizes->empty()) return "";
  const int good = static_cast<int>(Num(q, "good_up_to_pixels"));
  if (good > 0) return absl::StrFormat("; good up to %d px on screen", good);
  // The pass stops at the first size that misses: here the smallest.
  // The IoU it was judged by: outside the mesh's own edge since bake7.
  const nlohmann::json& first = sizes->front();
  const bool firm = first.contains("silhouette_iou_firm_mean");
  return absl::StrFormat("; misses the good-for targets already at %d px on screen (IoU %.3f%s, PSNR %.1f dB)",
                         static_cast<int>(Num(first, "pixels")),
                         Num(first, firm ? "silhouette_iou_firm_mean" : "silhouette_iou_mean"),
                         firm ? " outside the mesh's own edge" : "", Num(first, "albedo_psnr_shared_db_mean"));
}

}  // namespace

nlohmann::json ReadQualityBlock(const fs::path& manifest_path) {
  std::ifstream in(manifest_path);
  if (!in) return nullptr;
  nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (j.is_object() && j.contains("quality") && j["quality"].is_object()) return j["quality"];
  return nullptr;
}

std::string QualitySummaryLine(const nlohmann::json& q) {
  std::string line = absl::StrFormat(
      "quality: IoU %.3f (min %.3f), albedo PSNR %.1f dB (min %.1f) and SSIM %.3f where both cover, normal %.1f "
      "deg, depth %.3f r, pop %.2f over %d views of %d px",
      Num(q, "silhouette_iou_mean"), Num(q, "silhouette_iou_min"), Num(q, "albedo_psnr_shared_db_mean"),
      Num(q, "albedo_psnr_shared_db_min"), Num(q, "albedo_ssim_shared_mean"), Num(q, "normal_error_deg_mean"),
      Num(q, "depth_error_mean"), Num(q, "pop"), static_cast<int>(Num(q, "views")),
      static_cast<int>(Num(q, "view_pixels")));
  if (q.contains("pop_antialiased")) absl::StrAppend(&line, absl::StrFormat(" (antialiased %.2f)", Num(q, "pop_antialiased")));
  if (const std::string tried = FramesTried(q); !tried.empty()) absl::StrAppend(&line, "; frames tried ", tried);
  absl::StrAppend(&line, GoodForPhrase(q));
  return line;
}

bool IsQualityGateFailure(int error_code, const std::string& error_message) {
  return error_code == static_cast<int>(absl::StatusCode::kFailedPrecondition) &&
         error_message.rfind("quality gate", 0) == 0;
}

void FetchGatedResult(sdk::Client& client, const std::string& cache_key, const std::string& out_dir, bool quiet,
                      nlohmann::json* report) {
  absl::StatusOr<sdk::FetchResult> fetched = client.Fetch(cache_key, out_dir);
  if (!fetched.ok()) {
    std::fprintf(stderr, "impostor: could not download the rejected result for inspection: %s\n",
                 Describe(fetched.status()).c_str());
    return;
  }
  ReportFetchedResult(*fetched, quiet, report);
  if (quiet) return;
  std::fprintf(stderr, "the rejected result is in %s for inspection (impostor quality %s shows the worst view)\n",
               out_dir.c_str(), cache_key.c_str());
}

void ReportFetchedResult(const sdk::FetchResult& fetched, bool quiet, nlohmann::json* report) {
  (*report)["manifest"] = fetched.manifest_path.string();
  for (const fs::path& f : fetched.files) (*report)["files"].push_back(f.string());
  (*report)["warnings"] = fetched.warnings;
  // Warnings go to stderr even with --quiet: they say what the atlas lacks.
  for (const std::string& w : fetched.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  const nlohmann::json quality = ReadQualityBlock(fetched.manifest_path);
  (*report)["quality"] = quality;
  if (!quiet && quality.is_object()) std::fprintf(stderr, "%s\n", QualitySummaryLine(quality).c_str());
  for (const fs::path& f : fetched.files) {
    if (f.filename() != "contact_sheet.png") continue;
    (*report)["contact_sheet"] = f.string();
    if (!quiet) std::fprintf(stderr, "contact sheet: %s\n", f.string().c_str());
  }
}

int RunQuality(const CliArgs& args) {
  const std::string out_dir = args.out.empty() ? absl::StrCat("quality-", args.target.substr(0, 12)) : args.out;
  nlohmann::json report = {{"cache_key", args.target}, {"out_dir", out_dir}, {"manifest", nullptr},
                           {"quality", nullptr},       {"worst_view_png", nullptr}, {"warnings", nlohmann::json::array()},
                           {"error", nullptr}};
  auto fail = [&](int code, const std::string& error) {
    report["error"] = error;
    if (args.json) PrintJson(report);
    return Fail(code, error);
  };
  absl::StatusOr<std::unique_ptr<sdk::Client>> client =
      sdk::Client::Connect(ClientOptionsFor(args, kInteractiveOutageSeconds));
  if (!client.ok()) return fail(kExitServer, Describe(client.status()));
  absl::StatusOr<sdk::FetchResult> fetched = (*client)->Fetch(args.target, out_dir);
  if (!fetched.ok()) return fail(ExitCodeFor(fetched.status()), Describe(fetched.status()));
  report["manifest"] = fetched->manifest_path.string();
  report["warnings"] = fetched->warnings;
  const nlohmann::json q = ReadQualityBlock(fetched->manifest_path);
  if (!q.is_object()) {
    return fail(kExitBakeFailed, absl::StrCat("FAILED_PRECONDITION: result ", args.target,
                                              " has no quality block (not an atlas, or baked with --quality-views 0)"));
  }
  report["quality"] = q;
  const fs::path worst = fs::path(out_dir) / kWorstViewFile;
  std::error_code ec;
  if (fs::exists(worst, ec)) report["worst_view_png"] = worst.string();
  nlohmann::json views_doc;
  if (args.all_views) {
    const fs::path views = fs::path(out_dir) / "views.json";
    std::ifstream in(views);
    views_doc = in ? nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false) : nlohmann::json();
    if (!views_doc.is_object() || !views_doc.contains("views") || !views_doc["views"].is_array()) {
      return fail(kExitBakeFailed, absl::StrCat("FAILED_PRECONDITION: result ", args.target,
                                                " has no per-view files (views.json; baked before manifest format 2)"));
    }
    report["views_json"] = views.string();
    report["views"] = nlohmann::json::array();
    for (const nlohmann::json& v : views_doc["views"]) {
      report["views"].push_back({{"mesh", (fs::path(out_dir) / v.value("mesh", std::string())).string()},
                                 {"impostor", (fs::path(out_dir) / v.value("impostor", std::string())).string()},
                                 {"figures", v.value("figures", nlohmann::json::object())}});
    }
  }
  if (args.json) {
    PrintJson(report);
    return kExitOk;
  }
  std::printf("quality of %s (%s blend, %d held-out views of %d px, mesh vs impostor, unlit):\n",
              args.target.c_str(), q.value("blend", std::string("?")).c_str(), static_cast<int>(Num(q, "views")),
              static_cast<int>(Num(q, "view_pixels")));
  std::printf("  silhouette IoU   mean %.4f  min %.4f\n", Num(q, "silhouette_iou_mean"), Num(q, "silhouette_iou_min"));
  std::printf("  reconstruction   %s\n", q.value("reconstruction", std::string("plain")).c_str());
  std::printf("  albedo PSNR      mean %.2f dB  min %.2f dB (where both cover)\n", Num(q, "albedo_psnr_shared_db_mean"),
              Num(q, "albedo_psnr_shared_db_min"));
  std::printf("  albedo SSIM      mean %.4f  min %.4f (where both cover)\n", Num(q, "albedo_ssim_shared_mean"),
              Num(q, "albedo_ssim_shared_min"));
  std::printf("  boundary error   mean %.2f px  max %.2f px\n", Num(q, "boundary_error_px_mean"),
              Num(q, "boundary_error_px_max"));
  std::printf("  union PSNR       mean %.2f dB (colour and silhouette misses together, over black)\n",
              Num(q, "albedo_psnr_union_db_mean"));
  std::printf("  normal error     mean %.2f deg  max %.2f deg\n", Num(q, "normal_error_deg_mean"),
              Num(q, "normal_error_deg_max"));
  std::printf("  depth error      mean %.4f r  max %.4f r\n", Num(q, "depth_error_mean"), Num(q, "depth_error_max"));
  std::printf("  pop              %.3f (1.0 = as smooth as the mesh over a 1 degree orbit step; one sample a pixel)\n",
              Num(q, "pop"));
  if (q.contains("pop_antialiased")) {
    std::printf("  pop antialiased  %.3f (both orbits 3 x 3 samples, as a game with MSAA or TAA shows them)\n",
                Num(q, "pop_antialiased"));
  }
  if (auto sizes = q.find("sizes"); sizes != q.end() && sizes->is_array() && !sizes->empty()) {
    const int good = static_cast<int>(Num(q, "good_up_to_pixels"));
    if (good > 0) {
      std::printf("  good for         up to %d px on screen: switch to the impostor below it\n", good);
    } else {
      std::printf("  good for         no measured size: keep the mesh (or more frames, a larger atlas)\n");
    }
    for (const nlohmann::json& s : *sizes) {
      // Judged outside the mesh's own antialiased edge since baker bake7.
      const std::string firm = s.contains("silhouette_iou_firm_mean")
                                   ? absl::StrFormat(" (%.4f outside the mesh's own edge)",
                                                     Num(s, "silhouette_iou_firm_mean"))
                                   : "";
      std::printf("    %4d px         IoU %.4f%s, PSNR %.2f dB where both cover%s\n",
                  static_cast<int>(Num(s, "pixels")), Num(s, "silhouette_iou_mean"), firm.c_str(),
                  Num(s, "albedo_psnr_shared_db_mean"), s.value("meets", false) ? "" : "  (misses the targets)");
    }
  }
  if (q.contains("plain") && q["plain"].is_object()) {
    const nlohmann::json& p = q["plain"];
    std::printf("  plain mode       IoU %.4f (min %.4f), PSNR %.2f dB, SSIM %.4f where both cover, boundary %.2f px, "
                "pop %.3f\n",
                Num(p, "silhouette_iou_mean"), Num(p, "silhouette_iou_min"), Num(p, "albedo_psnr_shared_db_mean"),
                Num(p, "albedo_ssim_shared_mean"), Num(p, "boundary_error_px_mean"), Num(p, "pop"));
  }
  if (const std::string tried = FramesTried(q); !tried.empty()) std::printf("  frames tried     %s\n", tried.c_str());
  for (const std::string& w : fetched->warnings) std::printf("  warning          %s\n", w.c_str());
  if (report["worst_view_png"].is_string()) {
    std::printf("  worst view       %d: %s (mesh | impostor | difference; magenta = only the mesh covers, cyan = "
                "only the impostor)\n",
                static_cast<int>(Num(q, "worst_view")), worst.string().c_str());
  }
  if (args.all_views) {
    std::printf("  every view       %s (camera and figures of each view):\n", report["views_json"].get<std::string>().c_str());
    for (const nlohmann::json& v : report["views"]) {
      const nlohmann::json& f = v["figures"];
      std::printf("    %s | %s: IoU %.4f, PSNR %.2f dB where both cover, boundary %.2f px\n",
                  v["mesh"].get<std::string>().c_str(), v["impostor"].get<std::string>().c_str(),
                  Num(f, "silhouette_iou"), Num(f, "albedo_psnr_shared_db"), Num(f, "boundary_error_px_mean"));
    }
  }
  std::fflush(stdout);
  return kExitOk;
}

}  // namespace impostor::cli
