// Helpers for the dashboard's headless-Chromium tests: run a page through
// browser/cdp_page.mjs and read back the PNGs it hands out as data URLs.
#ifndef IMPOSTOR_TESTS_METRICS_BROWSER_CAPTURE_H_
#define IMPOSTOR_TESTS_METRICS_BROWSER_CAPTURE_H_

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/atlas/atlas_layout.h"
#include "tests/support/server_process.h"

// After the protobuf headers (OIIO's byteswap macros clash with them).
#include <OpenImageIO/imageio.h>

namespace impostor::testing {

std::string Base64Decode(const std::string& in);

// Opens http://127.0.0.1:PORT + `path` in headless Chromium, waits for
// `until`, evaluates `eval` and optionally saves a screenshot. Returns the
// cdp_page.mjs report ({"ok", "value", "console_errors", "error"}); a
// discarded JSON when the tool printed none.
nlohmann::json RunPage(int port, const std::string& path, const std::string& until, const std::string& eval,
                       const std::filesystem::path& screenshot = {});

// Writes the PNG of a "data:image/png;base64,..." URL to `file` and returns
// its RGBA8 pixels (empty, with a test failure, when it is not one).
std::vector<uint8_t> SavePngDataUrl(const std::string& url, const std::filesystem::path& file, int* width,
                                    int* height);

// One bake per layout, for the tests that compare the browser with the C++
// runtime on every layout.
struct LayoutCase {
  const char* name;
  v1::Layout layout;
  LayoutKind kind;
  uint32_t frames;      // 0: derived by the server
  uint32_t ring_views;  // ring-top only
};
inline constexpr LayoutCase kEveryLayout[] = {
    {"octahedral", v1::LAYOUT_OCTAHEDRAL, LayoutKind::kOctahedral, 8, 0},
    {"hemi-octahedral", v1::LAYOUT_HEMI_OCTAHEDRAL, LayoutKind::kHemiOctahedral, 8, 0},
    {"azimuth-elevation", v1::LAYOUT_AZIMUTH_ELEVATION, LayoutKind::kAzimuthElevation, 9, 0},
    {"ring-top", v1::LAYOUT_RING_TOP, LayoutKind::kRingTop, 0, 12},
    {"billboard", v1::LAYOUT_BILLBOARD, LayoutKind::kBillboard, 0, 0},
};
// The ring views of a baked layout as the runtime takes them (ImpostorLayout.ring_views).
int RingViews(LayoutKind kind, const v1::Manifest& m);

// Submits one bake of `mesh` per kEveryLayout entry (256 px, no quality
// pass), all at once so the worker bakes them back to back; the job ids in
// that order (a test failure and fewer ids when a submit is refused).
std::vector<std::string> SubmitEveryLayout(ServerProcess& server, const v1::MeshInput& mesh);

// RGBA pixels of a PNG file, as 8 or 16 bit per channel, exactly as stored.
// UnassociatedAlpha: without it OIIO premultiplies RGB by A on read (with a
// gamma), darkening the atlas's partially covered edge texels (MSAA coverage
// 64/128/191) and scaling normals by depth, while the bake, the reference
// renderer and the browser all use straight alpha; that alone cost the
// azimuth-elevation view 52 dB (26.3 -> 78.0).
template <typename T>
std::vector<T> ReadRgba(const std::filesystem::path& file, int* width, int* height) {
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(file.string(), &config);
  EXPECT_TRUE(in) << file;
  if (!in) return {};
  const OIIO::ImageSpec& spec = in->spec();
  *width = spec.width;
  *height = spec.height;
  EXPECT_EQ(spec.nchannels, 4) << file;
  std::vector<T> pixels(static_cast<size_t>(spec.width) * spec.height * 4);
  in->read_image(0, 0, 0, 4, sizeof(T) == 1 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16, pixels.data());
  return pixels;
}

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_METRICS_BROWSER_CAPTURE_H_
