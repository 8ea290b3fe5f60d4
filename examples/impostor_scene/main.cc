// impostor_example_scene: renders a glTF mesh next to its baked impostor on a
// ground plane under one directional light with shadows, to a PNG, with
// Vulkan (lavapipe works). What an engine integrator copies: how the
// reference material (shaders/impostor_material*.{glsl,frag}) is fed.
//
//   impostor bake Model.glb --out result/          # PNG maps (the default)
//   impostor_example_scene --result result/ --mesh Model.glb --out scene.png [--size 512]
//
// Exit status 0 on success, 1 on a bad input or a rendering failure (the
// message names what is wrong), 2 on a usage error.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "examples/impostor_scene/baked_impostor.h"
#include "examples/impostor_scene/scene_renderer.h"
#include "worker/output/map_writer.h"
#include "worker/scene/gltf_loader.h"

namespace {

constexpr const char* kUsage =
    "usage: impostor_example_scene --result DIR --mesh FILE.glb --out FILE.png [--size PIXELS] [--device NAME] "
    "[--no-depth-offset]\n"
    "  --result   a baked atlas result directory (manifest.json and PNG maps)\n"
    "  --mesh     the glTF the result was baked from\n"
    "  --size     image width and height, 16..4096 (default 512)\n"
    "  --no-depth-offset  draw the impostor at its card's depth (shows what the offset fixes)\n";

int Fail(const std::string& what) {
  std::fprintf(stderr, "impostor_example_scene: %s\n", what.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  std::string result, mesh_file, out, device;
  int size = 512;
  bool depth_offset = true;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--result" && has_value) {
      result = argv[++i];
    } else if (arg == "--mesh" && has_value) {
      mesh_file = argv[++i];
    } else if (arg == "--out" && has_value) {
      out = argv[++i];
    } else if (arg == "--device" && has_value) {
      device = argv[++i];
    } else if (arg == "--size" && has_value) {
      char* end = nullptr;
      const long v = std::strtol(argv[++i], &end, 10);
      if (*end != '\0' || v < 16 || v > 4096) {
        std::fprintf(stderr, "impostor_example_scene: --size must be an integer in 16..4096, got '%s'\n", argv[i]);
        return 2;
      }
      size = static_cast<int>(v);
    } else if (arg == "--no-depth-offset") {
      depth_offset = false;
    } else {
      std::fprintf(stderr, "impostor_example_scene: unknown or incomplete argument '%s'\n%s", argv[i], kUsage);
      return 2;
    }
  }
  if (result.empty() || mesh_file.empty() || out.empty()) {
    std::fprintf(stderr, "impostor_example_scene: --result, --mesh and --out are required\n%s", kUsage);
    return 2;
  }

  // 1. The baked result: layout, bounding sphere and the three maps.
  auto impostor = impostor::example::LoadBakedImpostor(result);
  if (!impostor.ok()) return Fail(std::string(impostor.status().message()));
  // 2. The mesh, with the worker's own loader (scene space = the bake's).
  auto mesh = impostor::LoadGltfScene(mesh_file);
  if (!mesh.ok()) return Fail(mesh_file + ": " + std::string(mesh.status().message()));
  // 3. Render: mesh left, impostor right, same size, same light.
  auto renderer = impostor::example::SceneRenderer::Create(device);
  if (!renderer.ok()) return Fail("no Vulkan device: " + std::string(renderer.status().message()));
  impostor::example::SceneSetup setup =
      impostor::example::DefaultSetup(impostor->sphere_center, impostor->sphere_radius, /*side_by_side=*/true);
  setup.width = setup.height = size;
  setup.depth_offset = depth_offset;
  auto image = (*renderer)->Render(*mesh, *impostor, setup);
  if (!image.ok()) return Fail(std::string(image.status().message()));
  // Alpha marks objects (for tests); the picture itself is opaque.
  for (size_t i = 3; i < image->rgba.size(); i += 4) image->rgba[i] = 255;
  if (auto s = impostor::WritePngRgba8(out, image->rgba, image->width, image->height); !s.ok()) {
    return Fail(std::string(s.message()));
  }
  std::printf("impostor_example_scene: wrote %s (%dx%d)\n", out.c_str(), image->width, image->height);
  return 0;
}
