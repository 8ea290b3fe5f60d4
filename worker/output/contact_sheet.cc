#include "worker/output/contact_sheet.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

constexpr int kLabelBand = 22;
constexpr int kGap = 4;

// Shrinks a full-atlas RGB image (floats 0..1, 3 channels) to panel x panel
// with a box filter: every atlas texel lands in exactly one panel pixel, so
// thin features still show.
std::vector<float> Shrink(const std::vector<float>& rgb, int w, int h, int panel) {
  std::vector<float> sum(static_cast<size_t>(panel) * panel * 3, 0.0f);
  std::vector<int> count(static_cast<size_t>(panel) * panel, 0);
  for (int y = 0; y < h; ++y) {
    const int py = std::min(panel - 1, static_cast<int>(static_cast<int64_t>(y) * panel / h));
    for (int x = 0; x < w; ++x) {
      const int px = std::min(panel - 1, static_cast<int>(static_cast<int64_t>(x) * panel / w));
      const size_t o = static_cast<size_t>(py) * panel + px;
      for (int c = 0; c < 3; ++c) sum[o * 3 + c] += rgb[(static_cast<size_t>(y) * w + x) * 3 + c];
      ++count[o];
    }
  }
  for (size_t i = 0; i < count.size(); ++i) {
    for (int c = 0; c < 3; ++c) sum[i * 3 + c] /= static_cast<float>(std::max(count[i], 1));
  }
  return sum;
}

bool DrawLabel(OIIO::ImageBuf& sheet, int x, int y, const std::string& text) {
  static const std::array<const char*, 3> kFonts = {
      "DejaVuSans", "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
      "/usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf"};
  const float white[] = {1.0f, 1.0f, 1.0f};
  for (const char* font : kFonts) {
    if (OIIO::ImageBufAlgo::render_text(sheet, x, y, text, 15, font, white)) return true;
  }
  return false;
}

}  // namespace

absl::StatusOr<ContactSheetInfo> WriteContactSheet(const std::filesystem::path& path,
                                                   const ContactSheetInput& in, int panel) {
  const size_t n = static_cast<size_t>(std::max(in.width, 0)) * std::max(in.height, 0);
  if (in.width < 1 || in.height < 1 || in.albedo_alpha.size() != n * 4 || in.normal_depth.size() != n * 4 ||
      in.orm.size() != n * 4 || (!in.emissive.empty() && in.emissive.size() != n * 4)) {
    return absl::InvalidArgumentError(
        absl::StrCat("contact sheet: map buffers do not match ", in.width, "x", in.height, " RGBA"));
  }
  if (panel < 16 || panel > 2048) {
    return absl::InvalidArgumentError(absl::StrCat("contact sheet: panel size ", panel, " is out of range 16..2048"));
  }
  struct Panel {
    std::string label;
    std::vector<float> rgb;  // full atlas resolution
  };
  std::vector<Panel> panels;
  auto add = [&](std::string label, auto&& texel) {
    Panel p{std::move(label), std::vector<float>(n * 3)};
    for (size_t i = 0; i < n; ++i) {
      const std::array<float, 3> c = texel(i);
      for (int k = 0; k < 3; ++k) p.rgb[i * 3 + k] = c[k];
    }
    panels.push_back(std::move(p));
  };
  const int w = in.width;
  auto checker = [w](size_t i) {
    const size_t x = i % w, y = i / w;
    return ((x / 16 + y / 16) % 2 == 0) ? 0.35f : 0.55f;
  };
  add("albedo", [&](size_t i) {
    const float a = in.albedo_alpha[i * 4 + 3] / 255.0f, bg = checker(i);
    return std::array<float, 3>{in.albedo_alpha[i * 4] / 255.0f * a + bg * (1 - a),
                                in.albedo_alpha[i * 4 + 1] / 255.0f * a + bg * (1 - a),
                                in.albedo_alpha[i * 4 + 2] / 255.0f * a + bg * (1 - a)};
  });
  add("coverage", [&](size_t i) {
    const float a = in.albedo_alpha[i * 4 + 3] / 255.0f;
    return std::array<float, 3>{a, a, a};
  });
  // Normal and ORM show the surface only: their dilated padding would hide
  // the silhouette.
  constexpr float kEmpty = 0.2f;
  auto covered = [&](size_t i) { return in.albedo_alpha[i * 4 + 3] != 0; };
  add("normal", [&](size_t i) {
    if (!covered(i)) return std::array<float, 3>{kEmpty, kEmpty, kEmpty};
    return std::array<float, 3>{in.normal_depth[i * 4] / 65535.0f, in.normal_depth[i * 4 + 1] / 65535.0f,
                                in.normal_depth[i * 4 + 2] / 65535.0f};
  });
  add("depth", [&](size_t i) {
    const float d = in.albedo_alpha[i * 4 + 3] == 0 ? 0.0f : 1.0f - in.normal_depth[i * 4 + 3] / 65535.0f;
    return std::array<float, 3>{d, d, d};
  });
  add("occl/rough/metal", [&](size_t i) {
    if (!covered(i)) return std::array<float, 3>{kEmpty, kEmpty, kEmpty};
    return std::array<float, 3>{in.orm[i * 4] / 255.0f, in.orm[i * 4 + 1] / 255.0f, in.orm[i * 4 + 2] / 255.0f};
  });
  if (!in.emissive.empty()) {
    add("emissive", [&](size_t i) {
      if (!covered(i)) return std::array<float, 3>{kEmpty, kEmpty, kEmpty};
      return std::array<float, 3>{in.emissive[i * 4] / 255.0f, in.emissive[i * 4 + 1] / 255.0f,
                                  in.emissive[i * 4 + 2] / 255.0f};
    });
  }

  ContactSheetInfo info;
  info.width = static_cast<int>(panels.size()) * (panel + kGap) + kGap;
  info.height = panel + kLabelBand + kGap;
  OIIO::ImageBuf sheet(OIIO::ImageSpec(info.width, info.height, 3, OIIO::TypeDesc::FLOAT));
  const float dark[] = {0.12f, 0.12f, 0.12f};
  OIIO::ImageBufAlgo::fill(sheet, dark);
  info.labelled = true;
  for (size_t k = 0; k < panels.size(); ++k) {
    const int x0 = kGap + static_cast<int>(k) * (panel + kGap);
    const std::vector<float> small = Shrink(panels[k].rgb, in.width, in.height, panel);
    OIIO::ROI roi(x0, x0 + panel, kLabelBand, kLabelBand + panel, 0, 1, 0, 3);
    sheet.set_pixels(roi, OIIO::TypeDesc::FLOAT, small.data());
    info.labelled = DrawLabel(sheet, x0 + 2, kLabelBand - 6, panels[k].label) && info.labelled;
  }
  const std::string name = path.string();
  if (!sheet.write(name, OIIO::TypeDesc::UINT8, "png")) {
    return absl::InternalError(absl::StrCat("cannot write '", name, "': ", sheet.geterror()));
  }
  return info;
}

}  // namespace impostor
