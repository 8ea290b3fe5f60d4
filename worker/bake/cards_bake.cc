#include "worker/bake/cards_bake.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/request/bake_request.h"
#include "common/manifest/manifest_json.h"
#include "common/util/sha256.h"
#include "worker/bake/bake_outputs.h"
#include "worker/cards/card_capture.h"
#include "worker/cards/card_packing.h"
#include "worker/cards/card_quality.h"
#include "worker/cards/card_rect.h"
#include "worker/cards/cards_glb.h"
#include "worker/cards/plane_fitting.h"
#include "worker/output/map_writer.h"
#include "worker/scene/bounding_sphere.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Progress fractions at which each stage starts.
constexpr double kLoadStart = 0.05, kFitStart = 0.1, kRenderStart = 0.3, kWriteStart = 0.75, kJudgeStart = 0.85,
                 kEnd = 0.95;

const std::vector<std::string> kAlbedoChannels = {
    "R: base colour red (texture x factor, unlit), sRGB", "G: base colour green, sRGB",
    "B: base colour blue, sRGB", "A: coverage, 0 = empty, 255 = mesh (MASK cut at alphaCutoff)"};
const std::vector<std::string> kNormalDepthChannels = {
    "R: scene-space normal x * 0.5 + 0.5 (normal map applied)", "G: normal y * 0.5 + 0.5",
    "B: normal z * 0.5 + 0.5",
    "A: offset from the card's plane along its normal, (1 - dist / radius) / 2 with radius the bounding "
    "sphere's: 0.5 = on the plane"};
const std::vector<std::string> kOrmChannels = {
    "R: ambient occlusion (1 + strength * (texture.r - 1)), linear", "G: roughness (factor x texture.g), linear",
    "B: metalness (factor x texture.b), linear", "A: coverage, as albedo_alpha.A"};
const std::vector<std::string> kTangentChannels = {
    "R: tangent-space normal x (card u axis) * 0.5 + 0.5", "G: tangent-space normal y (card v axis, image up) "
    "* 0.5 + 0.5", "B: tangent-space normal z (card normal) * 0.5 + 0.5", "A: 255"};
const std::vector<std::string> kGlbChannels = {
    "glTF 2.0 binary: one quad per card, material alphaMode MASK, doubleSided, textures embedded (PNG)"};

absl::StatusOr<std::string> ReadFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  if (!in) return absl::InternalError(absl::StrCat("cannot read back ", path.string()));
  return s.str();
}

v1::Digest DigestOf(std::string_view bytes) {
  v1::Digest d;
  d.set_hash(Sha256Hex(bytes));
  d.set_size_bytes(static_cast<int64_t>(bytes.size()));
  return d;
}

void AddMap(v1::Manifest* manifest, const char* semantic, const char* file, const char* format,
            const v1::Digest& digest, uint32_t width, uint32_t height, const std::vector<std::string>& channels) {
  v1::MapFile* map = manifest->add_maps();
  map->set_semantic(semantic);
  map->set_file(file);
  *map->mutable_digest() = digest;
  map->set_width(width);
  map->set_height(height);
  map->set_format(format);
  for (const auto& c : channels) map->add_channels(c);
}

}  // namespace

