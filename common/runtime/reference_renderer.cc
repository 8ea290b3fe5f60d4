#include "common/runtime/reference_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <glm/geometric.hpp>

#include "common/runtime/depth_reconstruction.h"
#include "common/runtime/tile_heights.h"
#include "common/runtime/virtual_plane.h"

namespace impostor {
namespace {

float SrgbToLinear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}
float LinearToSrgb(float c) {
  c = std::clamp(c, 0.0f, 1.0f);
  return c <= 0.0031308f ? c * 12.92f : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

const std::array<float, 256>& SrgbTable() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) t[i] = SrgbToLinear(static_cast<float>(i) / 255.0f);
    return t;
  }();
  return table;
}

uint8_t ToUnorm8(float v) {
  return static_cast<uint8_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
}
uint16_t ToUnorm16(float v) {
  return static_cast<uint16_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 65535.0f));
}

// One frame's filtered sample: bilinear alpha, and the alpha-weighted means
// of the covered texels' values (unset when alpha == 0).
struct TileSample {
  float alpha = 0.0f;
  glm::vec3 albedo{0.0f};  // linear
  glm::vec3 normal{0.0f};  // decoded to [-1, 1], not renormalised
  float depth = 1.0f;      // the frame's depth, 0..1
  glm::vec3 orm{0.0f};
};

// Calls tap(x, y, weight) for each of the 2x2 texel centres around st whose
// bilinear weight is positive (x, y relative to the tile, clamped to it);
// none when st lies outside the tile's square.
template <typename Tap>
void ForEachBilinearTap(const TileRect& tile, glm::vec2 st, const Tap& tap) {
  if (!(std::abs(st.x) <= 1.0f && std::abs(st.y) <= 1.0f)) return;
  const glm::vec2 pixel = FrameStToPixel(tile, st);
  const float fx = pixel.x - static_cast<float>(tile.x) - 0.5f;
  const float fy = pixel.y - static_cast<float>(tile.y) - 0.5f;
  const float flx = std::floor(fx);
  const float fly = std::floor(fy);
  const int ix = static_cast<int>(flx);
  const int iy = static_cast<int>(fly);
  const float ax = fx - flx;
  const float ay = fy - fly;
  const std::array<float, 4> bilinear = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
  for (int k = 0; k < 4; ++k) {
    if (bilinear[k] <= 0.0f) continue;
    tap(std::clamp(ix + (k & 1), 0, tile.width - 1), std::clamp(iy + (k >> 1), 0, tile.height - 1), bilinear[k]);
  }
}

class TileSampler {
 public:
  explicit TileSampler(const ImpostorAtlas& atlas) : atlas_(atlas), srgb_(SrgbTable()) {}

  // Bilinear over the 2x2 texel centres around st, texel indices clamped to
  // `tile`. (The march reads alpha and depth only, from TileHeights.)
  TileSample Sample(const TileRect& tile, glm::vec2 st) const {
    TileSample out;
    float covered = 0.0f;
    float depth = 0.0f;
    ForEachBilinearTap(tile, st, [&](int x, int y, float weight) {
      const size_t texel = (static_cast<size_t>(tile.y + y) * atlas_.width + tile.x + x) * 4;
      const float w = weight * (static_cast<float>(atlas_.albedo_alpha[texel + 3]) / 255.0f);
      if (w <= 0.0f) return;
      covered += w;
      const uint16_t* nd = &atlas_.normal_depth[texel];
      depth += w * (static_cast<float>(nd[3]) / 65535.0f);
      out.normal += w * (glm::vec3(nd[0], nd[1], nd[2]) * (2.0f / 65535.0f) - 1.0f);
      const uint8_t* c = &atlas_.albedo_alpha[texel];
      out.albedo += w * glm::vec3(srgb_[c[0]], srgb_[c[1]], srgb_[c[2]]);
      if (!atlas_.orm.empty()) {
        const uint8_t* o = &atlas_.orm[texel];
        out.orm += w * (glm::vec3(o[0], o[1], o[2]) / 255.0f);
      }
    });
    out.alpha = covered;
    if (covered > 0.0f) {
      out.depth = depth / covered;
      out.normal /= covered;
      out.albedo /= covered;
      out.orm /= covered;
    }
    return out;
  }

 private:
  const ImpostorAtlas& atlas_;
  const std::array<float, 256>& srgb_;
};

