// Renders small synthetic scenes through the real Vulkan renderer (Mesa
// lavapipe suffices) and checks baked pixels against values computed on the
// CPU from the camera conventions in common/frame_camera.h.
#include "worker/gpu/atlas_renderer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "common/atlas/atlas_layout.h"
#include "common/atlas/frame_camera.h"
#include "worker/scene/scene.h"

namespace impostor {
namespace {

// ---------------------------------------------------------------- helpers

double SrgbToLinear(double c) {
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}
double LinearToSrgb(double c) {
  return c <= 0.0031308 ? c * 12.92 : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
}
// 8-bit sRGB code of a linear value, as an SRGB attachment stores it.
int SrgbByte(double linear) { return static_cast<int>(std::lround(LinearToSrgb(linear) * 255.0)); }
double Decode8Srgb(int byte) { return SrgbToLinear(byte / 255.0); }
int Unorm16(double v) { return static_cast<int>(std::lround(v * 65535.0)); }

struct Pixel {
  std::array<int, 4> albedo;
  std::array<int, 4> normal_depth;
  std::array<int, 4> orm;
};

Pixel At(const AtlasImages& img, int x, int y) {
  const size_t i = (static_cast<size_t>(y) * img.width + x) * 4;
  Pixel p;
  for (int c = 0; c < 4; ++c) {
    p.albedo[c] = img.albedo_alpha[i + c];
    p.normal_depth[c] = img.normal_depth[i + c];
    p.orm[c] = img.orm[i + c];
  }
  return p;
}

// Empty texel encodings from atlas_renderer.h.
::testing::AssertionResult IsEmpty(const AtlasImages& img, int x, int y) {
  const Pixel p = At(img, x, y);
  const bool ok =
      p.albedo == std::array<int, 4>{0, 0, 0, 0} && p.orm == std::array<int, 4>{0, 0, 0, 0} &&
      std::abs(p.normal_depth[0] - 32768) <= 1 && std::abs(p.normal_depth[1] - 32768) <= 1 &&
      std::abs(p.normal_depth[2] - 32768) <= 1 && p.normal_depth[3] == 65535;
  if (ok) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << "texel (" << x << ", " << y << ") not empty: albedo " << p.albedo[0] << ","
         << p.albedo[1] << "," << p.albedo[2] << "," << p.albedo[3] << " normal_depth "
         << p.normal_depth[0] << "," << p.normal_depth[1] << "," << p.normal_depth[2] << ","
         << p.normal_depth[3] << " orm " << p.orm[0] << "," << p.orm[1] << "," << p.orm[2] << ","
         << p.orm[3];
}

::testing::AssertionResult Near(const char* what, int x, int y, int actual, int expected,
                                int tolerance) {
  if (std::abs(actual - expected) <= tolerance) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << what << " at (" << x << ", " << y << ") is " << actual
                                       << ", expected " << expected << " +- " << tolerance;
}

// Encoded normal (n * 0.5 + 0.5 in UNORM16).
void ExpectNormal(const AtlasImages& img, int x, int y, glm::vec3 n, int tolerance = 100) {
  const Pixel p = At(img, x, y);
  for (int c = 0; c < 3; ++c) {
    EXPECT_TRUE(Near("normal", x, y, p.normal_depth[c], Unorm16(n[c] * 0.5 + 0.5), tolerance));
  }
}

// Pixel centre of tile pixel (px, py) -> frame-plane coordinates s, t.
glm::vec2 TileST(const TileRect& tile, double px, double py) {
  const double s = (px - tile.x) / tile.width * 2.0 - 1.0;
  const double t = 1.0 - (py - tile.y) / tile.height * 2.0;
  return {static_cast<float>(s), static_cast<float>(t)};
}

// Depth of scene point p, normalised to the sphere (frame_camera.h).
double DepthOf(glm::vec3 p, const FrameCamera& cam, const BoundingSphere& sphere) {
  return (1.0 - glm::dot(p - sphere.center, cam.direction) / sphere.radius) / 2.0;
}

const FrameCamera* FindCamera(const std::vector<FrameCamera>& cameras, glm::vec3 direction) {
  for (const FrameCamera& c : cameras) {
    if (glm::dot(c.direction, direction) > 0.9999f) return &c;
  }
  return nullptr;
}

// ------------------------------------------------------------ scene builders

int AddMaterial(Scene& scene, glm::vec4 factor, bool double_sided = false) {
  SceneMaterial m;
  m.base_color_factor = factor;
  m.double_sided = double_sided;
  m.metallic_factor = 0.25f;
  m.roughness_factor = 0.75f;
  scene.materials.push_back(m);
  return static_cast<int>(scene.materials.size()) - 1;
}

// A parallelogram centred at `center` spanning +-u, +-v, facing cross(u, v)
// with counter-clockwise triangles seen from that side (glTF front faces)
// unless `reverse_winding`. uv (0,0) is the (-u, +v) corner, v grows toward
// -v, as a glTF image's top row maps to v = 0.
void AddQuad(Scene& scene, glm::vec3 center, glm::vec3 u, glm::vec3 v, int material,
             bool reverse_winding = false, bool flipped_winding = false) {
  const glm::vec3 n = glm::normalize(glm::cross(u, v));
  const uint32_t base = static_cast<uint32_t>(scene.vertices.size());
  const std::array<glm::vec2, 4> corners = {{{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}};
  for (glm::vec2 c : corners) {
    SceneVertex vert;
    vert.position = center + c.x * u + c.y * v;
    vert.normal = n;
    vert.tangent = glm::vec4(glm::normalize(u), 1.0f);
    vert.uv = {(c.x + 1) / 2, (1 - c.y) / 2};
    scene.vertices.push_back(vert);
    scene.bounds_min = glm::min(scene.bounds_min, vert.position);
    scene.bounds_max = glm::max(scene.bounds_max, vert.position);
  }
  SceneBatch batch;
  batch.first_index = static_cast<uint32_t>(scene.indices.size());
  batch.index_count = 6;
  batch.material = material;
  batch.flipped_winding = flipped_winding;
  const std::array<uint32_t, 6> ccw = {0, 1, 2, 0, 2, 3};
  const std::array<uint32_t, 6> cw = {0, 2, 1, 0, 3, 2};
  for (uint32_t i : reverse_winding ? cw : ccw) scene.indices.push_back(base + i);
  scene.batches.push_back(batch);
}

// Unit cube [-0.5, 0.5]^3, one material (and colour) per face.
struct CubeFace {
  glm::vec3 normal;
  glm::vec4 color;  // linear base colour factor
};
const std::array<CubeFace, 6> kCubeFaces = {{
    {{1, 0, 0}, {1.0f, 0.0f, 0.0f, 1}},
    {{-1, 0, 0}, {0.0f, 1.0f, 0.0f, 1}},
    {{0, 1, 0}, {0.0f, 0.0f, 1.0f, 1}},
    {{0, -1, 0}, {1.0f, 1.0f, 0.0f, 1}},
    {{0, 0, 1}, {0.5f, 0.5f, 0.5f, 1}},
    {{0, 0, -1}, {0.0f, 0.25f, 1.0f, 1}},
}};

Scene MakeCube() {
  Scene scene;
  for (const CubeFace& f : kCubeFaces) {
    const int m = AddMaterial(scene, f.color);
    const glm::vec3 helper = std::abs(f.normal.y) > 0.5f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    const glm::vec3 u = glm::cross(helper, f.normal);  // in-plane
    const glm::vec3 v = glm::cross(f.normal, u);       // u x v = normal
    AddQuad(scene, f.normal * 0.5f, u * 0.5f, v * 0.5f, m);
  }
  return scene;
}

// Quad in the z = 0 plane, |x|, |y| <= 0.5, front face toward +Z.
Scene MakeQuad(SceneMaterial material, bool reverse_winding = false, bool flipped = false) {
  Scene scene;
  scene.materials.push_back(material);
  AddQuad(scene, {0, 0, 0}, {0.5f, 0, 0}, {0, 0.5f, 0}, 0, reverse_winding, flipped);
  return scene;
}

SceneTexture MakeTexture(int w, int h, bool srgb, int wrap,
                         const std::function<std::array<uint8_t, 4>(int, int)>& texel) {
  SceneTexture t;
  t.width = w;
  t.height = h;
  t.srgb = srgb;
  t.wrap_s = t.wrap_t = wrap;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (uint8_t c : texel(x, y)) t.rgba8.push_back(c);
    }
  }
  return t;
}

constexpr int kClampToEdge = 33071;
constexpr int kRepeat = 10497;

// ---------------------------------------------------------------- fixture

class AtlasRendererTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    absl::StatusOr<std::unique_ptr<AtlasRenderer>> r = AtlasRenderer::Create();
    if (r.ok()) {
      renderer_ = std::move(*r).release();
    } else {
      create_error_ = new std::string(r.status().ToString());
    }
  }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
    delete create_error_;
    create_error_ = nullptr;
  }
  void SetUp() override {
    ASSERT_NE(renderer_, nullptr) << "AtlasRenderer::Create failed: "
                                  << (create_error_ ? *create_error_ : "");
  }

  static AtlasImages RenderOk(const Scene& scene, const BoundingSphere& sphere,
                              const std::vector<FrameCamera>& cameras, int atlas,
                              RenderTimings* timings = nullptr,
                              const std::function<void(double)>& progress = {}) {
    absl::StatusOr<AtlasImages> images =
        renderer_->Render(scene, sphere, cameras, atlas, progress, timings);
    EXPECT_TRUE(images.ok()) << images.status();
    if (!images.ok()) return {};
    EXPECT_EQ(images->width, atlas);
    EXPECT_EQ(images->height, atlas);
    EXPECT_EQ(images->albedo_alpha.size(), static_cast<size_t>(atlas) * atlas * 4);
    EXPECT_EQ(images->normal_depth.size(), static_cast<size_t>(atlas) * atlas * 4);
    EXPECT_EQ(images->orm.size(), static_cast<size_t>(atlas) * atlas * 4);
    return *std::move(images);
  }

  static AtlasRenderer* renderer_;
  static std::string* create_error_;
};

