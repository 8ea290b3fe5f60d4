#include "worker/output/ktx2_encoder.h"

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/request/ktx2_encoder_version.h"
#include "worker/output/ktx2_file.h"
#include "worker/output/map_writer.h"
#include "worker/output/run_tool.h"

namespace impostor {
namespace {

absl::StatusOr<std::string> ReadAll(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::InternalError(absl::StrCat("cannot read '", path.string(), "'"));
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

std::filesystem::path DefaultBasisuPath() {
  if (const char* env = std::getenv("IMPOSTOR_BASISU"); env != nullptr && *env != '\0') return env;
  return IMPOSTOR_BASISU_DEFAULT;
}

absl::Status CheckBasisuVersion(const std::filesystem::path& basisu) {
  std::error_code ec;
  const std::filesystem::path log =
      std::filesystem::temp_directory_path(ec) / absl::StrCat("impostor_basisu_version_", getpid(), ".log");
  auto out = RunTool({basisu.string(), "-version"}, log);
  std::filesystem::remove(log, ec);
  if (!out.ok()) return out.status();
  if (out->find(kKtx2EncoderBanner) == std::string::npos) {
    return absl::FailedPreconditionError(absl::StrCat("KTX2 encoder '", basisu.string(), "' is not ",
                                                      std::string(kKtx2EncoderVersion), " (it printed: ", *out, ")"));
  }
  return absl::OkStatus();
}

MipLevel<uint8_t> To8Bit(const MipLevel<uint16_t>& level) {
  MipLevel<uint8_t> out{level.width, level.height, std::vector<uint8_t>(level.rgba.size())};
  for (size_t i = 0; i < level.rgba.size(); ++i) {
    out.rgba[i] = static_cast<uint8_t>((static_cast<uint32_t>(level.rgba[i]) * 255 + 32767) / 65535);
  }
  return out;
}

absl::StatusOr<std::string> EncodeUastcKtx2(std::span<const MipLevel<uint8_t>> levels,
                                            const Ktx2EncodeOptions& options) {
  if (levels.empty()) return absl::InvalidArgumentError("ktx2: no mip levels to encode");
  std::error_code ec;
  std::filesystem::create_directories(options.scratch, ec);
  if (ec) return absl::InternalError(absl::StrCat("cannot create '", options.scratch.string(), "': ", ec.message()));
  Ktx2Texture joined;
  for (size_t i = 0; i < levels.size(); ++i) {
    const std::string stem = absl::StrCat(options.name, "_level", i);
    const std::filesystem::path png = options.scratch / (stem + ".png");
    const std::filesystem::path ktx2 = options.scratch / (stem + ".ktx2");
    if (auto s = WritePngRgba8(png, levels[i].rgba, levels[i].width, levels[i].height); !s.ok()) return s;
    // -force_alpha: coverage/depth live in A even where a level is opaque.
    // No mipmaps: the chain is ours. Zstandard is basisu's KTX2 default.
    std::vector<std::string> argv = {options.basisu.string(), "-uastc", "-ktx2", options.alpha ? "-force_alpha" : "-no_alpha", "-uastc_level",
                                     "2", "-file", png.string(), "-output_file", ktx2.string()};
    if (!options.srgb) argv.push_back("-linear");
    if (options.rdo) {
      // -uastc_rdo_m: single-threaded RDO, so the same input gives the
      // same bytes (results are content-addressed).
      for (const char* a : {"-uastc_rdo_l", "1.0", "-uastc_rdo_m"}) argv.push_back(a);
    }
    auto ran = RunTool(argv, options.scratch / (stem + ".log"), options.cancelled);
    if (!ran.ok()) return ran.status();
    auto bytes = ReadAll(ktx2);
    if (!bytes.ok()) return bytes.status();
    auto one = ParseKtx2(*bytes);
    if (!one.ok()) {
      return absl::InternalError(absl::StrCat("encoder output '", ktx2.string(), "': ", one.status().message()));
    }
    if (one->levels.size() != 1 || one->width != static_cast<uint32_t>(levels[i].width) ||
        one->height != static_cast<uint32_t>(levels[i].height) || one->ColorModel() != kKtx2ColorModelUastc) {
      return absl::InternalError(absl::StrCat("encoder output '", ktx2.string(), "' is not a one-level ",
                                              levels[i].width, "x", levels[i].height, " UASTC texture"));
    }
    if (i == 0) {
      joined = std::move(*one);
    } else {
      if (one->supercompression != joined.supercompression || one->dfd != joined.dfd) {
        return absl::InternalError(absl::StrCat("encoder output '", ktx2.string(),
                                                "' differs from level 0 in supercompression or format"));
      }
      joined.levels.push_back(std::move(one->levels[0]));
    }
    std::filesystem::remove(png, ec);
    std::filesystem::remove(ktx2, ec);
    std::filesystem::remove(options.scratch / (stem + ".log"), ec);
  }
  return SerializeKtx2(joined);
}

}  // namespace impostor
