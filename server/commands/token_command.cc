#include "server/commands/token_command.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include <chrono>
#include <cstdio>
#include <map>
#include <optional>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/time/time.h"
#include "common/util/sha256.h"
#include "server/store/job_store_factory.h"
#include "server/store/token_store_factory.h"

namespace impostor {
namespace {

// WHERE: the server's --data DIR, or its --database URL when it runs on
// PostgreSQL (the replicas' shared tokens).
constexpr char kUsage[] =
    "usage: impostor-server token create WHERE --role reader|submitter|worker|admin --name NAME "
    "[--expires-in 90d] [--require-tag TAG]...\n"
    "       impostor-server token list WHERE\n"
    "       impostor-server token revoke WHERE --name NAME\n"
    "WHERE: --data DIR (SQLite, the server's data directory) or --database postgresql://... (the database "
    "the server replicas share)\n"
    "--require-tag TAG: every bake submitted with the token (submitter or admin) requires a worker started with "
    "--tags TAG, besides the request's own --require-tag; repeat for several (at most 16, each 1..64 bytes of "
    "[a-z0-9._-])\n";

int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string Iso(int64_t ms) {
  if (ms == 0) return "-";
  return absl::FormatTime("%Y-%m-%dT%H:%M:%SZ", absl::FromUnixMillis(ms), absl::UTCTimeZone());
}

int UsageError(const std::string& message) {
  std::fprintf(stderr, "impostor-server token: %s\n%s", message.c_str(), kUsage);
  return 2;
}

int StoreError(const absl::Status& status) {
  std::fprintf(stderr, "impostor-server token: %s\n", std::string(status.message()).c_str());
  return 1;
}

// `impostor-server token create --data /var/lib/impostor` is typically run
// as root, before or beside a server that runs as the data directory's
// owner (the packages' `impostor` user). A tokens.sqlite3 that root created
// would be read-only to that server: it starts, reads tokens, and then fails
// every quota write. So the files go to the directory's owner.
void GiveTokenFilesToDataDirOwner(const std::filesystem::path& data_dir) {
  if (::geteuid() != 0) return;
  struct stat dir {};
  if (::stat(data_dir.c_str(), &dir) != 0 || dir.st_uid == 0) return;
  for (const char* name : {"tokens.sqlite3", "tokens.sqlite3-wal", "tokens.sqlite3-shm"}) {
    const std::filesystem::path file = data_dir / name;
    if (::lchown(file.c_str(), dir.st_uid, dir.st_gid) != 0 && errno != ENOENT) {
      std::fprintf(stderr, "impostor-server token: warning: cannot give %s to the owner of %s (uid %u): %s\n",
                   file.c_str(), data_dir.c_str(), static_cast<unsigned>(dir.st_uid), std::strerror(errno));
    }
  }
}

}  // namespace

absl::StatusOr<int64_t> ParseExpiresIn(const std::string& text) {
  const auto bad = [&] {
    return absl::InvalidArgumentError(
        absl::StrCat("--expires-in: \"", text, "\" is not a duration like 90d, 12h, 30m or 45s (1 s .. 3650 d)"));
  };
  if (text.size() < 2 || text.size() > 12) return bad();
  int64_t n = 0;
  for (size_t i = 0; i + 1 < text.size(); ++i) {
    if (text[i] < '0' || text[i] > '9') return bad();
    n = n * 10 + (text[i] - '0');
  }
  static const std::map<char, int64_t> kUnitMs = {{'s', 1000}, {'m', 60'000}, {'h', 3'600'000}, {'d', 86'400'000}};
  const auto unit = kUnitMs.find(text.back());
  if (unit == kUnitMs.end() || n < 1) return bad();
  const int64_t ms = n * unit->second;
  if (ms > int64_t{3650} * 86'400'000) return bad();
  return ms;
}

int RunTokenCommand(const std::vector<std::string>& args) {
  if (args.empty()) return UsageError("missing subcommand: create, list or revoke");
  const std::string& verb = args[0];
  if (verb == "--help" || verb == "help") {
    std::fputs(kUsage, stdout);
    return 0;
  }
  const std::map<std::string, std::vector<std::string>> allowed = {
      {"create", {"--data", "--database", "--role", "--name", "--expires-in", "--require-tag"}},
      {"list", {"--data", "--database"}},
      {"revoke", {"--data", "--database", "--name"}},
  };
  const auto spec = allowed.find(verb);
  if (spec == allowed.end()) return UsageError(absl::StrCat("unknown subcommand \"", verb, "\""));
  std::map<std::string, std::string> flags;
  std::vector<std::string> require_tags;  // --require-tag repeats
  for (size_t i = 1; i < args.size(); ++i) {
    std::string flag = args[i];
    std::optional<std::string> value;
    if (const size_t eq = flag.find('='); eq != std::string::npos) {
      value = flag.substr(eq + 1);
      flag.resize(eq);
    }
    for (char& c : flag) c = c == '_' ? '-' : c;
    if (std::find(spec->second.begin(), spec->second.end(), flag) == spec->second.end()) {
      return UsageError(absl::StrCat("unknown argument \"", flag, "\" for 'token ", verb, "'"));
    }
    if (!value) {
      if (i + 1 >= args.size()) return UsageError(absl::StrCat(flag, ": missing value"));
      value = args[++i];
    }
    if (flag == "--require-tag") {
      require_tags.push_back(*value);
      continue;
    }
    if (flags.contains(flag)) return UsageError(absl::StrCat(flag, ": given twice"));
    flags[flag] = *value;
  }
  const std::string data = flags["--data"];
  const std::string database = flags["--database"];
  if (!database.empty()) {
    if (auto s = ValidateDatabaseUrl(database); !s.ok()) return UsageError(std::string(s.message()));
  } else {
    if (data.empty()) {
      return UsageError("--data: required (the server's data directory), or --database with its PostgreSQL URL");
    }
    std::error_code ec;
    if (!std::filesystem::is_directory(data, ec)) {
      return UsageError(absl::StrCat("--data: ", data, " is not a directory (give the server's --data)"));
    }
    if (const std::string url = TokensInDatabaseOf(data); !url.empty()) {
      return UsageError(absl::StrCat("--data: the server on ", data, " keeps its tokens in its --database (", url,
                                     "); give --database with that URL instead"));
    }
  }

  std::optional<Role> role;
  std::optional<int64_t> expires_in_ms;
  std::vector<std::string> required_tags;
  if (verb == "create") {
    if (!flags.contains("--role")) return UsageError("--role: required (reader, submitter, worker or admin)");
    auto r = ParseRole(flags["--role"]);
    if (!r.ok()) return UsageError(std::string(r.status().message()));
    role = *r;
    if (flags.contains("--expires-in")) {
      auto e = ParseExpiresIn(flags["--expires-in"]);
      if (!e.ok()) return UsageError(std::string(e.status().message()));
      expires_in_ms = *e;
    }
    auto tags = NormalizeTokenRequiredTags(require_tags);
    if (!tags.ok()) return UsageError(std::string(tags.status().message()));
    required_tags = *std::move(tags);
    if (auto s = CheckRequiredTagsFitRole(*role, required_tags); !s.ok()) return UsageError(std::string(s.message()));
  }
  if (verb != "list") {
    if (!flags.contains("--name")) return UsageError("--name: required");
    if (auto s = ValidateTokenName(flags["--name"]); !s.ok()) return UsageError(std::string(s.message()));
  }

  // --database wins: a server on PostgreSQL keeps its tokens there.
  auto storage = OpenTokenStorage({.database_url = database, .data_dir = database.empty() ? data : ""});
  if (!storage.ok()) return StoreError(storage.status());
  TokenStore* const store = storage->tokens.get();
  // On every way out, after the verb wrote (and before the store closes).
  struct OwnerFix {
    std::string dir;
    ~OwnerFix() {
      if (!dir.empty()) GiveTokenFilesToDataDirOwner(dir);
    }
  } owner_fix{database.empty() ? data : ""};
  const int64_t now = NowMs();
  if (verb == "create") {
    const std::string secret = NewTokenSecret();
    TokenRecord record{.name = flags["--name"],
                       .role = *role,
                       .secret_hash = TokenHash(secret),
                       .created_ms = now,
                       .expires_ms = expires_in_ms ? now + *expires_in_ms : 0,
                       .required_tags = required_tags};
    if (auto s = store->Insert(record); !s.ok()) return StoreError(s);
    // The only time the secret exists outside the caller's hands.
    std::printf("%s\n", secret.c_str());
    std::fprintf(stderr,
                 "impostor-server token: created '%s' (role %s, expires %s%s); the secret above is shown once\n",
                 record.name.c_str(), std::string(RoleName(record.role)).c_str(),
                 record.expires_ms ? Iso(record.expires_ms).c_str() : "never",
                 record.required_tags.empty()
                     ? ""
                     : absl::StrCat(", its bakes require tags ", absl::StrJoin(record.required_tags, ",")).c_str());
    return 0;
  }
  if (verb == "revoke") {
    if (auto s = store->Revoke(flags["--name"], now); !s.ok()) return StoreError(s);
    std::fprintf(stderr, "impostor-server token: revoked '%s'; a running server refuses it within a few seconds\n",
                 flags["--name"].c_str());
    return 0;
  }
  auto tokens = store->List();
  if (!tokens.ok()) return StoreError(tokens.status());
  // REQUIRED_TAGS last: scripts that cut the first columns keep working.
  std::printf("%-24s %-9s %-20s %-20s %-20s %-8s %s\n", "NAME", "ROLE", "CREATED", "EXPIRES", "LAST_USED", "STATUS",
              "REQUIRED_TAGS");
  for (const TokenRecord& t : *tokens) {
    const char* status = t.revoked_ms ? "revoked" : (t.expires_ms && now >= t.expires_ms ? "expired" : "active");
    const std::string tags = t.required_tags.empty() ? "-" : absl::StrJoin(t.required_tags, ",");
    std::printf("%-24s %-9s %-20s %-20s %-20s %-8s %s\n", t.name.c_str(), std::string(RoleName(t.role)).c_str(),
                Iso(t.created_ms).c_str(), t.expires_ms ? Iso(t.expires_ms).c_str() : "never",
                Iso(t.last_used_ms).c_str(), status, tags.c_str());
  }
  return 0;
}

std::string LocalWorkerTokenName(bool shared_database, const std::filesystem::path& data_dir) {
  if (!shared_database) return "local-workers";
  char host[256] = {};
  ::gethostname(host, sizeof(host) - 1);
  std::error_code ec;
  const std::filesystem::path dir = std::filesystem::absolute(data_dir, ec);
  return "local-workers-" + Sha256Hex(absl::StrCat(host, ":", dir.string())).substr(0, 12);
}

absl::StatusOr<std::filesystem::path> MintLocalWorkerToken(TokenStore* store, const std::filesystem::path& data_dir,
                                                           const std::string& name) {
  if (auto s = store->Revoke(name, NowMs()); !s.ok() && !absl::IsNotFound(s)) return s;
  const std::string secret = NewTokenSecret();
  if (auto s = store->Insert(
          {.name = name, .role = Role::kWorker, .secret_hash = TokenHash(secret), .created_ms = NowMs()});
      !s.ok()) {
    return s;
  }
  const std::filesystem::path path = data_dir / "local-workers.token";
  std::filesystem::remove(path);
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) return absl::InternalError(absl::StrCat("cannot create ", path.string()));
  const std::string line = secret + "\n";
  const bool written = ::write(fd, line.data(), line.size()) == static_cast<ssize_t>(line.size());
  ::close(fd);
  if (!written) return absl::InternalError(absl::StrCat("cannot write ", path.string()));
  return path;
}

}  // namespace impostor
