#include "worker/output/contact_sheet.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <array>
#include <future>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/util/parallel_for.h"
#include "worker/output/map_writer.h"

namespace impostor {
namespace {

constexpr int kLabelBand = 22;
constexpr int kGap = 4;

// Shrinks the atlas to panel x panel with a box filter, reading each texel's
// panel colour through `texel` (index -> RGB 0..1): every atlas texel lands
// in exactly one panel pixel, so thin features still show. The panel's rows
// are summed side by side, each from its own band of atlas rows in the order
// one thread would take them (rows down, texels across), so the sums are
// the same floats whatever the thread count.
template <typename Texel>
std::vector<float> Shrink(int w, int h, int panel, const Texel& texel) {
  std::vector<float> sum(static_cast<size_t>(panel) * panel * 3, 0.0f);
  // The atlas rows of panel row py: [first[py], first[py + 1]).
  std::vector<int> first(static_cast<size_t>(panel) + 1, h);
  for (int y = h - 1; y >= 0; --y) {
    first[std::min(panel - 1, static_cast<int>(static_cast<int64_t>(y) * panel / h))] = y;
  }
  for (int py = panel - 1; py > 0; --py) first[py - 1] = std::min(first[py - 1], first[py]);
  std::vector<int> column(static_cast<size_t>(w));
  for (int x = 0; x < w; ++x) column[x] = std::min(panel - 1, static_cast<int>(static_cast<int64_t>(x) * panel / w));
  ParallelFor(static_cast<size_t>(panel), [&](size_t py) {
    float* row = sum.data() + py * panel * 3;
    std::vector<int> count(static_cast<size_t>(panel), 0);
    for (int y = first[py]; y < first[py + 1]; ++y) {
      for (int x = 0; x < w; ++x) {
        const int px = column[x];
        const std::array<float, 3> c = texel(static_cast<size_t>(y) * w + x);
        for (int k = 0; k < 3; ++k) row[px * 3 + k] += c[k];
        ++count[px];
      }
    }
    for (int px = 0; px < panel; ++px) {
      for (int c = 0; c < 3; ++c) row[px * 3 + c] /= static_cast<float>(std::max(count[px], 1));
    }
  });
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
    std::vector<float> rgb;  // panel x panel
  };
  // Each panel reads a whole atlas (4 M texels at 2048 px): they are shrunk
  // side by side, each on its own thread, rather than one after another.
  std::vector<std::string> labels;
  std::vector<std::future<std::vector<float>>> shrunk;
  auto add = [&](std::string label, auto texel) {
    labels.push_back(std::move(label));
    shrunk.push_back(std::async(std::launch::async, [&in, panel, texel] { return Shrink(in.width, in.height, panel, texel); }));
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

  std::vector<Panel> panels;
  for (size_t k = 0; k < shrunk.size(); ++k) panels.push_back({std::move(labels[k]), shrunk[k].get()});

  ContactSheetInfo info;
  info.width = static_cast<int>(panels.size()) * (panel + kGap) + kGap;
  info.height = panel + kLabelBand + kGap;
  OIIO::ImageBuf sheet(OIIO::ImageSpec(info.width, info.height, 3, OIIO::TypeDesc::FLOAT));
  const float dark[] = {0.12f, 0.12f, 0.12f};
  OIIO::ImageBufAlgo::fill(sheet, dark);
  info.labelled = true;
  for (size_t k = 0; k < panels.size(); ++k) {
    const int x0 = kGap + static_cast<int>(k) * (panel + kGap);
    OIIO::ROI roi(x0, x0 + panel, kLabelBand, kLabelBand + panel, 0, 1, 0, 3);
    sheet.set_pixels(roi, OIIO::TypeDesc::FLOAT, panels[k].rgb.data());
    info.labelled = DrawLabel(sheet, x0 + 2, kLabelBand - 6, panels[k].label) && info.labelled;
  }
  // The maps' zlib level and row filter (map_writer.h) rather than
  // libpng's level 6 and per-row filter search: on 2 cores the write took
  // 0.13-0.23 s of the sheet's 0.35-0.45 s, and on a GPU host the sheet was
  // the slowest step of the bake's encoding.
  sheet.specmod().attribute("png:compressionLevel", kPngCompressionLevel);
  sheet.specmod().attribute("png:filter", kPngRowFilter);
  const std::string name = path.string();
  if (!sheet.write(name, OIIO::TypeDesc::UINT8, "png")) {
    return absl::InternalError(absl::StrCat("cannot write '", name, "': ", sheet.geterror()));
  }
  return info;
}

}  // namespace impostor
