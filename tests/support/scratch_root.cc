// One scratch folder per test binary: see scratch_root.h.
#include "tests/support/scratch_root.h"

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <system_error>

#include <gtest/gtest.h>

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

// The run's verdict, set when GoogleTest finishes the test program. The
// exit handler must not ask GoogleTest itself: it may run after
// GoogleTest's own statics are gone (it did, in binaries where this file's
// start-up hook ran first).
enum class Verdict { kNotRun, kPassed, kFailed };
std::atomic<Verdict> verdict{Verdict::kNotRun};

class VerdictListener : public ::testing::EmptyTestEventListener {
  void OnTestProgramEnd(const ::testing::UnitTest& unit_test) override {
    verdict = unit_test.Passed() ? Verdict::kPassed : Verdict::kFailed;
  }
};

// Removed unless a test failed: after a pass, and after a run with no tests
// (--gtest_list_tests, which CTest's discovery runs at build time).
void RemoveScratchIfPassed() {
  if (verdict != Verdict::kFailed) {
    std::error_code ec;
    fs::remove_all(ScratchRoot(), ec);
  } else {
    std::printf("[ harness  ] a test failed: its files are kept in %s\n", ScratchRoot().c_str());
  }
}

}  // namespace

const fs::path& ScratchRoot() {
  // Never destroyed: the exit handler below runs after static destructors.
  static const fs::path* const root = [] {
    const char* base = std::getenv("TMPDIR");
    const fs::path parent = base != nullptr && base[0] != '\0' ? fs::path(base) : fs::path("/tmp");
    auto* r = new fs::path(parent / ("impostor_it_" + std::to_string(::getpid())));
    fs::create_directories(*r);
    // Like /tmp: servers started as another user (PostgreSQL's) use it too.
    fs::permissions(*r, fs::perms::all | fs::perms::sticky_bit);
    ::setenv("TMPDIR", r->c_str(), 1);
    std::atexit(RemoveScratchIfPassed);
    ::testing::UnitTest::GetInstance()->listeners().Append(new VerdictListener);
    return r;
  }();
  return *root;
}

namespace {
// Made at start-up, before any test or child: every temporary path the
// binary asks for afterwards (fs::temp_directory_path() reads TMPDIR) is
// inside it.
[[maybe_unused]] const bool kScratchReady = !ScratchRoot().empty();
}  // namespace

}  // namespace impostor::testing