AtlasRenderer* AtlasRendererTest::renderer_ = nullptr;
std::string* AtlasRendererTest::create_error_ = nullptr;

// Quad scenes: sphere of radius 0.75 around the origin, 3x3 octahedral
// frames of 64 px, which include the +Z and -Z horizon views.
constexpr int kQuadFrames = 3;
constexpr int kQuadAtlas = 192;
const BoundingSphere kQuadSphere{{0, 0, 0}, 0.75f};

std::vector<FrameCamera> QuadCameras() {
  return AtlasCameras(LayoutKind::kOctahedral, kQuadFrames, kQuadAtlas);
}

// Tile pixel of scene point (x, y, 0) seen from camera `cam`.
glm::ivec2 QuadPixel(const FrameCamera& cam, float x, float y) {
  const glm::vec3 p(x, y, 0);
  const float s = glm::dot(p - kQuadSphere.center, cam.right) / kQuadSphere.radius;
  const float t = glm::dot(p - kQuadSphere.center, cam.up) / kQuadSphere.radius;
  return {static_cast<int>(std::floor(cam.tile.x + (s + 1) / 2 * cam.tile.width)),
          static_cast<int>(std::floor(cam.tile.y + (1 - t) / 2 * cam.tile.height))};
}

// Every texel of the tile whose centre lies inside the quad's region
// |x|,|y| <= extent (shrunk by a pixel for rasterisation edges).
template <typename Fn>
void ForQuadInterior(const FrameCamera& cam, float x0, float x1, float y0, float y1, Fn fn) {
  const int tile = cam.tile.width;
  for (int py = cam.tile.y; py < cam.tile.y + tile; ++py) {
    for (int px = cam.tile.x; px < cam.tile.x + tile; ++px) {
      const glm::vec2 st = TileST(cam.tile, px + 0.5, py + 0.5);
      const glm::vec3 p =
          kQuadSphere.center + kQuadSphere.radius * (st.x * cam.right + st.y * cam.up);
      const float margin = 1.5f * 2 * kQuadSphere.radius / tile;
      if (p.x > x0 + margin && p.x < x1 - margin && p.y > y0 + margin && p.y < y1 - margin) {
        fn(px, py);
      }
    }
  }
}

