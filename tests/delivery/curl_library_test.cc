// libcurl is loaded when the first mirror download needs it
// (client/transport/curl_library.h), not when a program using the SDK starts.
#include "client/transport/curl_library.h"

#include <dlfcn.h>

#include <cstdlib>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace impostor::sdk {
namespace {

using ::testing::HasSubstr;

bool CurlIsLoaded() {
  void* handle = dlopen(kCurlSoname, RTLD_NOW | RTLD_NOLOAD);
  if (handle == nullptr) return false;
  dlclose(handle);  // drops only the reference RTLD_NOLOAD took
  return true;
}

// In a fresh process (the threadsafe death-test style re-executes this
// binary for this test alone): the program starts without libcurl, which
// fails if the SDK's libraries link it again; the first Curl() loads it.
TEST(CurlLibraryTest, IsLoadedOnFirstUseNotAtStartUp) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        if (CurlIsLoaded()) std::_Exit(2);
        auto curl = Curl();
        if (!curl.ok() || (*curl)->easy_init == nullptr) std::_Exit(3);
        CURL* handle = (*curl)->easy_init();
        if (handle == nullptr) std::_Exit(4);
        (*curl)->easy_cleanup(handle);
        std::_Exit(CurlIsLoaded() ? 0 : 5);
      },
      ::testing::ExitedWithCode(0), "")
      << "exit 2: libcurl loaded at start-up; 3/4: not usable; 5: not loaded after Curl()";
}

TEST(CurlLibraryTest, ALibraryThatCannotBeLoadedIsAClearError) {
  auto lib = LoadCurlLibrary("libcurl-impostor-test-missing.so.9");
  ASSERT_FALSE(lib.ok());
  EXPECT_EQ(lib.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(lib.status().message(), HasSubstr("libcurl-impostor-test-missing.so.9"));
  EXPECT_THAT(lib.status().message(), HasSubstr("libcurl4"));
  EXPECT_THAT(lib.status().message(), HasSubstr("cannot load it"));
}

// A library that loads but is not libcurl (libm has none of its functions).
TEST(CurlLibraryTest, ALibraryWithoutCurlsFunctionsIsAClearError) {
  auto lib = LoadCurlLibrary("libm.so.6");
  ASSERT_FALSE(lib.ok());
  EXPECT_EQ(lib.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(lib.status().message(), HasSubstr("a function is missing"));
  EXPECT_THAT(lib.status().message(), HasSubstr("curl_global_init"));
}

}  // namespace
}  // namespace impostor::sdk
