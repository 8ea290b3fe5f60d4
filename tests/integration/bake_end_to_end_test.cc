// End to end: a real impostor-server with real impostor-worker processes on a
// loopback port, baking real assets from ../shared/assets.
#include <future>
#include <thread>

#include <glm/geometric.hpp>
#include <grpcpp/generic/generic_stub.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/atlas/frame_camera.h"
#include "common/manifest/manifest_json.h"
#include "tests/support/server_process.h"
#include "tests/integration/silhouette.h"
#include "worker/scene/gltf_loader.h"

// After the protobuf headers: OpenImageIO's byte-swap helpers clash with
// protobuf's port.h when included first.
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

namespace impostor {
namespace {

using testing::AssetsDir;
using testing::ServerProcess;

struct Rgba8Image {
  int width = 0, height = 0;
  std::vector<uint8_t> pixels;
};

Rgba8Image DecodePng(const std::string& bytes) {
  Rgba8Image img;
  OIIO::Filesystem::IOMemReader mem(bytes.data(), bytes.size());
  auto in = OIIO::ImageInput::open("atlas.png", nullptr, &mem);
  if (!in) return img;
  const OIIO::ImageSpec& spec = in->spec();
  img.width = spec.width;
  img.height = spec.height;
  img.pixels.resize(static_cast<size_t>(spec.width) * spec.height * 4);
  in->read_image(0, 0, 0, 4, OIIO::TypeDesc::UINT8, img.pixels.data());
  return img;
}

v1::Job Submit(ServerProcess& server, const v1::MeshInput& mesh, v1::BakeParameters params,
               v1::SubmitBakeResponse* response_out = nullptr) {
  grpc::ClientContext ctx;
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = mesh;
  *request.mutable_parameters() = params;
  v1::SubmitBakeResponse response;
  const grpc::Status s = server.bake().SubmitBake(&ctx, request, &response);
  EXPECT_TRUE(s.ok()) << "SubmitBake: " << s.error_message();
  if (response_out) *response_out = response;
  return response.job();
}

v1::BakeParameters Params(v1::Layout layout, int frames, int resolution) {
  v1::BakeParameters p;
  p.set_layout(layout);
  p.set_frames(static_cast<uint32_t>(frames));
  p.set_resolution(static_cast<uint32_t>(resolution));
  return p;
}

struct LayoutCase {
  const char* name;
  v1::Layout layout;
  uint32_t frames;      // requested; 0 = derived by the server
  uint32_t ring_views;  // ring-top only
  uint32_t expect_frames;
  int expect_views;
};

class SilhouetteTest : public ::testing::TestWithParam<LayoutCase> {};

// The product's core promise: a real asset baked by a real server and
// worker, whose every tile's alpha covers the mesh's silhouette as seen by a
// camera rebuilt from the manifest alone.
TEST_P(SilhouetteTest, EveryTileCoversTheMeshSilhouetteFromItsCamera) {
  ServerProcess server(/*local_workers=*/1);
  const auto glb = AssetsDir() / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";
  const v1::MeshInput mesh = testing::UploadGlb(server.assets(), glb);
  const LayoutCase& param = GetParam();
  v1::BakeParameters params = Params(param.layout, static_cast<int>(param.frames), 512);
  if (param.ring_views != 0) params.set_ring_views(param.ring_views);
  // One sample per texel, at its centre, as the CPU rasteriser samples:
  // supersampled coverage is checked in tests/bake.
  params.set_supersampling(1);
  const v1::Job submitted = Submit(server, mesh, params);
  std::vector<v1::Job> updates;
  const v1::Job done = testing::WatchToEnd(server.bake(), submitted.job_id(), &updates);
  ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  bool saw_running = false;
  for (const auto& u : updates) saw_running = saw_running || (u.state() == v1::JOB_STATE_RUNNING && !u.stage().empty());
  EXPECT_TRUE(saw_running) << "WatchJob never reported a running stage";

  const v1::Manifest& m = done.result();
  EXPECT_EQ(m.cache_key(), submitted.cache_key());
  EXPECT_EQ(m.layout(), param.layout);
  EXPECT_EQ(m.frames(), param.expect_frames);
  EXPECT_EQ(m.tile_size(), static_cast<uint32_t>(TileSize(512, static_cast<int>(param.expect_frames))));
  ASSERT_GE(m.maps_size(), 3);
  ASSERT_EQ(m.views_size(), param.expect_views);
  EXPECT_EQ(m.mesh().triangles(), 15452u);

  // manifest.json in the store says the same as the proto.
  std::string json;
  ASSERT_TRUE(testing::ReadBlob(server.assets(), m.manifest_json(), &json).ok());
  auto from_json = ManifestFromJson(json);
  ASSERT_TRUE(from_json.ok()) << from_json.status();
  EXPECT_EQ(from_json->views_size(), param.expect_views);
  EXPECT_EQ(from_json->layout(), param.layout);
  EXPECT_EQ(from_json->maps(0).digest().hash(), m.maps(0).digest().hash());
  // Its timings include the worker's own stages (the download, the load in
  // the isolated child), as the proto's do; only the upload comes after it.
  const nlohmann::json timings = nlohmann::json::parse(json).at("timings_seconds");
  EXPECT_GT(timings.at("load").get<double>(), 0.0) << timings.dump();
  EXPECT_EQ(timings.at("load").get<double>(), m.timings().load_seconds()) << timings.dump();
  EXPECT_EQ(timings.at("download").get<double>(), m.timings().download_seconds()) << timings.dump();
  EXPECT_EQ(timings.at("total").get<double>(), m.timings().total_seconds()) << timings.dump();
  EXPECT_EQ(timings.at("store").get<double>(), 0.0) << timings.dump();
  EXPECT_GT(m.timings().store_seconds(), 0.0);

  std::string png;
  ASSERT_EQ(m.maps(0).semantic(), "albedo_alpha");
  ASSERT_TRUE(testing::ReadBlob(server.assets(), m.maps(0).digest(), &png).ok());
  EXPECT_EQ(testing::DigestOf(png).hash(), m.maps(0).digest().hash());
  const Rgba8Image albedo = DecodePng(png);
  ASSERT_EQ(albedo.width, 512);

  auto scene = LoadGltfScene(glb);
  ASSERT_TRUE(scene.ok()) << scene.status();
  const glm::vec3 center(m.bounding_sphere().center(0), m.bounding_sphere().center(1), m.bounding_sphere().center(2));
  for (const v1::View& view : m.views()) {
    const testing::ManifestCamera cam{
        center, m.bounding_sphere().radius(),
        glm::vec3(view.direction(0), view.direction(1), view.direction(2)),
        glm::vec3(view.up(0), view.up(1), view.up(2)), static_cast<int>(view.tile().width()),
        static_cast<int>(view.tile().height())};
    const std::vector<uint8_t> expected = testing::RasterizeSilhouette(*scene, cam);
    int both = 0, either = 0, lit = 0;
    for (int y = 0; y < cam.tile_height; ++y) {
      for (int x = 0; x < cam.tile_width; ++x) {
        const size_t px = (static_cast<size_t>(view.tile().y()) + y) * albedo.width + view.tile().x() + x;
        const bool covered = albedo.pixels[px * 4 + 3] > 0;
        const bool should = expected[static_cast<size_t>(y) * cam.tile_width + x] != 0;
        both += covered && should;
        either += covered || should;
        if (covered) lit += albedo.pixels[px * 4] + albedo.pixels[px * 4 + 1] + albedo.pixels[px * 4 + 2] > 30;
      }
    }
    ASSERT_GT(either, 0) << "view " << view.index() << " is empty";
    const double iou = static_cast<double>(both) / either;
    EXPECT_GT(iou, 0.985) << "view " << view.index() << ": alpha vs CPU silhouette IoU " << iou;
    EXPECT_GT(lit, both / 2) << "view " << view.index() << ": covered texels are mostly black";
  }
  // The bounding box lies inside the bounding sphere and touches it.
  ASSERT_EQ(m.bounding_box().min_size(), 3);
  ASSERT_EQ(m.bounding_box().max_size(), 3);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(m.bounding_box().min(i), m.bounding_box().max(i));
    EXPECT_GE(m.bounding_box().min(i), center[i] - m.bounding_sphere().radius() - 1e-4f);
    EXPECT_LE(m.bounding_box().max(i), center[i] + m.bounding_sphere().radius() + 1e-4f);
  }
  EXPECT_EQ(from_json->bounding_box().min_size(), 3);
  // The cutout polygon holds every covered texel of every frame (texel
  // centres, in tile coordinates) and saves overdraw.
  const v1::Cutout& cutout = m.cutout();
  ASSERT_GE(cutout.vertices_size(), 6);
  ASSERT_LE(cutout.vertices_size(), 16);
  EXPECT_GT(cutout.area_ratio(), 0.1f);
  EXPECT_LT(cutout.area_ratio(), 1.0f);
  EXPECT_EQ(from_json->cutout().vertices_size(), cutout.vertices_size());
  const int n_cut = cutout.vertices_size() / 2;
  auto inside_cutout = [&](float u, float v) {
    for (int i = 0; i < n_cut; ++i) {
      const float ax = cutout.vertices(2 * i), ay = cutout.vertices(2 * i + 1);
      const float bx = cutout.vertices(2 * ((i + 1) % n_cut)), by = cutout.vertices(2 * ((i + 1) % n_cut) + 1);
      if ((bx - ax) * (v - ay) - (by - ay) * (u - ax) > 1e-5f) return false;
    }
    return true;
  };
  for (const v1::View& view : m.views()) {
    const int tw = static_cast<int>(view.tile().width()), th = static_cast<int>(view.tile().height());
    for (int y = 0; y < th; ++y) {
      for (int x = 0; x < tw; ++x) {
        const size_t px = (static_cast<size_t>(view.tile().y()) + y) * albedo.width + view.tile().x() + x;
        if (albedo.pixels[px * 4 + 3] == 0) continue;
        ASSERT_TRUE(inside_cutout((x + 0.5f) / tw, (y + 0.5f) / th))
            << "view " << view.index() << " texel " << x << "," << y << " outside the cutout";
      }
    }
  }
  // Grid tiles no frame uses (ring-top's remainder) stay fully transparent.
  const int side = static_cast<int>(m.frames()), tile = static_cast<int>(m.tile_size());
  std::vector<bool> used(static_cast<size_t>(side * side), false);
  for (const v1::View& view : m.views()) used[(view.tile().y() / tile) * side + view.tile().x() / tile] = true;
  for (int t = 0; t < side * side; ++t) {
    if (used[static_cast<size_t>(t)]) continue;
    int covered = 0;
    for (int y = 0; y < tile; ++y) {
      for (int x = 0; x < tile; ++x) {
        const size_t px = static_cast<size_t>((t / side) * tile + y) * albedo.width + (t % side) * tile + x;
        covered += albedo.pixels[px * 4 + 3] > 0;
      }
    }
    EXPECT_EQ(covered, 0) << "unused tile " << t << " has covered texels";
  }
}

INSTANTIATE_TEST_SUITE_P(
    Layouts, SilhouetteTest,
    ::testing::Values(LayoutCase{"octahedral", v1::LAYOUT_OCTAHEDRAL, 4, 0, 4, 16},
                      LayoutCase{"hemi_octahedral", v1::LAYOUT_HEMI_OCTAHEDRAL, 4, 0, 4, 16},
                      LayoutCase{"azimuth_elevation", v1::LAYOUT_AZIMUTH_ELEVATION, 5, 0, 5, 25},
                      // 10 ring views + the top in a 4 x 4 grid: 5 tiles stay empty.
                      LayoutCase{"ring_top", v1::LAYOUT_RING_TOP, 0, 10, 4, 11},
                      LayoutCase{"billboard", v1::LAYOUT_BILLBOARD, 0, 0, 3, 9}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(EndToEnd, SecondRequestComesFromTheCacheUnderAnyFileName) {
  ServerProcess server(/*local_workers=*/1);
  const auto glb = AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb";
  const v1::MeshInput mesh = testing::UploadGlb(server.assets(), glb);
  const v1::Job first = Submit(server, mesh, Params(v1::LAYOUT_OCTAHEDRAL, 3, 64));
  const v1::Job done = testing::WatchToEnd(server.bake(), first.job_id());
  ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_EQ(done.attempts(), 1u);

  // Same bytes, same parameters (defaults spelled out or not): answered at
  // once, from the store, by SubmitBake itself.
  const v1::MeshInput renamed = testing::UploadGlb(server.assets(), glb, "a_different_name.glb");
  v1::SubmitBakeResponse again;
  Submit(server, renamed, Params(v1::LAYOUT_UNSPECIFIED, 3, 64), &again);
  EXPECT_TRUE(again.cached());
  EXPECT_EQ(again.cache_key(), first.cache_key());
  EXPECT_EQ(again.job().state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(again.job().attempts(), 0u) << "a cache hit must not reach a worker";
  EXPECT_EQ(again.job().result().maps(0).digest().hash(), done.result().maps(0).digest().hash());

  grpc::ClientContext ctx;
  v1::GetResultRequest get;
  get.set_cache_key(first.cache_key());
  v1::Manifest manifest;
  ASSERT_TRUE(server.assets().GetResult(&ctx, get, &manifest).ok());
  EXPECT_EQ(manifest.manifest_json().hash(), done.result().manifest_json().hash());

  // Other parameters are another bake.
  v1::SubmitBakeResponse other;
  Submit(server, mesh, Params(v1::LAYOUT_HEMI_OCTAHEDRAL, 2, 64), &other);
  EXPECT_FALSE(other.cached());
  EXPECT_NE(other.cache_key(), first.cache_key());
}

TEST(EndToEnd, IdenticalConcurrentSubmissionsShareOneBake) {
  ServerProcess server(/*local_workers=*/0);
  const v1::MeshInput mesh =
      testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb");
  const v1::BakeParameters params = Params(v1::LAYOUT_OCTAHEDRAL, 3, 64);
  auto a = std::async(std::launch::async, [&] { return Submit(server, mesh, params); });
  auto b = std::async(std::launch::async, [&] { return Submit(server, mesh, params); });
  const v1::Job ja = a.get(), jb = b.get();
  EXPECT_NE(ja.job_id(), jb.job_id()) << "each requester has its own job";
  EXPECT_EQ(ja.cache_key(), jb.cache_key());

  // One worker bakes it once; both requesters see the result.
  testing::ChildProcess worker({(testing::BinaryDir() / "impostor-worker").string(), "--server=" + server.address(),
                                "--max-jobs=1", "--log-level=warn"});
  const v1::Job done = testing::WatchToEnd(server.bake(), ja.job_id());
  ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  EXPECT_EQ(done.attempts(), 1u);
  const v1::Job other = testing::WatchToEnd(server.bake(), jb.job_id());
  ASSERT_EQ(other.state(), v1::JOB_STATE_SUCCEEDED) << other.error().message();
  EXPECT_EQ(other.result().maps(0).digest().hash(), done.result().maps(0).digest().hash());
  EXPECT_EQ(worker.Wait(), 0) << "--max-jobs=1: the worker leaves after its one job";

  grpc::ClientContext ctx;
  v1::LeaseJobRequest lease;
  lease.set_worker_id("probe");
  v1::LeaseJobResponse response;
  ctx.set_deadline(std::chrono::system_clock::now() + testing::kRpcTimeout);
  ASSERT_TRUE(server.workers().LeaseJob(&ctx, lease, &response).ok());
  EXPECT_FALSE(response.has_job()) << "nothing else was queued";
}

TEST(EndToEnd, MalformedGltfFailsWithInvalidArgumentAndTheWorkerKeepsServing) {
  ServerProcess server(/*local_workers=*/0);
  testing::ChildProcess worker(
      {(testing::BinaryDir() / "impostor-worker").string(), "--server=" + server.address(), "--log-level=warn"});
  const std::string good = testing::ReadFileBytes(AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  struct Case {
    const char* name;
    std::string bytes;
    const char* path;
  } cases[] = {
      {"truncated glb", good.substr(0, 200), "box.glb"},
      {"not json", "{ this is not json", "broken.gltf"},
      {"missing buffer file", R"({"asset":{"version":"2.0"},"buffers":[{"uri":"nowhere.bin","byteLength":36}]})",
       "lonely.gltf"},
  };
  for (const Case& c : cases) {
    v1::MeshInput mesh;
    mesh.mutable_entry()->set_path(c.path);
    *mesh.mutable_entry()->mutable_digest() = testing::DigestOf(c.bytes);
    ASSERT_TRUE(testing::UploadBytes(server.assets(), c.bytes, mesh.entry().digest()).ok()) << c.name;
    const v1::Job job = Submit(server, mesh, Params(v1::LAYOUT_OCTAHEDRAL, 3, 64));
    const v1::Job done = testing::WatchToEnd(server.bake(), job.job_id());
    EXPECT_EQ(done.state(), v1::JOB_STATE_FAILED) << c.name;
    EXPECT_EQ(done.error().code(), static_cast<int>(grpc::StatusCode::INVALID_ARGUMENT)) << c.name;
    EXPECT_FALSE(done.error().message().empty()) << c.name;
    EXPECT_EQ(done.attempts(), 1u) << c.name << ": bad input must not be retried";
  }
  // The same worker process is alive and bakes the next, valid job.
  const v1::MeshInput mesh = testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  const v1::Job job = Submit(server, mesh, Params(v1::LAYOUT_OCTAHEDRAL, 3, 64));
  EXPECT_EQ(testing::WatchToEnd(server.bake(), job.job_id()).state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_TRUE(worker.Running()) << "the worker process exited with " << worker.exit_code();
}

TEST(EndToEnd, UploadWithAWrongDigestIsRefused) {
  ServerProcess server(/*local_workers=*/0);
  const std::string bytes = "these bytes are not what the digest says";
  struct Case {
    const char* name;
    v1::Digest digest;
  } cases[] = {
      {"wrong hash", testing::DigestOf("other bytes")},
      {"short size", testing::DigestOf(bytes)},
      {"long size", testing::DigestOf(bytes)},
      {"malformed hash", testing::DigestOf(bytes)},
  };
  cases[0].digest.set_size_bytes(static_cast<int64_t>(bytes.size()));
  cases[1].digest.set_size_bytes(5);
  cases[2].digest.set_size_bytes(1000);
  cases[3].digest.set_hash("not-hex");
  for (const Case& c : cases) {
    const grpc::Status s = testing::UploadBytes(server.assets(), bytes, c.digest);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.name << ": " << s.error_message();
    EXPECT_FALSE(s.error_message().empty()) << c.name;
  }
  grpc::ClientContext ctx;
  v1::FindMissingBlobsRequest find;
  *find.add_digests() = cases[0].digest;
  *find.add_digests() = testing::DigestOf(bytes);
  v1::FindMissingBlobsResponse missing;
  ASSERT_TRUE(server.assets().FindMissingBlobs(&ctx, find, &missing).ok());
  EXPECT_EQ(missing.missing_size(), 2) << "no refused upload may become visible";
}

TEST(EndToEnd, SubmitNamesTheBadFieldAndReadBlobResumes) {
  ServerProcess server(/*local_workers=*/0);
  const v1::MeshInput mesh = testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  struct Case {
    const char* name;
    v1::MeshInput mesh;
    v1::BakeParameters params;
    grpc::StatusCode code;
    const char* mentions;
  };
  v1::MeshInput escaping = mesh;
  escaping.mutable_entry()->set_path("../box.glb");
  v1::MeshInput absent = mesh;
  absent.mutable_entry()->mutable_digest()->set_hash(std::string(64, 'f'));
  const Case cases[] = {
      {"one frame", mesh, Params(v1::LAYOUT_OCTAHEDRAL, 1, 64), grpc::StatusCode::INVALID_ARGUMENT,
       "parameters.frames"},
      {"huge atlas", mesh, Params(v1::LAYOUT_OCTAHEDRAL, 8, 1 << 20), grpc::StatusCode::INVALID_ARGUMENT,
       "parameters.resolution"},
      {"path escape", escaping, Params(v1::LAYOUT_OCTAHEDRAL, 3, 64), grpc::StatusCode::INVALID_ARGUMENT,
       "mesh.entry.path"},
      {"blob not uploaded", absent, Params(v1::LAYOUT_OCTAHEDRAL, 3, 64), grpc::StatusCode::FAILED_PRECONDITION,
       "upload it first"},
  };
  for (const Case& c : cases) {
    grpc::ClientContext ctx;
    v1::SubmitBakeRequest request;
    *request.mutable_mesh() = c.mesh;
    *request.mutable_parameters() = c.params;
    v1::SubmitBakeResponse response;
    const grpc::Status s = server.bake().SubmitBake(&ctx, request, &response);
    EXPECT_EQ(s.error_code(), c.code) << c.name << ": " << s.error_message();
    EXPECT_NE(s.error_message().find(c.mentions), std::string::npos) << c.name << ": " << s.error_message();
  }

  const std::string bytes = testing::ReadFileBytes(AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  std::string tail;
  ASSERT_TRUE(testing::ReadBlob(server.assets(), mesh.entry().digest(), &tail, 1000, 0).ok());
  EXPECT_EQ(tail, bytes.substr(1000));
  std::string middle;
  ASSERT_TRUE(testing::ReadBlob(server.assets(), mesh.entry().digest(), &middle, 100, 50).ok());
  EXPECT_EQ(middle, bytes.substr(100, 50));
  std::string none;
  EXPECT_EQ(testing::ReadBlob(server.assets(), testing::DigestOf("never uploaded"), &none).error_code(),
            grpc::StatusCode::NOT_FOUND);
}

TEST(EndToEnd, ServesStandardHealthChecks) {
  ServerProcess server(/*local_workers=*/0);
  // grpc.health.v1.Health/Check with an empty request (service "" = whole
  // server); the reply's field 1 is the serving status (1 = SERVING).
  grpc::GenericStub stub(server.channel());
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  grpc::ByteBuffer request, response;
  grpc::Slice empty("");
  request = grpc::ByteBuffer(&empty, 1);
  std::promise<grpc::Status> done;
  stub.UnaryCall(&ctx, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                 [&](grpc::Status s) { done.set_value(s); });
  const grpc::Status s = done.get_future().get();
  ASSERT_TRUE(s.ok()) << s.error_message();
  std::vector<grpc::Slice> slices;
  ASSERT_TRUE(response.Dump(&slices).ok());
  std::string bytes;
  for (const auto& slice : slices) bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
  EXPECT_EQ(bytes, std::string("\x08\x01", 2));
}

}  // namespace
}  // namespace impostor
