// The quality report of a baked atlas, as the `impostor` tool prints it:
// read from the manifest.json a fetch wrote (its "quality" block, see
// common/manifest/manifest_format.md). Used by `impostor quality KEY` and after
// `impostor bake`. Thread-compatible; writes only to stdout/stderr.
#ifndef IMPOSTOR_CLIENT_CLI_QUALITY_COMMAND_H_
#define IMPOSTOR_CLIENT_CLI_QUALITY_COMMAND_H_

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "impostor/client.h"

namespace impostor::cli {

// The manifest's "quality" block, or null when the file has none or cannot
// be read.
nlohmann::json ReadQualityBlock(const std::filesystem::path& manifest_path);

// One line: "quality: IoU 0.925 (min 0.881), albedo PSNR 12.2 dB (min 10.1),
// SSIM 0.290, normal 24.3 deg, depth 0.086 r, pop 1.83 over 16 views of 64
// px", plus "; frames tried 8 (missed), 10 (met)" after a --frames auto bake.
std::string QualitySummaryLine(const nlohmann::json& quality);

// True for a job error that is the quality gate's verdict (code 9,
// FAILED_PRECONDITION, "quality gate: ..."): the result exists.
bool IsQualityGateFailure(int error_code, const std::string& error_message);

// What `impostor bake` says about a downloaded result: records "manifest",
// "files", "warnings", "quality" and "contact_sheet" in `report`, prints
// each warning on stderr (even when quiet: they say what the result lacks)
// and, unless quiet, the quality line and the contact sheet's path.
void ReportFetchedResult(const sdk::FetchResult& fetched, bool quiet, nlohmann::json* report);

// After a quality-gate failure: downloads the result into `out_dir` anyway,
// reports it as ReportFetchedResult does and tells the user (stderr, unless
// quiet) where to look. A failed download is reported on stderr only: the
// gate's failure stays the command's outcome.
void FetchGatedResult(sdk::Client& client, const std::string& cache_key, const std::string& out_dir, bool quiet,
                      nlohmann::json* report);

}  // namespace impostor::cli

#endif  // IMPOSTOR_CLIENT_CLI_QUALITY_COMMAND_H_
