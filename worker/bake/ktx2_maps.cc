#include "worker/bake/ktx2_maps.h"

#include <cmath>
#include <future>

#include "absl/strings/str_cat.h"
#include "common/request/texture_format_parameters.h"
#include "worker/bake/bake_outputs.h"
#include "worker/output/ktx2_encoder.h"
#include "worker/output/tile_mip_chain.h"

namespace impostor {

const char* const kKtx2AlbedoPrecision =
    "UASTC 4x4 from 8-bit sRGB: RMS error 4-5.5 8-bit steps per colour channel, coverage 0.2 (DamagedHelmet, "
    "tested <= 7)";
const char* const kKtx2NormalDepthPrecision =
    "8 bits per channel before UASTC 4x4 (the PNG keeps 16): normals mean error 4.5 degrees (tested <= 6); A (depth) "
    "shares its blocks with the normal and keeps RMS 7.5/255 of the bounding-sphere diameter: use depth.ktx2";
const char* const kKtx2DepthPrecision =
    "depth alone (R = G = B), 8 bits before UASTC 4x4: error RMS 0.71/255 of the bounding-sphere diameter, p99 0.9%, "
    "max 2.4% (DamagedHelmet, tested RMS <= 1/255); 16-bit depth does not survive block compression";
const char* const kKtx2OrmPrecision =
    "UASTC 4x4 from 8-bit linear: RMS error 9-11 8-bit steps per channel (four unrelated channels share each block; "
    "tested <= 14)";

namespace {

absl::StatusOr<v1::MapFile> EncodeOne(const std::filesystem::path& dir, const std::string& semantic,
                                      std::span<const MipLevel<uint8_t>> chain, bool srgb, bool rdo,
                                      const char* precision, const std::atomic<bool>* cancelled,
                                      bool alpha = true) {
  Ktx2EncodeOptions options{.basisu = DefaultBasisuPath(),
                            .scratch = dir / ".ktx2_scratch",
                            .name = semantic,
                            .srgb = srgb,
                            .rdo = rdo,
                            .alpha = alpha,
                            .cancelled = cancelled};
  auto bytes = EncodeUastcKtx2(chain, options);
  if (!bytes.ok()) return bytes.status();
  const std::string file = semantic + ".ktx2";
  auto digest = WriteFileWithDigest(dir / file, *bytes);
  if (!digest.ok()) return digest.status();
  v1::MapFile map;
  map.set_semantic(semantic);
  map.set_file(file);
  *map.mutable_digest() = *digest;
  map.set_width(static_cast<uint32_t>(chain[0].width));
  map.set_height(static_cast<uint32_t>(chain[0].height));
  map.set_format("ktx2_uastc");
  map.set_codec(rdo ? "uastc_rdo" : "uastc");
  map.set_levels(static_cast<uint32_t>(chain.size()));
  map.set_precision(precision);
  return map;
}

// The manifest's coverage_by_level for a map whose A is coverage, rounded
// to 4 decimals so the manifest reads as figures, not float noise.
absl::StatusOr<v1::MapFile> WithCoverageByLevel(absl::StatusOr<v1::MapFile> map,
                                                std::span<const MipLevel<uint8_t>> chain,
                                                std::span<const TileRect> tiles) {
  if (!map.ok()) return map;
  auto ratios = CoverageByLevel(chain, tiles);
  if (!ratios.ok()) return ratios.status();
  for (double r : *ratios) map->add_coverage_by_level(std::round(r * 1e4) / 1e4);
  return map;
}

}  // namespace

absl::StatusOr<std::vector<v1::MapFile>> WriteKtx2Maps(const std::filesystem::path& dir, const Ktx2MapsInput& in) {
  if (auto s = CheckBasisuVersion(DefaultBasisuPath()); !s.ok()) return s;
  auto albedo = BuildCoverageMipChain(in.albedo_alpha, in.width, in.height, in.tiles, in.levels);
  if (!albedo.ok()) return albedo.status();
  const bool rdo = in.albedo_codec == v1::ALBEDO_CODEC_UASTC_RDO;
  // basisu uses every core for one image; the maps still overlap their
  // file writes and chain building.
  auto albedo_file = std::async(std::launch::async, [&] {
    return WithCoverageByLevel(
        EncodeOne(dir, "albedo_alpha", *albedo, /*srgb=*/true, rdo, kKtx2AlbedoPrecision, in.cancelled), *albedo,
        in.tiles);
  });
  std::vector<v1::MapFile> normal_files;  // the depth map, written by normal_file's task
  auto normal_file = std::async(std::launch::async, [&]() -> absl::StatusOr<v1::MapFile> {
    auto chain16 = BuildNormalDepthMipChain(in.normal_depth, *albedo, in.tiles);
    if (!chain16.ok()) return chain16.status();
    std::vector<MipLevel<uint8_t>> chain;
    for (size_t level = 0; level < chain16->size(); ++level) {
      MipLevel<uint16_t>& l = (*chain16)[level];
      const std::vector<TileRect> tiles = TilesAtLevel(in.tiles, static_cast<int>(level));
      if (auto s = DilateDepth(l, (*albedo)[level], tiles); !s.ok()) return s;
      chain.push_back(To8Bit(l));
    }
    auto normal = EncodeOne(dir, "normal_depth", chain, /*srgb=*/false, /*rdo=*/false, kKtx2NormalDepthPrecision,
                            in.cancelled);
    if (!normal.ok()) return normal;
    // normal_depth.A shares its blocks with three normal channels and keeps
    // little precision; depth alone in an RGB texture keeps ~8 bits.
    for (MipLevel<uint8_t>& l : chain) {
      for (size_t i = 0; i < l.rgba.size(); i += 4) {
        l.rgba[i] = l.rgba[i + 1] = l.rgba[i + 2] = l.rgba[i + 3];
        l.rgba[i + 3] = 255;
      }
    }
    auto depth = EncodeOne(dir, "depth", chain, /*srgb=*/false, /*rdo=*/false, kKtx2DepthPrecision, in.cancelled,
                           /*alpha=*/false);
    if (!depth.ok()) return depth;
    for (const char* c : {"R: depth as normal_depth.A, linear (empty texels: dilated, coverage is albedo_alpha.A)",
                          "G: = R", "B: = R", "A: 1"}) {
      depth->add_channels(c);
    }
    normal_files.push_back(std::move(*depth));
    return normal;
  });
  auto orm_file = std::async(std::launch::async, [&]() -> absl::StatusOr<v1::MapFile> {
    auto chain = BuildCoverageMipChain(in.orm, in.width, in.height, in.tiles, in.levels);
    if (!chain.ok()) return chain.status();
    return WithCoverageByLevel(
        EncodeOne(dir, "orm", *chain, /*srgb=*/false, /*rdo=*/false, kKtx2OrmPrecision, in.cancelled), *chain,
        in.tiles);
  });
  std::vector<v1::MapFile> maps;
  absl::Status first = absl::OkStatus();
  for (auto* f : {&albedo_file, &normal_file, &orm_file}) {
    absl::StatusOr<v1::MapFile> m = f->get();
    if (!m.ok() && first.ok()) first = m.status();
    if (m.ok()) maps.push_back(std::move(*m));
  }
  for (v1::MapFile& m : normal_files) maps.push_back(std::move(m));
  if (first.ok() && !in.emissive.empty()) {
    auto chain = BuildCoverageMipChain(in.emissive, in.width, in.height, in.tiles, in.levels);
    if (!chain.ok()) {
      first = chain.status();
    } else {
      auto m = WithCoverageByLevel(
          EncodeOne(dir, "emissive", *chain, /*srgb=*/true, rdo, kKtx2AlbedoPrecision, in.cancelled), *chain,
          in.tiles);
      if (m.ok()) maps.push_back(std::move(*m));
      else first = m.status();
    }
  }
  std::error_code ec;
  std::filesystem::remove_all(dir / ".ktx2_scratch", ec);
  if (!first.ok()) return first;
  return maps;
}

}  // namespace impostor