// Covered texels of a tile, as a box in tile-pixel coordinates grown by one
// texel: a bilinear sample outside it reads four empty texels, so the
// parallax march may skip it without changing any result.
struct CoveredBox {
  float x0 = 0, y0 = 0, x1 = -1, y1 = -1;  // empty when x1 < x0
  bool MayCover(const TileRect& tile, glm::vec2 st) const {
    const glm::vec2 p = FrameStToPixel(tile, st) - glm::vec2(tile.x, tile.y);
    return p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1;
  }
  // MayCover for kLanes points given in tile pixel coordinates.
  IntLanes MayCoverLanes(FloatLanes x, FloatLanes y) const { return (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1); }
  // True when the ray passes the box at every height a march samples
  // (1 .. -1): then every read of the march is empty and it finds nothing,
  // so it may be skipped without changing any result. The ray's frame
  // coordinates are affine in the height; the margin covers their rounding.
  bool MissedBy(const FrameCamera& frame, glm::vec3 origin, glm::vec3 ray) const {
    const FramePlaneRay plane(frame, origin, ray);
    if (!plane.valid()) return false;  // the march says so itself
    const glm::vec2 tile(frame.tile.x, frame.tile.y);
    const glm::vec2 a = FrameStToPixel(frame.tile, plane.At(1.0f).st) - tile;
    const glm::vec2 b = FrameStToPixel(frame.tile, plane.At(-1.0f).st) - tile;
    constexpr float kMargin = 1.0f / 64.0f;  // px; rounding is ~1e-5 px
    return std::max(a.x, b.x) < x0 - kMargin || std::min(a.x, b.x) > x1 + kMargin ||
           std::max(a.y, b.y) < y0 - kMargin || std::min(a.y, b.y) > y1 + kMargin;
  }
};

CoveredBox FindCoveredBox(const ImpostorAtlas& atlas, const TileRect& tile) {
  int min_x = tile.width, min_y = tile.height, max_x = -1, max_y = -1;
  for (int y = 0; y < tile.height; ++y) {
    const uint8_t* row = &atlas.albedo_alpha[(static_cast<size_t>(tile.y + y) * atlas.width + tile.x) * 4];
    for (int x = 0; x < tile.width; ++x) {
      if (row[x * 4 + 3] == 0) continue;
      min_x = std::min(min_x, x);
      max_x = std::max(max_x, x);
      min_y = std::min(min_y, y);
      max_y = std::max(max_y, y);
    }
  }
  CoveredBox box;
  if (max_x < 0) return box;
  // Texel i spans [i, i + 1]; a sample within one texel of it may read it.
  box.x0 = static_cast<float>(min_x) - 1.0f;
  box.y0 = static_cast<float>(min_y) - 1.0f;
  box.x1 = static_cast<float>(max_x) + 2.0f;
  box.y1 = static_cast<float>(max_y) + 2.0f;
  return box;
}

// One pixel's running blend: coverage and the w * a weighted sums.
struct PixelBlend {
  float alpha = 0.0f;    // sum of weight * alpha (coverage)
  float covered = 0.0f;  // sum of the shading weights
  glm::vec3 albedo{0.0f}, normal{0.0f}, orm{0.0f};
  float depth = 0.0f;

  // Adds sample `s` of `frame` at frame coordinates st with shading weight w.
  void Add(float w, const TileSample& s, const FrameCamera& frame, glm::vec2 st, const FrameCamera& camera) {
    if (w <= 0.0f) return;
    covered += w;
    albedo += w * s.albedo;
    normal += w * s.normal;
    orm += w * s.orm;
    // The sample's surface point, then its depth for the view camera.
    const glm::vec3 p = st.x * frame.right + st.y * frame.up + (1.0f - 2.0f * s.depth) * frame.direction;
    depth += w * (1.0f - glm::dot(p, camera.direction)) * 0.5f;
  }

  void Write(size_t pixel, bool has_orm, ViewImages* view) {
    const float len = glm::length(normal);
    if (len > 1e-12f) normal /= len;
    const glm::vec3 mean_orm = orm / covered;
    StoreShadedPixel(pixel, albedo / covered, normal, depth / covered, has_orm ? &mean_orm : nullptr, view);
  }
};