void ExpectTileEmpty(const AtlasImages& img, const FrameCamera& cam) {
  int bad = 0;
  for (int py = cam.tile.y; py < cam.tile.y + cam.tile.height; ++py) {
    for (int px = cam.tile.x; px < cam.tile.x + cam.tile.width; ++px) {
      if (!IsEmpty(img, px, py) && ++bad <= 3) {
        ADD_FAILURE() << "frame " << cam.index << ": " << IsEmpty(img, px, py).message();
      }
    }
  }
  EXPECT_EQ(bad, 0) << "frame " << cam.index << " should be empty";
}

// ------------------------------------------------------------------ tests

TEST_F(AtlasRendererTest, ReportsAVulkan13Device) {
  const DeviceInfo& info = renderer_->device();
  EXPECT_FALSE(info.name.empty());
  EXPECT_GE(info.api_version, (1u << 22) | (3u << 12));  // VK_API_VERSION_1_3
  EXPECT_TRUE(info.type == "discrete" || info.type == "integrated" || info.type == "virtual" ||
              info.type == "cpu" || info.type == "other")
      << info.type;
}

struct CubeCase {
  LayoutKind layout;
  int frames;
  int atlas;  // not a multiple of frames: the leftover border must stay empty
};
void PrintTo(const CubeCase& c, std::ostream* os) {
  *os << LayoutName(c.layout) << " " << c.frames << "x" << c.frames << " in " << c.atlas;
}

class CubeTest : public AtlasRendererTest, public ::testing::WithParamInterface<CubeCase> {};

