#include "common/request/bake_memory_estimate.h"

#include <algorithm>
#include <cstdio>

#include "absl/strings/str_cat.h"
#include "common/atlas/atlas_layout.h"
#include "common/request/layout_parameters.h"

namespace impostor {
namespace {

// Bytes a texel of each map takes (worker/gpu/device_selection.h's formats,
// AtlasImages' layout): albedo RGBA8, normal_depth RGBA16, orm RGBA8, the
// optional emissive RGBA8; the render pass adds a D32 depth target.
constexpr int64_t kAlbedoTexel = 4, kNormalDepthTexel = 8, kOrmTexel = 4, kEmissiveTexel = 4, kDepthTexel = 4;
constexpr int64_t kThreeMapsTexel = kAlbedoTexel + kNormalDepthTexel + kOrmTexel;

// PNG encoding (png_encoder.cc) of the three maps at once: each holds
// deflateBound-sized band buffers (about the raw map; std::vector keeps the
// capacity after shrinking), then the joined stream and the file, each the
// compressed size. Atlas maps compress to well under half, so twice the raw
// maps bounds the three (the emissive map is encoded after them, alone).
constexpr int64_t kPngEncodeTexel = 2 * kThreeMapsTexel;

// KTX2 (ktx2_maps.cc): mip chains of albedo and orm (RGBA8), of
// normal_depth (RGBA16, and an RGBA8 copy), 4/3 of level 0 each; each level
// written as a PNG on the way (three at once); and one basisu process per
// map at once, measured at 27 bytes a texel of its level (basisu -uastc
// -uastc_level 2 on a 2048 px PNG: 112 MB peak).
constexpr int64_t kKtx2ChainsTexel = (4 * (kAlbedoTexel + kOrmTexel + kNormalDepthTexel + 4) + 2) / 3;
constexpr int64_t kKtx2LevelPngTexel = 3 * 2 * 4;
constexpr int64_t kBasisuTexel = 27;
constexpr int64_t kKtx2EncodeTexel = kKtx2ChainsTexel + kKtx2LevelPngTexel + 3 * kBasisuTexel;

// What a bake holds besides its atlases, whatever their size: the quality
// pass's views, the contact sheet, threads' stacks, the loader's leftovers
// (measured: 1-2 MB above the atlas terms).
constexpr int64_t kSmallBuffersBytes = 16 << 20;

// A surfel capture turns every covered texel into a 48-byte Surfel; the
// mesh covers at most the bounding sphere's disc, pi/4 of each tile.
constexpr int64_t kSurfelSamplesTexel = 48 * 785 / 1000;

struct Shape {
  int64_t resolution = 0;   // side of the maps read back, px
  int64_t render = 0;       // side of the render targets, px (resolution x supersampling)
  int64_t tile = 0;         // side of one frame's tile in the maps, px
  bool emissive = false;
  bool quality_pass = false;
  bool ktx2 = false;
};

Shape ShapeOf(const v1::BakeParameters& p) {
  Shape s;
  s.resolution = p.resolution();
  const bool supersampled = p.product() == v1::PRODUCT_ATLAS || p.product() == v1::PRODUCT_LOD_CHAIN;
  s.render = s.resolution * (supersampled && p.has_supersampling() ? std::max<int64_t>(1, p.supersampling()) : 1);
  // frames_auto bakes its candidates one after another; the fewest frames
  // (the largest tiles) cost the most to dilate.
  const int side = p.frames() > 0 ? GridSide(ViewLayoutOf(p)) : 0;
  s.tile = s.resolution / std::max(2, side);
  s.emissive = p.emissive();
  s.quality_pass = supersampled && (!p.has_quality_views() || p.quality_views() > 0);
  s.ktx2 = p.texture_format() == v1::TEXTURE_FORMAT_KTX2;
  return s;
}

}  // namespace

BakeDevice BakeDeviceOfType(std::string_view device_type) {
  if (device_type == "cpu") return BakeDevice::kCpu;
  if (device_type == "integrated") return BakeDevice::kIntegratedGpu;
  return BakeDevice::kDedicatedGpu;
}

BakeMemoryEstimate EstimateBakeMemory(const v1::BakeParameters& normalised, BakeDevice device) {
  const Shape s = ShapeOf(normalised);
  const int64_t maps_texels = s.resolution * s.resolution;
  const int64_t render_texels = s.render * s.render;
  const int64_t emissive = s.emissive ? kEmissiveTexel : 0;

  // Render (atlas_targets.cc): the targets on the device, then the maps
  // copied from the readback buffers (host-visible) into AtlasImages.
  const int64_t targets = render_texels * (kThreeMapsTexel + emissive + kDepthTexel);
  const int64_t readback = maps_texels * (kThreeMapsTexel + emissive);
  const int64_t maps = readback;
  // The quality pass (quality_pass.cc) gets its own copy of the three maps;
  // on a GPU it uploads them (sampled images) through a staging buffer as
  // large as the largest map.
  const bool gpu_views = device != BakeDevice::kCpu;
  const int64_t quality_copy = s.quality_pass ? maps_texels * kThreeMapsTexel : 0;
  const int64_t quality_upload = s.quality_pass && gpu_views ? maps_texels * kThreeMapsTexel : 0;
  const int64_t quality_staging = s.quality_pass && gpu_views ? maps_texels * kNormalDepthTexel : 0;
  // The quality pass's mesh views (quality_pass.cc RenderMeshViews): one
  // render of n views as tiles, ceil(sqrt(n)) a side, each view's pixels x 3
  // (its supersampling), resolved on the device. The largest of: the
  // antialiased pop orbit (72 views of min(64, view) px), the held-out views
  // (16 of `view` px, view = min(128, resolution / 8)) and the good-for
  // sizes' largest (4 views of twice that; good_for_size.h).
  const int64_t view = std::clamp<int64_t>(s.resolution / 8, 8, 128);
  const int64_t orbit_side = 9 * std::min<int64_t>(64, view) * 3;
  const int64_t held_out_side = 4 * view * 3;
  const int64_t sizes_side = 2 * std::min<int64_t>(1024, 2 * view) * 3;
  const int64_t views_side = std::max({orbit_side, held_out_side, sizes_side});
  const int64_t quality_views =
      s.quality_pass ? views_side * views_side * (kThreeMapsTexel + kDepthTexel) : 0;
  // Dilation (atlas_dilation.cc): one seed grid (8 bytes a texel) per
  // tile, three maps at once.
  const int64_t dilation = 3 * (s.tile + 2) * (s.tile + 2) * 8;
  // The encoders; texture arrays (--array) follow the PNG maps on the same
  // thread, one map at a time, below this.
  const int64_t encode = maps_texels * (s.ktx2 ? kKtx2EncodeTexel : kPngEncodeTexel);

  const bool device_is_host = device != BakeDevice::kDedicatedGpu;
  const int64_t render_device = targets + (device_is_host ? readback : 0);
  const int64_t render_host = (device_is_host ? targets : 0) + readback + maps;
  int64_t post_host = maps + std::max(dilation, quality_copy + encode + quality_staging);
  if (device_is_host) post_host += quality_upload + quality_views;
  if (normalised.product() == v1::PRODUCT_SURFELS) {
    // The maps become samples (and are freed); no quality pass, no PNG maps.
    post_host = maps + maps_texels * kSurfelSamplesTexel;
  }

  BakeMemoryEstimate out;
  out.host_bytes = std::max(render_host, post_host) + kSmallBuffersBytes;
  out.device_bytes = std::max(render_device, quality_upload + quality_views);
  out.largest_allocation_bytes = render_texels * kNormalDepthTexel;
  out.largest_allocation = "normal_depth render target";
  out.largest_allocation_shape = absl::StrCat(s.render, " px square, ", kNormalDepthTexel, " bytes a texel");
  return out;
}

namespace {

bool Supersampled(const v1::BakeParameters& p) {
  return (p.product() == v1::PRODUCT_ATLAS || p.product() == v1::PRODUCT_LOD_CHAIN) && p.has_supersampling();
}

}  // namespace

// "17.2 GB", "46 MB", "3.1 MB", "512 bytes": decimal units, as people read them.
std::string MemoryAmount(int64_t bytes) {
  char text[32];
  if (bytes >= 1'000'000'000) {
    std::snprintf(text, sizeof(text), "%.1f GB", static_cast<double>(bytes) / 1e9);
  } else if (bytes >= 10'000'000) {
    std::snprintf(text, sizeof(text), "%.0f MB", static_cast<double>(bytes) / 1e6);
  } else if (bytes >= 1'000'000) {
    std::snprintf(text, sizeof(text), "%.1f MB", static_cast<double>(bytes) / 1e6);
  } else {
    std::snprintf(text, sizeof(text), "%lld bytes", static_cast<long long>(bytes));
  }
  return text;
}

// What is baked, with the parameters that drive its memory:
// "an atlas of 16384 px at supersampling 2 (frames 64)".
std::string DescribeBake(const v1::BakeParameters& p) {
  const std::string frames = p.frames() > 0 ? absl::StrCat("frames ", p.frames()) : "frames auto";
  const std::string texture = p.texture_format() == v1::TEXTURE_FORMAT_KTX2 ? ", KTX2 maps" : "";
  const std::string sampling = Supersampled(p) ? absl::StrCat(" at supersampling ", p.supersampling()) : "";
  const std::string what = p.product() == v1::PRODUCT_SURFELS     ? "a surfel capture"
                           : p.product() == v1::PRODUCT_CARDS     ? "a card atlas"
                           : p.product() == v1::PRODUCT_LOD_CHAIN ? "a LOD chain's impostor atlas"
                                                                  : "an atlas";
  return absl::StrCat(what, " of ", p.resolution(), " px", sampling, " (", frames, texture, ")");
}

}  // namespace impostor