// Depth mode for one pixel (depth_reconstruction.h, steps 1..5).
template <typename March>
void ShadeDepthPixel(const ImpostorAtlas& atlas, const FrameCamera& camera, const FrameBlend& blend,
                     const TileSampler& sampler, const std::array<TileHeights, 4>& heights, glm::vec2 view_st,
                     const March& march, PixelBlend* px) {
  std::array<DepthEntry, 4> entries;
  for (int i = 0; i < blend.count; ++i) {
    entries[i] = {&atlas.cameras[blend.entries[i].index], blend.entries[i].weight};
  }
  const DepthPixel depth = ReconstructDepthBatched(
      entries, blend.count, ViewRayOrigin(camera, view_st), -camera.direction,
      [&](int i) { return march(i, *entries[i].frame, view_st); },
      [&](int i, glm::vec2 st, float* height) {
        const TileHeights::AlphaDepth s = heights[i].Sample(st);
        *height = 1.0f - 2.0f * s.depth;
        return s.alpha;
      },
      [&](int i, int n, const glm::vec2* st, float* alpha, float* height) {
        static_assert(kMaxSurfaceBatch <= kLanes);
        FloatLanes s, t, a, d, x, y;
        for (int l = 0; l < kLanes; ++l) {
          s[l] = st[std::min(l, n - 1)].x;
          t[l] = st[std::min(l, n - 1)].y;
        }
        heights[i].SampleLanes(s, t, &a, &d, &x, &y);
        const FloatLanes h = 1.0f - 2.0f * d;
        for (int l = 0; l < n; ++l) alpha[l] = a[l], height[l] = h[l];
      });
  px->alpha = depth.coverage;
  if (px->alpha < 0.5f) return;
  for (int j = 0; j < blend.count; ++j) {
    const DepthSampleAt& at = depth.samples[j];
    if (!at.used) continue;
    const FrameCamera& frame = *entries[j].frame;
    px->Add(at.weight, sampler.Sample(frame.tile, at.st), frame, at.st, camera);
  }
}

}  // namespace

bool AtlasIsConsistent(const ImpostorAtlas& atlas) {
  const ViewLayout layout = AtlasViewLayout(atlas);
  const bool ring = layout.kind == LayoutKind::kRingTop || layout.kind == LayoutKind::kBillboard;
  if ((ring ? layout.ring_views <= 0 : atlas.frames <= 0) || atlas.width <= 0 || atlas.height <= 0 || atlas.sphere.radius <= 0.0f) return false;
  const size_t texels = static_cast<size_t>(atlas.width) * atlas.height * 4;
  if (atlas.albedo_alpha.size() != texels || atlas.normal_depth.size() != texels) return false;
  if (!atlas.orm.empty() && atlas.orm.size() != texels) return false;
  if (atlas.cameras.size() != static_cast<size_t>(FrameCount(layout))) return false;
  for (const FrameCamera& c : atlas.cameras) {
    const TileRect& t = c.tile;
    if (t.width <= 0 || t.height <= 0 || t.x < 0 || t.y < 0 || t.x + t.width > atlas.width ||
        t.y + t.height > atlas.height) {
      return false;
    }
  }
  return true;
}

ViewLayout AtlasViewLayout(const ImpostorAtlas& atlas) {
  ViewLayout layout{.kind = atlas.layout, .frames = atlas.frames, .ring_views = atlas.ring_views};
  if (atlas.layout == LayoutKind::kBillboard) layout.ring_views = kBillboardRingViews;
  if (atlas.layout != LayoutKind::kRingTop && atlas.layout != LayoutKind::kBillboard) layout.ring_views = 0;
  return layout;
}

FrameCamera ViewCameraFor(glm::vec3 direction) { return CameraForDirection(direction); }

ViewImages EmptyViewImages(int pixels, bool has_orm) {
  ViewImages view;
  view.width = pixels;
  view.height = pixels;
  const size_t count = static_cast<size_t>(pixels) * pixels;
  view.albedo_alpha.assign(count * 4, 0);
  view.normal_depth.resize(count * 4);
  for (size_t i = 0; i < count; ++i) {
    view.normal_depth[i * 4 + 0] = kEmptyNormal16;
    view.normal_depth[i * 4 + 1] = kEmptyNormal16;
    view.normal_depth[i * 4 + 2] = kEmptyNormal16;
    view.normal_depth[i * 4 + 3] = kEmptyDepth16;
  }
  if (has_orm) view.orm.assign(count * 4, 0);
  return view;
}