// For every frame and every texel, traces the texel centre against the cube
// on the CPU: texels well inside one face must carry that face's colour,
// normal, depth and ORM; texels well outside must be empty. Texels within
// half a pixel of an edge are skipped.
TEST_P(CubeTest, EveryTexelMatchesCpuRayTrace) {
  const CubeCase param = GetParam();
  const Scene scene = MakeCube();
  const BoundingSphere sphere{{0, 0, 0}, std::sqrt(3.0f) / 2};
  const std::vector<FrameCamera> cameras = AtlasCameras(param.layout, param.frames, param.atlas);
  std::vector<double> progress;
  RenderTimings timings;
  const AtlasImages img = RenderOk(scene, sphere, cameras, param.atlas, &timings,
                                   [&](double f) { progress.push_back(f); });
  ASSERT_FALSE(img.albedo_alpha.empty());
  ASSERT_FALSE(progress.empty());
  EXPECT_DOUBLE_EQ(progress.back(), 1.0);
  EXPECT_TRUE(std::is_sorted(progress.begin(), progress.end()));
  EXPECT_GT(timings.render_seconds, 0.0);
  EXPECT_GT(timings.upload_seconds, 0.0);
  EXPECT_GT(timings.readback_seconds, 0.0);

  // Ray from texel centre (s, t) along -direction: the face it enters first.
  auto trace = [&](const FrameCamera& cam, glm::vec2 st, glm::vec3* hit) -> int {
    const glm::vec3 origin =
        sphere.center + sphere.radius * (st.x * cam.right + st.y * cam.up + cam.direction);
    const glm::vec3 dir = -cam.direction;
    double t_enter = -1e30, t_exit = 1e30;
    int face = -1;
    for (int axis = 0; axis < 3; ++axis) {
      if (std::abs(dir[axis]) < 1e-9) {
        if (std::abs(origin[axis]) > 0.5) return -1;
        continue;
      }
      double t0 = (-0.5 - origin[axis]) / dir[axis];
      double t1 = (0.5 - origin[axis]) / dir[axis];
      // Entering through the face whose outward normal opposes the ray.
      int enter_face = dir[axis] > 0 ? 2 * axis + 1 : 2 * axis;  // -axis : +axis
      if (t0 > t1) std::swap(t0, t1);
      if (t0 > t_enter) {
        t_enter = t0;
        face = enter_face;
      }
      t_exit = std::min(t_exit, t1);
    }
    if (t_enter > t_exit) return -1;
    *hit = origin + static_cast<float>(t_enter) * dir;
    return face;
  };

  int checked_inside = 0, checked_outside = 0, failures = 0;
  for (const FrameCamera& cam : cameras) {
    for (int py = cam.tile.y; py < cam.tile.y + cam.tile.height; ++py) {
      for (int px = cam.tile.x; px < cam.tile.x + cam.tile.width; ++px) {
        glm::vec3 hit;
        const int face = trace(cam, TileST(cam.tile, px + 0.5, py + 0.5), &hit);
        bool robust = true;
        for (glm::vec2 o : {glm::vec2(-0.6f, -0.6f), glm::vec2(0.6f, -0.6f), glm::vec2(-0.6f, 0.6f),
                            glm::vec2(0.6f, 0.6f)}) {
          glm::vec3 unused;
          if (trace(cam, TileST(cam.tile, px + 0.5 + o.x, py + 0.5 + o.y), &unused) != face) {
            robust = false;
          }
        }
        if (!robust) continue;
        if (failures > 10) continue;  // keep the log readable
        if (face < 0) {
          ++checked_outside;
          const auto r = IsEmpty(img, px, py);
          if (!r) {
            ++failures;
            ADD_FAILURE() << "frame " << cam.index << ": " << r.message();
          }
          continue;
        }
        ++checked_inside;
        // Faces are stored +X,-X,+Y,-Y,+Z,-Z, as `face` numbers them.
        const CubeFace& f = kCubeFaces[face];
        const Pixel p = At(img, px, py);
        std::vector<::testing::AssertionResult> checks;
        for (int c = 0; c < 3; ++c) {
          checks.push_back(Near("albedo", px, py, p.albedo[c], SrgbByte(f.color[c]), 2));
          checks.push_back(
              Near("normal", px, py, p.normal_depth[c], Unorm16(f.normal[c] * 0.5 + 0.5), 100));
        }
        checks.push_back(Near("coverage", px, py, p.albedo[3], 255, 0));
        checks.push_back(
            Near("depth", px, py, p.normal_depth[3], Unorm16(DepthOf(hit, cam, sphere)), 80));
        checks.push_back(Near("occlusion", px, py, p.orm[0], 255, 0));
        checks.push_back(Near("roughness", px, py, p.orm[1], 191, 1));
        checks.push_back(Near("metalness", px, py, p.orm[2], 64, 1));
        checks.push_back(Near("orm coverage", px, py, p.orm[3], 255, 0));
        for (const auto& check : checks) {
          if (!check) {
            ++failures;
            ADD_FAILURE() << "frame " << cam.index << " face " << face << ": " << check.message();
          }
        }
      }
    }
  }
  EXPECT_EQ(failures, 0);
  // Sanity: the trace saw plenty of both kinds of texel.
  EXPECT_GT(checked_inside, static_cast<int>(cameras.size()) * 200);
  EXPECT_GT(checked_outside, static_cast<int>(cameras.size()) * 200);

  // The border beyond the last tile (atlas % frames) is never drawn.
  const int used = TileSize(param.atlas, param.frames) * param.frames;
  ASSERT_LT(used, param.atlas);
  for (int y = 0; y < param.atlas; ++y) {
    for (int x = used; x < param.atlas; ++x) ASSERT_TRUE(IsEmpty(img, x, y));
  }
  for (int y = used; y < param.atlas; ++y) {
    for (int x = 0; x < param.atlas; ++x) ASSERT_TRUE(IsEmpty(img, x, y));
  }
}