absl::StatusOr<AtlasBakeOutput> BakeCards(const AtlasBakeRequest& request, AtlasRenderer& renderer,
                                          const BakeProgress& progress, const std::atomic<bool>& cancelled) {
  const auto start = Clock::now();
  const v1::BakeParameters& p = request.parameters;
  const int resolution = static_cast<int>(p.resolution());
  v1::Manifest manifest;
  v1::BakeTimings* timings = manifest.mutable_timings();

  progress("load", kLoadStart);
  auto t = Clock::now();
  absl::StatusOr<std::shared_ptr<const Scene>> loaded = SceneOf(request);
  if (!loaded.ok()) return loaded.status();
  const Scene* scene = loaded->get();
  timings->set_load_seconds(SecondsSince(t));
  if (cancelled) return absl::CancelledError("cancelled after loading");
  absl::StatusOr<BoundingSphere> framing = FramingSphere(*scene);
  if (!framing.ok()) return framing.status();
  const BoundingSphere sphere = *framing;

  // Fit planes and their cards.
  progress("encode", kFitStart);
  t = Clock::now();
  const size_t triangle_count = scene->TriangleCount();
  std::vector<Triangle3> triangles(triangle_count);
  for (size_t i = 0; i < triangle_count; ++i) {
    for (int k = 0; k < 3; ++k) triangles[i][k] = scene->vertices[scene->indices[3 * i + k]].position;
  }
  PlaneFitOptions fit_options;
  fit_options.max_planes = static_cast<int>(p.max_planes());
  fit_options.tolerance = p.tolerance() * sphere.radius;
  const PlaneFit fit = FitPlanes(triangles, fit_options);
  const double fit_seconds = SecondsSince(t);
  const size_t card_count = fit.planes.size();
  std::vector<std::vector<uint32_t>> card_triangles(card_count);
  for (size_t i = 0; i < triangle_count; ++i) card_triangles[fit.triangle_plane[i]].push_back(static_cast<uint32_t>(i));
  std::vector<CardRect> cards;
  std::vector<float> card_depth;
  for (size_t c = 0; c < card_count; ++c) {
    std::vector<glm::vec3> points;
    for (uint32_t i : card_triangles[c]) points.insert(points.end(), triangles[i].begin(), triangles[i].end());
    cards.push_back(MinimalCardRect(points, fit.planes[c].normal, fit.planes[c].d));
    card_depth.push_back(fit.planes[c].max_distance);
  }
  auto packing = PackCards(cards, resolution);
  if (!packing.ok()) return packing.status();
  // Snap every card to its whole-texel tile (it only grows, about its centre).
  for (size_t c = 0; c < card_count; ++c) {
    cards[c].half_u = packing->tiles[c].width / (2.0f * packing->texels_per_unit);
    cards[c].half_v = packing->tiles[c].height / (2.0f * packing->texels_per_unit);
  }
  if (cancelled) return absl::CancelledError("cancelled after fitting planes");

  // Render the cards.
  progress("render", kRenderStart);
  CardCaptureRequest capture_request{scene, sphere, cards, card_triangles, card_depth, *packing, resolution};
  renderer.set_cancel_flag(&cancelled);
  auto capture = CaptureCards(
      capture_request, renderer,
      [&](double f) { progress("render", kRenderStart + f * (kWriteStart - kRenderStart)); }, cancelled);
  renderer.set_cancel_flag(nullptr);
  if (!capture.ok()) return capture.status();
  timings->set_render_seconds(capture->timings.upload_seconds + capture->timings.render_seconds);
  timings->set_readback_seconds(capture->timings.readback_seconds);
  if (cancelled) return absl::CancelledError("cancelled after rendering");

  // Write the maps and the .glb.
  progress("encode", kWriteStart);
  t = Clock::now();
  const std::filesystem::path& dir = request.output_dir;
  const AtlasImages& atlas = capture->atlas;
  const std::vector<uint8_t> tangent_normals = TangentSpaceNormals(atlas, cards, *packing);
  if (auto s = WritePngRgba8(dir / "albedo_alpha.png", atlas.albedo_alpha, resolution, resolution); !s.ok()) return s;
  if (auto s = WritePngRgba16(dir / "normal_depth.png", atlas.normal_depth, resolution, resolution); !s.ok()) {
    return s;
  }
  if (auto s = WritePngRgba8(dir / "orm.png", atlas.orm, resolution, resolution); !s.ok()) return s;
  if (auto s = WritePngRgba8(dir / kCardNormalTangentFile, tangent_normals, resolution, resolution); !s.ok()) {
    return s;
  }
  auto albedo_png = ReadFile(dir / "albedo_alpha.png");
  auto normal_depth_png = ReadFile(dir / "normal_depth.png");
  auto orm_png = ReadFile(dir / "orm.png");
  auto tangent_png = ReadFile(dir / kCardNormalTangentFile);
  for (const auto* r : {&albedo_png, &normal_depth_png, &orm_png, &tangent_png}) {
    if (!r->ok()) return r->status();
  }
  CardsGlbInput glb_input;
  glb_input.cards = cards;
  glb_input.tiles = packing->tiles;
  glb_input.atlas_size = resolution;
  glb_input.albedo_png = *albedo_png;
  glb_input.normal_png = *tangent_png;
  glb_input.orm_png = *orm_png;
  glb_input.generator = absl::StrCat("impostor cards baker ", std::string(BakerVersion()));
  auto glb = EncodeCardsGlb(glb_input);
  if (!glb.ok()) return glb.status();
  auto glb_digest = WriteFileWithDigest(dir / kCardsGlbFile, *glb);
  if (!glb_digest.ok()) return glb_digest.status();
  timings->set_encode_seconds(fit_seconds + SecondsSince(t));

  // Judge: the .glb as any viewer would load it, against the mesh.
  progress("encode", kJudgeStart);
  t = Clock::now();
  auto card_scene = LoadGltfScene(dir / kCardsGlbFile);
  if (!card_scene.ok()) {
    return absl::InternalError(absl::StrCat("cards.glb does not load back: ", card_scene.status().ToString()));
  }
  std::vector<glm::vec3> normals;
  for (const FittedPlane& plane : fit.planes) normals.push_back(plane.normal);
  auto quality = JudgeCards(*scene, *card_scene, sphere, normals, renderer);
  if (!quality.ok()) return quality.status();
  const double judge_seconds = SecondsSince(t);

  // Manifest.
  manifest.set_format_version(kManifestFormatVersion);
  manifest.set_cache_key(request.cache_key);
  manifest.set_baker_version(std::string(BakerVersion()));
  manifest.set_product(v1::PRODUCT_CARDS);
  manifest.set_layout(p.layout());  // unused by cards; kept valid for readers
  manifest.set_resolution(p.resolution());
  for (int i = 0; i < 3; ++i) manifest.mutable_bounding_sphere()->add_center(sphere.center[i]);
  manifest.mutable_bounding_sphere()->set_radius(sphere.radius);
  const auto res = static_cast<uint32_t>(resolution);
  AddMap(&manifest, "albedo_alpha", "albedo_alpha.png", "png_rgba8", DigestOf(*albedo_png), res, res, kAlbedoChannels);
  AddMap(&manifest, "normal_depth", "normal_depth.png", "png_rgba16", DigestOf(*normal_depth_png), res, res,
         kNormalDepthChannels);
  AddMap(&manifest, "orm", "orm.png", "png_rgba8", DigestOf(*orm_png), res, res, kOrmChannels);
  AddMap(&manifest, "normal_tangent", kCardNormalTangentFile, "png_rgba8", DigestOf(*tangent_png), res, res,
         kTangentChannels);
  AddMap(&manifest, "cards", kCardsGlbFile, "glb", *glb_digest, static_cast<uint32_t>(card_count), 1, kGlbChannels);

  v1::CardCluster* cc = manifest.mutable_cards();
  cc->set_file(kCardsGlbFile);
  *cc->mutable_digest() = *glb_digest;
  for (const FittedPlane& plane : fit.planes) {
    v1::CardPlane* out = cc->add_planes();
    for (int i = 0; i < 3; ++i) out->add_plane(plane.normal[i]);
    out->add_plane(plane.d);
  }
  for (uint32_t plane : fit.triangle_plane) cc->add_triangle_plane(plane);
  for (size_t c = 0; c < card_count; ++c) {
    v1::Card* card = cc->add_cards();
    for (const glm::vec3& corner : cards[c].Corners()) {
      for (int i = 0; i < 3; ++i) card->add_corners(corner[i]);
    }
    card->set_triangles(fit.planes[c].triangles);
    card->set_texels(capture->card_texels[c]);
    const TileRect& tile = packing->tiles[c];
    card->mutable_tile()->set_x(static_cast<uint32_t>(tile.x));
    card->mutable_tile()->set_y(static_cast<uint32_t>(tile.y));
    card->mutable_tile()->set_width(static_cast<uint32_t>(tile.width));
    card->mutable_tile()->set_height(static_cast<uint32_t>(tile.height));
    card->set_max_distance(fit.planes[c].max_distance);
    card->set_mean_distance(fit.planes[c].mean_distance);
  }
  cc->set_tolerance(fit_options.tolerance);
  cc->set_max_distance(fit.max_distance);
  cc->set_mean_distance(fit.mean_distance);
  cc->set_budget_exhausted(fit.budget_exhausted);
  cc->set_triangles(static_cast<uint32_t>(2 * card_count));
  v1::CardQuality* q = cc->mutable_quality();
  q->set_views(static_cast<uint32_t>(quality->views));
  q->set_silhouette_iou_mean(static_cast<float>(quality->iou_mean));
  q->set_silhouette_iou_min(static_cast<float>(quality->iou_min));
  q->set_albedo_psnr_db(static_cast<float>(quality->albedo_psnr_db));
  if (fit.budget_exhausted) {
    manifest.add_warnings(absl::StrCat("cards: ", p.max_planes(), " planes could not hold every triangle within ",
                                       fit_options.tolerance, " scene units; the rest went to their nearest plane "
                                       "(max distance ", fit.max_distance, ")"));
  }

  manifest.mutable_mesh()->set_triangles(triangle_count);
  manifest.mutable_mesh()->set_materials(static_cast<uint32_t>(scene->materials.size()));
  manifest.mutable_mesh()->set_textures(static_cast<uint32_t>(scene->textures.size()));
  manifest.set_device(renderer.device().name);
  timings->set_encode_seconds(timings->encode_seconds() + judge_seconds);
  timings->set_total_seconds(SecondsSince(start));

  absl::StatusOr<AtlasBakeOutput> out = WriteManifest(dir, std::move(manifest));
  if (!out.ok()) return out.status();
  progress("encode", kEnd);
  spdlog::info(
      "event=cards_bake_done cache_key={} triangles={} cards={} card_triangles={} tolerance={:.6g} "
      "max_distance={:.6g} budget_exhausted={} texels_per_unit={:.6g} iou_mean={:.4f} iou_min={:.4f} "
      "albedo_psnr_db={:.2f} seconds={:.2f}",
      request.cache_key, triangle_count, card_count, 2 * card_count, fit_options.tolerance, fit.max_distance,
      fit.budget_exhausted, packing->texels_per_unit, quality->iou_mean, quality->iou_min, quality->albedo_psnr_db,
      SecondsSince(start));
  return out;
}

}  // namespace impostor