void StoreShadedPixel(size_t pixel, glm::vec3 albedo, glm::vec3 normal, float depth, const glm::vec3* orm,
                      ViewImages* view) {
  const size_t o = pixel * 4;
  view->albedo_alpha[o + 0] = ToUnorm8(LinearToSrgb(albedo.x));
  view->albedo_alpha[o + 1] = ToUnorm8(LinearToSrgb(albedo.y));
  view->albedo_alpha[o + 2] = ToUnorm8(LinearToSrgb(albedo.z));
  view->albedo_alpha[o + 3] = 255;
  view->normal_depth[o + 0] = ToUnorm16(normal.x * 0.5f + 0.5f);
  view->normal_depth[o + 1] = ToUnorm16(normal.y * 0.5f + 0.5f);
  view->normal_depth[o + 2] = ToUnorm16(normal.z * 0.5f + 0.5f);
  view->normal_depth[o + 3] = ToUnorm16(depth);
  if (orm != nullptr && !view->orm.empty()) {
    view->orm[o + 0] = ToUnorm8(orm->x);
    view->orm[o + 1] = ToUnorm8(orm->y);
    view->orm[o + 2] = ToUnorm8(orm->z);
    view->orm[o + 3] = 255;
  }
}

ViewImages RenderImpostorView(const ImpostorAtlas& atlas, const FrameCamera& camera, int pixels,
                              const ReferenceRenderOptions& options) {
  if (pixels <= 0 || !AtlasIsConsistent(atlas)) return {};
  const bool has_orm = !atlas.orm.empty();
  ViewImages view = EmptyViewImages(pixels, has_orm);

  // The view is orthographic: one view direction, one set of frames.
  const FrameBlend blend = BlendFrames(AtlasViewLayout(atlas), camera.direction, options.blend);
  const TileSampler sampler(atlas);
  const float inv = 1.0f / static_cast<float>(pixels);
  std::array<CoveredBox, 4> boxes;
  std::array<TileHeights, 4> heights;
  if (options.parallax || options.reconstruction == Reconstruction::kDepth) {
    for (int i = 0; i < blend.count; ++i) {
      const TileRect& tile = atlas.cameras[blend.entries[i].index].tile;
      boxes[i] = FindCoveredBox(atlas, tile);
      heights[i] = TileHeights(atlas, tile);
    }
  }

  const bool depth_mode = options.reconstruction == Reconstruction::kDepth;
  const auto march = [&](int i, const FrameCamera& frame, glm::vec2 view_st) {
    const CoveredBox& box = boxes[i];
    const glm::vec3 origin = ViewRayOrigin(camera, view_st);
    if (box.MissedBy(frame, origin, -camera.direction)) return PlaneSample{};
    // ProjectToFrameParallax, reading the march's steps kLanes at a time.
    return MarchFrameHeightField(
        FramePlaneRay(frame, origin, -camera.direction),
        [&](glm::vec2 st, float* height) {
          if (!box.MayCover(frame.tile, st)) return false;
          const TileHeights::AlphaDepth s = heights[i].Sample(st);
          if (s.alpha < 0.5f) return false;
          *height = 1.0f - 2.0f * s.depth;
          return true;
        },
        [&](const FramePlaneRay& plane, const float* at, int n, CoarseStep* steps) {
          n = std::min(n, kLanes);
          FloatLanes h;
          for (int l = 0; l < kLanes; ++l) h[l] = at[std::min(l, n - 1)];
          FloatLanes s, t, alpha, depth, x, y;
          plane.StAt(h, &s, &t);
          heights[i].SampleLanes(s, t, &alpha, &depth, &x, &y);
          const IntLanes covered = box.MayCoverLanes(x, y) & (alpha >= 0.5f);
          const FloatLanes surface = 1.0f - 2.0f * depth;
          for (int l = 0; l < n; ++l) steps[l] = {covered[l] != 0, surface[l]};
          return n;
        },
        /*refine_crossings=*/depth_mode);
  };

  for (int y = 0; y < pixels; ++y) {
    for (int x = 0; x < pixels; ++x) {
      const glm::vec2 view_st((static_cast<float>(x) + 0.5f) * inv * 2.0f - 1.0f,
                              1.0f - (static_cast<float>(y) + 0.5f) * inv * 2.0f);
      PixelBlend px;
      if (depth_mode) {
        ShadeDepthPixel(atlas, camera, blend, sampler, heights, view_st, march, &px);
      } else {
        for (int i = 0; i < blend.count; ++i) {
          const FrameCamera& frame = atlas.cameras[blend.entries[i].index];
          const PlaneSample plane =
              options.parallax ? march(i, frame, view_st) : ProjectToFrame(camera, frame, view_st);
          if (!plane.valid) continue;
          const TileSample s = sampler.Sample(frame.tile, plane.st);
          const float w = blend.entries[i].weight * s.alpha;
          px.alpha += w;
          px.Add(w, s, frame, plane.st, camera);
        }
      }
      if (px.alpha < 0.5f) continue;  // empty: keeps the clear encodings
      px.Write(static_cast<size_t>(y) * pixels + x, has_orm, &view);
    }
  }
  return view;
}

}  // namespace impostor