INSTANTIATE_TEST_SUITE_P(Layouts, CubeTest,
                         ::testing::Values(
                             // 9 frames: one submission; includes the six axis views.
                             CubeCase{LayoutKind::kOctahedral, 3, 200},
                             // 25 frames: two submissions, so chunk 2 must load chunk 1's tiles.
                             CubeCase{LayoutKind::kHemiOctahedral, 5, 243}),
                         [](const ::testing::TestParamInfo<CubeCase>& info) {
                           return std::string(info.param.layout == LayoutKind::kOctahedral
                                                  ? "Octahedral"
                                                  : "HemiOctahedral") +
                                  std::to_string(info.param.frames);
                         });

TEST_F(AtlasRendererTest, HeadOnFaceHasExactNormalAndDepth) {
  SceneMaterial m;
  m.base_color_factor = {0.2f, 0.4f, 0.6f, 1.0f};
  const Scene scene = MakeQuad(m);
  const std::vector<FrameCamera> cameras = QuadCameras();
  const FrameCamera* front = FindCamera(cameras, {0, 0, 1});
  ASSERT_NE(front, nullptr);
  const AtlasImages img = RenderOk(scene, kQuadSphere, cameras, kQuadAtlas);
  ASSERT_FALSE(img.albedo_alpha.empty());

  // The quad's centre lands on the tile's centre.
  const glm::ivec2 centre = QuadPixel(*front, 0.01f, 0.01f);
  EXPECT_EQ(centre.x, front->tile.x + front->tile.width / 2);
  int count = 0;
  ForQuadInterior(*front, -0.5f, 0.5f, -0.5f, 0.5f, [&](int x, int y) {
    ++count;
    const Pixel p = At(img, x, y);
    EXPECT_EQ(p.albedo[3], 255);
    EXPECT_TRUE(Near("r", x, y, p.albedo[0], SrgbByte(0.2), 2));
    EXPECT_TRUE(Near("g", x, y, p.albedo[1], SrgbByte(0.4), 2));
    EXPECT_TRUE(Near("b", x, y, p.albedo[2], SrgbByte(0.6), 2));
    // +Z face from the +Z camera: (0.5, 0.5, 1.0) * 65535, depth 0.5.
    ExpectNormal(img, x, y, {0, 0, 1}, 2);
    EXPECT_TRUE(Near("depth", x, y, p.normal_depth[3], 32768, 2));
    // Default material without textures: occlusion 1, roughness 1, metal 1.
    EXPECT_EQ(p.orm, (std::array<int, 4>{255, 255, 255, 255}));
  });
  EXPECT_GT(count, 30 * 30);
  // Just outside the quad's edges: empty.
  const glm::ivec2 left = QuadPixel(*front, -0.55f, 0.0f);
  const glm::ivec2 top = QuadPixel(*front, 0.0f, 0.55f);
  EXPECT_TRUE(IsEmpty(img, left.x, left.y));
  EXPECT_TRUE(IsEmpty(img, top.x, top.y));
  // +Y is up: the quad's top edge is at a smaller row than its bottom edge.
  EXPECT_LT(QuadPixel(*front, 0, 0.4f).y, QuadPixel(*front, 0, -0.4f).y);
}

TEST_F(AtlasRendererTest, SingleSidedQuadIsCulledFromBehind) {
  SceneMaterial m;
  const Scene scene = MakeQuad(m);
  const std::vector<FrameCamera> cameras = QuadCameras();
  const FrameCamera* back = FindCamera(cameras, {0, 0, -1});
  ASSERT_NE(back, nullptr);
  const AtlasImages img = RenderOk(scene, kQuadSphere, cameras, kQuadAtlas);
  ASSERT_FALSE(img.albedo_alpha.empty());
  ExpectTileEmpty(img, *back);
}

