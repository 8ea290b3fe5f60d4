// Everything a test binary writes to disk goes under one folder,
// <TMPDIR or /tmp>/impostor_it_<pid>/, made before main: temporary folders
// (fs::temp_directory_path() and mkdtemp follow TMPDIR, which is set for
// this process and so inherited by every server, worker and tool it
// starts), process logs, scratch files. It is removed when the binary exits
// with every test passed (also after --gtest_list_tests, which CTest's
// discovery runs at build time) and kept, and named, when a test failed,
// for inspection. A binary killed (a ctest timeout, a crash) leaves it too.
//
// Linked into a test binary as the object library impostor_test_scratch
// (so the start-up hook is always in), or with impostor_test_support.
#ifndef IMPOSTOR_TESTS_SUPPORT_SCRATCH_ROOT_H_
#define IMPOSTOR_TESTS_SUPPORT_SCRATCH_ROOT_H_

#include <filesystem>

namespace impostor::testing {

const std::filesystem::path& ScratchRoot();

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_SUPPORT_SCRATCH_ROOT_H_
