#include "worker/cards/card_capture.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "worker/output/atlas_dilation.h"

namespace impostor {
namespace {

// The card's tile grown by the gutter: what dilation fills.
TileRect WithGutter(const TileRect& t, int gutter, int size) {
  TileRect g{std::max(0, t.x - gutter), std::max(0, t.y - gutter), 0, 0};
  g.width = std::min(size, t.x + t.width + gutter) - g.x;
  g.height = std::min(size, t.y + t.height + gutter) - g.y;
  return g;
}

}  // namespace

absl::StatusOr<CardCapture> CaptureCards(const CardCaptureRequest& req, AtlasRenderer& renderer,
                                         const std::function<void(double)>& progress,
                                         const std::atomic<bool>& cancelled) {
  const Scene& src = *req.scene;
  const int n = req.atlas_size;
  const size_t texels = static_cast<size_t>(n) * n;
  CardCapture out;
  out.atlas.width = out.atlas.height = n;
  out.atlas.albedo_alpha.assign(texels * 4, 0);
  out.atlas.orm.assign(texels * 4, 0);
  out.atlas.normal_depth.resize(texels * 4);
  for (size_t i = 0; i < texels; ++i) {
    out.atlas.normal_depth[4 * i + 0] = out.atlas.normal_depth[4 * i + 1] = out.atlas.normal_depth[4 * i + 2] = 32768;
    out.atlas.normal_depth[4 * i + 3] = 65535;
  }
  out.card_texels.assign(req.cards.size(), 0);

  // One working scene: the mesh's vertices, materials (double-sided: a card
  // shows whatever of its triangles faces either side) and textures; only
  // its triangles change from card to card.
  Scene work;
  work.vertices = src.vertices;
  work.materials = src.materials;
  for (SceneMaterial& m : work.materials) m.double_sided = true;
  work.textures = src.textures;
  work.bounds_min = src.bounds_min;
  work.bounds_max = src.bounds_max;
  std::vector<int> triangle_batch(src.TriangleCount(), 0);
  for (size_t b = 0; b < src.batches.size(); ++b) {
    const SceneBatch& batch = src.batches[b];
    for (uint32_t t = batch.first_index / 3; t < (batch.first_index + batch.index_count) / 3; ++t) {
      triangle_batch[t] = static_cast<int>(b);
    }
  }

  const float rho = req.packing.texels_per_unit;
  const float mesh_radius = req.mesh_sphere.radius;
  for (size_t c = 0; c < req.cards.size(); ++c) {
    if (cancelled) return absl::CancelledError(absl::StrCat("cancelled after ", c, " of ", req.cards.size(), " cards"));
    const CardRect& card = req.cards[c];
    const TileRect& tile = req.packing.tiles[c];
    work.indices.clear();
    work.batches.clear();
    std::vector<uint32_t> triangles = req.card_triangles[c];
    std::stable_sort(triangles.begin(), triangles.end(),
                     [&](uint32_t a, uint32_t b) { return triangle_batch[a] < triangle_batch[b]; });
    for (uint32_t t : triangles) {
      const SceneBatch& from = src.batches[triangle_batch[t]];
      if (work.batches.empty() || work.batches.back().material != from.material ||
          work.batches.back().flipped_winding != from.flipped_winding) {
        work.batches.push_back({static_cast<uint32_t>(work.indices.size()), 0, from.material, from.flipped_winding});
      }
      for (int k = 0; k < 3; ++k) work.indices.push_back(src.indices[3 * t + k]);
      work.batches.back().index_count += 3;
    }
    if (work.indices.empty()) continue;

    // Square scratch view: the tile in its top-left corner, and at least as
    // deep as the card's farthest triangle (plus a texel) on either side.
    const float texel = 1.0f / rho;
    const int depth_pixels = static_cast<int>(std::ceil(2.0f * (req.card_depth[c] + texel) * rho));
    int size = std::max({tile.width, tile.height, depth_pixels});
    if (size > kMaxCardScratchPixels) {
      spdlog::warn("event=card_depth_capped card={} depth={:.6g} pixels={}", c, req.card_depth[c], size);
      size = kMaxCardScratchPixels;
    }
    const float r = static_cast<float>(size) / (2.0f * rho);
    BoundingSphere view;
    view.radius = r;
    view.center = card.center + card.u * (r - card.half_u) - card.v * (r - card.half_v);
    FrameCamera camera;
    camera.direction = card.normal;
    camera.up = card.v;
    camera.right = card.u;
    camera.tile = {0, 0, size, size};
    RenderTimings timings;
    auto images = renderer.Render(work, view, {camera}, size, {}, &timings);
    if (!images.ok()) return images.status();
    out.timings.upload_seconds += timings.upload_seconds;
    out.timings.render_seconds += timings.render_seconds;
    out.timings.readback_seconds += timings.readback_seconds;

    for (int y = 0; y < tile.height; ++y) {
      for (int x = 0; x < tile.width; ++x) {
        const size_t s = (static_cast<size_t>(y) * size + x) * 4;
        const size_t d = (static_cast<size_t>(tile.y + y) * n + tile.x + x) * 4;
        const bool covered = images->albedo_alpha[s + 3] > 0;
        if (!covered) continue;
        ++out.card_texels[c];
        for (int k = 0; k < 4; ++k) {
          out.atlas.albedo_alpha[d + k] = images->albedo_alpha[s + k];
          out.atlas.orm[d + k] = images->orm[s + k];
        }
        for (int k = 0; k < 3; ++k) out.atlas.normal_depth[d + k] = images->normal_depth[s + k];
        // Card view depth (1 - dist / r) / 2 -> mesh-radius depth.
        const float dist = (1.0f - 2.0f * images->normal_depth[s + 3] / 65535.0f) * r;
        const float a = std::clamp(0.5f * (1.0f - dist / mesh_radius), 0.0f, 1.0f);
        out.atlas.normal_depth[d + 3] = static_cast<uint16_t>(std::lround(a * 65535.0f));
      }
    }
    if (progress) progress(static_cast<double>(c + 1) / req.cards.size());
  }

  std::vector<TileRect> regions;
  for (const TileRect& t : req.packing.tiles) regions.push_back(WithGutter(t, req.packing.gutter, n));
  if (auto s = DilateRgba8(out.atlas.albedo_alpha, n, n, regions); !s.ok()) return s;
  if (auto s = DilateRgba8(out.atlas.orm, n, n, regions); !s.ok()) return s;
  if (auto s = DilateRgba16(out.atlas.normal_depth, out.atlas.albedo_alpha, n, n, regions); !s.ok()) return s;
  return out;
}

std::vector<uint8_t> TangentSpaceNormals(const AtlasImages& atlas, const std::vector<CardRect>& cards,
                                         const CardPacking& packing) {
  const int n = atlas.width;
  std::vector<uint8_t> out(static_cast<size_t>(n) * n * 4);
  for (size_t i = 0; i < out.size(); i += 4) {
    out[i] = 128;
    out[i + 1] = 128;
    out[i + 2] = 255;
    out[i + 3] = 255;
  }
  auto encode = [](float v) { return static_cast<uint8_t>(std::lround(std::clamp(v * 0.5f + 0.5f, 0.0f, 1.0f) * 255.0f)); };
  for (size_t c = 0; c < cards.size(); ++c) {
    const TileRect g = WithGutter(packing.tiles[c], packing.gutter, n);
    const CardRect& card = cards[c];
    for (int y = g.y; y < g.y + g.height; ++y) {
      for (int x = g.x; x < g.x + g.width; ++x) {
        const size_t i = (static_cast<size_t>(y) * n + x) * 4;
        glm::vec3 m(atlas.normal_depth[i] / 65535.0f * 2.0f - 1.0f, atlas.normal_depth[i + 1] / 65535.0f * 2.0f - 1.0f,
                    atlas.normal_depth[i + 2] / 65535.0f * 2.0f - 1.0f);
        glm::vec3 t(0.0f, 0.0f, 1.0f);
        if (glm::length(m) > 0.5f) {
          t = glm::vec3(glm::dot(m, card.u), glm::dot(m, card.v), glm::dot(m, card.normal));
          // Seen from the card's front a surface faces the viewer; a
          // tangent-space normal below the card is not representable.
          t.z = std::max(t.z, 0.05f);
          t = glm::normalize(t);
        }
        out[i] = encode(t.x);
        out[i + 1] = encode(t.y);
        out[i + 2] = encode(t.z);
      }
    }
  }
  return out;
}

}  // namespace impostor