TEST_F(AtlasRendererTest, DoubleSidedQuadShowsItsBackWithFlippedNormal) {
  SceneMaterial m;
  m.double_sided = true;
  m.base_color_factor = {1.0f, 0.5f, 0.0f, 1.0f};
  const Scene scene = MakeQuad(m);
  const std::vector<FrameCamera> cameras = QuadCameras();
  const FrameCamera* back = FindCamera(cameras, {0, 0, -1});
  const FrameCamera* front = FindCamera(cameras, {0, 0, 1});
  ASSERT_NE(back, nullptr);
  ASSERT_NE(front, nullptr);
  const AtlasImages img = RenderOk(scene, kQuadSphere, cameras, kQuadAtlas);
  ASSERT_FALSE(img.albedo_alpha.empty());
  int count = 0;
  ForQuadInterior(*back, -0.5f, 0.5f, -0.5f, 0.5f, [&](int x, int y) {
    ++count;
    const Pixel p = At(img, x, y);
    EXPECT_EQ(p.albedo[3], 255);
    EXPECT_TRUE(Near("g", x, y, p.albedo[1], SrgbByte(0.5), 2));
    ExpectNormal(img, x, y, {0, 0, -1}, 2);
    EXPECT_TRUE(Near("depth", x, y, p.normal_depth[3], 32768, 2));
  });
  EXPECT_GT(count, 30 * 30);
  ForQuadInterior(*front, -0.5f, 0.5f, -0.5f, 0.5f, [&](int x, int y) {
    ExpectNormal(img, x, y, {0, 0, 1}, 2);
  });
}

