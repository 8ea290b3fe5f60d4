// The contact sheet: the baked maps side by side in one small labelled PNG,
// so a person can check a bake at a glance (in a file browser, a CI
// artefact, a chat) without a tool that understands impostor atlases.
//
// Panels, left to right: albedo over a grey checkerboard (so transparency
// shows), coverage (white = covered), normals (RGB as stored), depth (near
// = white), ORM (as stored), and emissive when given; normal, ORM and
// emissive are dark grey where nothing is covered (their dilated padding
// would hide the silhouette). Each panel is the
// whole atlas shrunk to `panel_size` pixels square with a box filter, under
// a label band naming the map. Labels are drawn with OpenImageIO's
// render_text and a system TrueType font (DejaVu Sans, from Debian's
// fonts-dejavu-core); without a usable font the sheet is written unlabelled
// and the result says so.
//
// Pure function apart from the file it writes; thread-safe.
#ifndef IMPOSTOR_WORKER_OUTPUT_CONTACT_SHEET_H_
#define IMPOSTOR_WORKER_OUTPUT_CONTACT_SHEET_H_

#include <cstdint>
#include <filesystem>
#include <span>

#include "absl/status/statusor.h"

namespace impostor {

inline constexpr int kDefaultContactPanel = 256;

struct ContactSheetInput {
  int width = 0;   // atlas pixels
  int height = 0;
  std::span<const uint8_t> albedo_alpha;   // RGBA8
  std::span<const uint16_t> normal_depth;  // RGBA16
  std::span<const uint8_t> orm;            // RGBA8
  std::span<const uint8_t> emissive;       // RGBA8 or empty
};

struct ContactSheetInfo {
  int width = 0;
  int height = 0;
  bool labelled = false;
};

// Writes the sheet as an 8-bit RGB PNG at `path`. INVALID_ARGUMENT for
// buffers that do not match width x height or a panel size outside
// 16..2048; INTERNAL when the file cannot be written.
absl::StatusOr<ContactSheetInfo> WriteContactSheet(const std::filesystem::path& path,
                                                   const ContactSheetInput& input,
                                                   int panel_size = kDefaultContactPanel);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_OUTPUT_CONTACT_SHEET_H_
