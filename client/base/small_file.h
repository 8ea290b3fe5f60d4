// Reads a whole small file (an entry's record, a result's manifest, a kept
// channel file or catalog) with one open, fstat and read.
//
// Why not std::ifstream: the cache reads an entry's record on every Get
// that misses (to see whether another process installed it meanwhile) and
// its manifest after every install. A profile of a fleet of 100 caches
// (bench/fleet_bench, perf with DWARF call stacks) put 2-4 % of the SDK's
// CPU in constructing ifstreams and copying through a stringstream: a
// locale taken under a process-wide mutex, an 8 KiB stream buffer, and the
// text copied twice, where the file is read once here.
#ifndef IMPOSTOR_CLIENT_BASE_SMALL_FILE_H_
#define IMPOSTOR_CLIENT_BASE_SMALL_FILE_H_

#include <cstdint>
#include <filesystem>
#include <string>

#include "absl/status/statusor.h"

namespace impostor::sdk {

// The bytes of `path`. NOT_FOUND when it (or a folder on its way) does not
// exist; OUT_OF_RANGE when it holds more than `max_bytes` (nothing is read
// then: a damaged or foreign file is not loaded whole); otherwise a
// LocalIoError (INTERNAL naming the path, e.g. for a folder or no
// permission).
absl::StatusOr<std::string> ReadSmallFile(const std::filesystem::path& path, int64_t max_bytes);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_BASE_SMALL_FILE_H_