// Triangles wound clockwise (as a mirroring node transform leaves them):
// with flipped_winding the +Z side is still the front; without it, the
// clockwise triangles face -Z. Either way exactly one side is drawn.
TEST_F(AtlasRendererTest, FlippedWindingSelectsTheFrontFace) {
  SceneMaterial m;
  const std::vector<FrameCamera> cameras = QuadCameras();
  const FrameCamera* back = FindCamera(cameras, {0, 0, -1});
  const FrameCamera* front = FindCamera(cameras, {0, 0, 1});
  ASSERT_NE(back, nullptr);
  ASSERT_NE(front, nullptr);

  const AtlasImages flipped = RenderOk(MakeQuad(m, /*reverse_winding=*/true, /*flipped=*/true),
                                       kQuadSphere, cameras, kQuadAtlas);
  ASSERT_FALSE(flipped.albedo_alpha.empty());
  int count = 0;
  ForQuadInterior(*front, -0.5f, 0.5f, -0.5f, 0.5f, [&](int x, int y) {
    ++count;
    EXPECT_EQ(At(flipped, x, y).albedo[3], 255);
    ExpectNormal(flipped, x, y, {0, 0, 1}, 2);
  });
  EXPECT_GT(count, 30 * 30);
  ExpectTileEmpty(flipped, *back);

  const AtlasImages unflagged = RenderOk(MakeQuad(m, /*reverse_winding=*/true, /*flipped=*/false),
                                         kQuadSphere, cameras, kQuadAtlas);
  ASSERT_FALSE(unflagged.albedo_alpha.empty());
  ExpectTileEmpty(unflagged, *front);
  ForQuadInterior(*back, -0.5f, 0.5f, -0.5f, 0.5f,
                  [&](int x, int y) { EXPECT_EQ(At(unflagged, x, y).albedo[3], 255); });
}

}  // namespace
// gtest prints parameters through PrintTo found by ADL in AlphaMode's namespace.
void PrintTo(AlphaMode mode, std::ostream* os) {
  *os << (mode == AlphaMode::kMask ? "MASK" : mode == AlphaMode::kBlend ? "BLEND" : "OPAQUE");
}
namespace {

class AlphaCutoutTest : public AtlasRendererTest,
                        public ::testing::WithParamInterface<AlphaMode> {};

// Texture: left half alpha 0, right half alpha 255; texels well inside the
// transparent half are empty in every map, the opaque half carries the
// texture colour times the factor (multiplied in linear light).
TEST_P(AlphaCutoutTest, TransparentHalfIsCutOut) {
  Scene scene;
  SceneMaterial m;
  m.alpha_mode = GetParam();
  m.alpha_cutoff = 0.5f;
  m.base_color_factor = {0.5f, 1.0f, 1.0f, 1.0f};
  m.base_color_texture = 0;
  scene = MakeQuad(m);
  scene.textures.push_back(MakeTexture(4, 4, /*srgb=*/true, kClampToEdge, [](int x, int) {
    return std::array<uint8_t, 4>{128, 64, 200, static_cast<uint8_t>(x < 2 ? 0 : 255)};
  }));
  const std::vector<FrameCamera> cameras = QuadCameras();
  const FrameCamera* front = FindCamera(cameras, {0, 0, 1});
  ASSERT_NE(front, nullptr);
  const AtlasImages img = RenderOk(scene, kQuadSphere, cameras, kQuadAtlas);
  ASSERT_FALSE(img.albedo_alpha.empty());

  int cut = 0, kept = 0;
  ForQuadInterior(*front, -0.5f, -0.1f, -0.5f, 0.5f, [&](int x, int y) {
    ++cut;
    EXPECT_TRUE(IsEmpty(img, x, y));
  });
  ForQuadInterior(*front, 0.1f, 0.5f, -0.5f, 0.5f, [&](int x, int y) {
    ++kept;
    const Pixel p = At(img, x, y);
    EXPECT_EQ(p.albedo[3], 255);
    EXPECT_EQ(p.orm[3], 255);
    EXPECT_TRUE(Near("r", x, y, p.albedo[0], SrgbByte(0.5 * Decode8Srgb(128)), 2));
    EXPECT_TRUE(Near("g", x, y, p.albedo[1], 64, 2));
    EXPECT_TRUE(Near("b", x, y, p.albedo[2], 200, 2));
  });
  EXPECT_GT(cut, 300);
  EXPECT_GT(kept, 300);
}

INSTANTIATE_TEST_SUITE_P(MaskAndBlend, AlphaCutoutTest,
                         ::testing::Values(AlphaMode::kMask, AlphaMode::kBlend),
                         [](const ::testing::TestParamInfo<AlphaMode>& info) {
                           return info.param == AlphaMode::kMask ? "Mask" : "Blend";
                         });

TEST_F(AtlasRendererTest, NormalMapOcclusionAndMetalRoughTexturesApply) {
  SceneMaterial m;
  m.normal_texture = 0;
  m.normal_scale = 0.5f;
  m.metallic_roughness_texture = 1;
  m.roughness_factor = 0.5f;
  m.metallic_factor = 1.0f;
  m.occlusion_texture = 2;
  m.occlusion_strength = 0.5f;
  Scene scene = MakeQuad(m);
  const std::array<uint8_t, 4> normal_texel = {218, 60, 218, 255};
  scene.textures.push_back(
      MakeTexture(2, 2, false, kRepeat, [&](int, int) { return normal_texel; }));
  scene.textures.push_back(MakeTexture(2, 2, false, kRepeat, [](int, int) {
    return std::array<uint8_t, 4>{0, 128, 255, 255};
  }));
  scene.textures.push_back(MakeTexture(2, 2, false, kRepeat, [](int, int) {
    return std::array<uint8_t, 4>{128, 0, 0, 255};
  }));
  const std::vector<FrameCamera> cameras = QuadCameras();
  const FrameCamera* front = FindCamera(cameras, {0, 0, 1});
  ASSERT_NE(front, nullptr);
  const AtlasImages img = RenderOk(scene, kQuadSphere, cameras, kQuadAtlas);
  ASSERT_FALSE(img.albedo_alpha.empty());

  // glTF: n = normalize(T * x + B * y + N * z), B = cross(N, T) * w, with
  // (x, y) scaled by normal_scale. Here T = +X, N = +Z, so B = +Y.
  glm::vec3 tn(normal_texel[0] / 255.0f * 2 - 1, normal_texel[1] / 255.0f * 2 - 1,
               normal_texel[2] / 255.0f * 2 - 1);
  tn.x *= 0.5f;
  tn.y *= 0.5f;
  const glm::vec3 expected = glm::normalize(tn);  // TBN is the identity here
  ASSERT_LT(expected.y, -0.1f);                   // the map really tilts toward -B
  int count = 0;
  ForQuadInterior(*front, -0.5f, 0.5f, -0.5f, 0.5f, [&](int x, int y) {
    ++count;
    ExpectNormal(img, x, y, expected, 200);
    const Pixel p = At(img, x, y);
    EXPECT_TRUE(Near("occlusion", x, y, p.orm[0], 191, 1));  // 1 + 0.5 * (128/255 - 1)
    EXPECT_TRUE(Near("roughness", x, y, p.orm[1], 64, 1));   // 0.5 * 128/255
    EXPECT_TRUE(Near("metalness", x, y, p.orm[2], 255, 0));
    EXPECT_EQ(p.orm[3], 255);
  });
  EXPECT_GT(count, 30 * 30);
}

// A 1-texel black/white checkerboard seen at about 3 texels per pixel:
// sampled from a mip chain, every texel is close to the linear average
// (0.5, sRGB 188); sampled from level 0 alone it would alias to a mix of
// near-black and near-white texels.
TEST_F(AtlasRendererTest, MinifiedTexturesAreMipmapped) {
  SceneMaterial m;
  m.base_color_texture = 0;
  Scene scene = MakeQuad(m);
  scene.textures.push_back(MakeTexture(64, 64, /*srgb=*/true, kRepeat, [](int x, int y) {
    const uint8_t v = (x + y) % 2 ? 255 : 0;
    return std::array<uint8_t, 4>{v, v, v, 255};
  }));
  const int atlas = 96;  // 32 px tiles: the quad spans ~21 px
  const std::vector<FrameCamera> cameras = AtlasCameras(LayoutKind::kOctahedral, 3, atlas);
  const FrameCamera* front = FindCamera(cameras, {0, 0, 1});
  ASSERT_NE(front, nullptr);
  const AtlasImages img = RenderOk(scene, kQuadSphere, cameras, atlas);
  ASSERT_FALSE(img.albedo_alpha.empty());
  int count = 0;
  ForQuadInterior(*front, -0.5f, 0.5f, -0.5f, 0.5f, [&](int x, int y) {
    ++count;
    EXPECT_TRUE(Near("filtered grey", x, y, At(img, x, y).albedo[0], SrgbByte(0.5), 12));
  });
  EXPECT_GT(count, 100);
}

// KeepSceneUploaded: a kept upload serves only the scene object it was made
// for and only with the texture filter it was made with; every render equals
// one from a fresh upload. A 1-texel checkerboard at 1.5 texels per pixel
// tells the filters apart: the supersampled bake's sharper mip bias keeps
// more of the checker's contrast than anisotropic filtering does.
TEST_F(AtlasRendererTest, AKeptUploadRendersWhatAFreshUploadRenders) {
  SceneMaterial m;
  m.base_color_texture = 0;
  Scene checker = MakeQuad(m);
  checker.textures.push_back(MakeTexture(64, 64, /*srgb=*/true, kRepeat, [](int x, int y) {
    const uint8_t v = (x + y) % 2 ? 255 : 0;
    return std::array<uint8_t, 4>{v, v, v, 255};
  }));
  const Scene cube = MakeCube();
  const std::vector<FrameCamera> cameras = QuadCameras();
  const auto render = [&](const Scene& scene, int supersampling) {
    renderer_->set_supersampling(supersampling);
    AtlasImages img = RenderOk(scene, kQuadSphere, cameras, kQuadAtlas);
    renderer_->set_supersampling(1);
    return img;
  };
  const AtlasImages fresh_checker = render(checker, 1);
  const AtlasImages fresh_checker_sharp = render(checker, 2);
  const AtlasImages fresh_cube = render(cube, 1);
  ASSERT_FALSE(fresh_checker.albedo_alpha.empty());
  // The two filters differ on this texture, so reusing the wrong one shows.
  ASSERT_NE(fresh_checker.albedo_alpha, fresh_checker_sharp.albedo_alpha);
  ASSERT_NE(fresh_checker.albedo_alpha, fresh_cube.albedo_alpha);

  {
    const ScopedKeptScene kept(*renderer_, checker);
    EXPECT_EQ(render(checker, 1).albedo_alpha, fresh_checker.albedo_alpha);  // makes the upload
    EXPECT_EQ(render(checker, 1).albedo_alpha, fresh_checker.albedo_alpha);  // reuses it
    EXPECT_EQ(render(cube, 1).albedo_alpha, fresh_cube.albedo_alpha);        // another scene
    EXPECT_EQ(render(checker, 2).albedo_alpha, fresh_checker_sharp.albedo_alpha);  // another filter
    EXPECT_EQ(render(checker, 1).albedo_alpha, fresh_checker.albedo_alpha);
  }
  EXPECT_EQ(render(checker, 1).albedo_alpha, fresh_checker.albedo_alpha);  // freed, fresh again
}

TEST_F(AtlasRendererTest, RejectsInvalidRequests) {
  SceneMaterial m;
  const Scene scene = MakeQuad(m);
  const auto expect_invalid = [&](const Scene& s, const std::vector<FrameCamera>& cams, int atlas,
                                  const std::string& needle) {
    absl::StatusOr<AtlasImages> r = renderer_->Render(s, kQuadSphere, cams, atlas, {}, nullptr);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << r.status();
    EXPECT_NE(r.status().message().find(needle), std::string::npos) << r.status();
  };
  // Larger than any device's maxImageDimension2D; the message names both.
  const int huge = 1 << 20;
  expect_invalid(scene, AtlasCameras(LayoutKind::kOctahedral, 2, huge), huge, "1048576");
  expect_invalid(scene, AtlasCameras(LayoutKind::kOctahedral, 2, huge), huge,
                 "maxImageDimension2D");
  expect_invalid(scene, {}, 64, "no cameras");
  expect_invalid(scene, AtlasCameras(LayoutKind::kOctahedral, 2, 256), 128, "outside");
  expect_invalid(scene, AtlasCameras(LayoutKind::kOctahedral, 2, 64), 0, "atlas size 0");
  expect_invalid(Scene{}, AtlasCameras(LayoutKind::kOctahedral, 2, 64), 64, "empty scene");
  Scene bad_material = scene;
  bad_material.batches[0].material = 7;
  expect_invalid(bad_material, AtlasCameras(LayoutKind::kOctahedral, 2, 64), 64, "material 7");
  Scene bad_texture = scene;
  bad_texture.materials[0].base_color_texture = 3;
  expect_invalid(bad_texture, AtlasCameras(LayoutKind::kOctahedral, 2, 64), 64, "texture 3");

  // The renderer still works after rejecting requests.
  const AtlasImages img = RenderOk(scene, kQuadSphere, QuadCameras(), kQuadAtlas);
  EXPECT_FALSE(img.albedo_alpha.empty());
}

}  // namespace
}  // namespace impostor
