// TexelBuffer and the texel arena (worker/scene/texel_buffer.h,
// texel_arena.h): copies share bytes and a mutation never reaches another
// buffer; texels decoded into an arena travel through the scene bytes as
// their place in it and come back as views of the mapped memfd, and a
// place outside the arena (forged by a compromised child) is refused.
#include <sys/mman.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "worker/scene/scene_wire.h"
#include "worker/scene/texel_arena.h"
#include "worker/scene/texel_buffer.h"

namespace impostor {
namespace {

std::span<const uint8_t> Bytes(const std::string& s) { return {reinterpret_cast<const uint8_t*>(s.data()), s.size()}; }

TEST(TexelBufferTest, CopiesShareBytesAndAMutationStaysWithItsBuffer) {
  TexelBuffer a{1, 2, 3, 4};
  TexelBuffer b = a;
  EXPECT_EQ(a.data(), b.data()) << "a copy shares the bytes";
  b.mutable_data()[0] = 9;
  EXPECT_EQ(a, (std::vector<uint8_t>{1, 2, 3, 4}));
  EXPECT_EQ(b, (std::vector<uint8_t>{9, 2, 3, 4}));
  EXPECT_NE(a.data(), b.data());
  b.push_back(5);
  EXPECT_EQ(b.size(), 5u);
  EXPECT_EQ(b[4], 5);
  b.clear();
  EXPECT_TRUE(b.empty());
  EXPECT_EQ(a.size(), 4u);
}

// A scene with one 2x2 texture decoded (copied) into an arena over `fd`.
Scene SceneWithArenaTexture(TexelArena* arena) {
  Scene s;
  s.vertices.resize(3);
  s.vertices[1].position = glm::vec3(1, 0, 0);
  s.vertices[2].position = glm::vec3(0, 1, 0);
  s.indices = {0, 1, 2};
  s.materials.resize(1);
  s.materials[0].base_color_texture = 0;
  s.batches = {{.first_index = 0, .index_count = 3, .material = 0}};
  s.bounds_max = glm::vec3(1, 1, 0);
  const std::vector<uint8_t> texels = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16};
  ScopedTexelArena use(arena);
  SceneTexture t;
  t.width = 2;
  t.height = 2;
  t.rgba8 = TexelBuffer::CopyOf(texels);
  s.textures.push_back(std::move(t));
  return s;
}

TEST(TexelArenaTest, ArenaTexelsTravelByPlaceAndComeBackAsViews) {
  const int fd = ::memfd_create("texel-test", MFD_CLOEXEC);
  ASSERT_GE(fd, 0);
  TexelArena arena(fd);
  const Scene scene = SceneWithArenaTexture(&arena);
  ASSERT_EQ(scene.textures[0].rgba8.arena(), &arena);
  std::string bytes;
  EncodeScene(scene, [&](std::string_view b) { bytes.append(b); }, &arena);
  std::string inline_bytes;
  EncodeScene(scene, &inline_bytes);
  EXPECT_EQ(inline_bytes.size() - bytes.size(), 16u - 8u) << "the texels are not in the scene bytes";

  absl::StatusOr<MappedTexels> mapped = MapTexelArena(fd);
  ASSERT_TRUE(mapped.ok()) << mapped.status();
  absl::StatusOr<Scene> back = DecodeScene(Bytes(bytes), &*mapped);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->textures[0].rgba8, scene.textures[0].rgba8);
  EXPECT_GE(back->textures[0].rgba8.data(), mapped->bytes.data()) << "a view of the mapping, not a copy";
  EXPECT_LT(back->textures[0].rgba8.data(), mapped->bytes.data() + mapped->bytes.size());

  // Without the arena, or with a place outside it: refused.
  EXPECT_NE(DecodeScene(Bytes(bytes)).status().message().find("texels in an arena, but no arena was handed over"),
            std::string::npos);
  // The texture's place as written: "in arena" (1), offset 0, 16 bytes.
  std::string place(4 + 8 + 8, '\0');
  const uint32_t in_arena = 1;
  const uint64_t offset = 0, size = 16, past = mapped->bytes.size();
  std::memcpy(place.data(), &in_arena, 4);
  std::memcpy(place.data() + 4, &offset, 8);
  std::memcpy(place.data() + 12, &size, 8);
  std::string forged = bytes;
  const size_t at = forged.find(place);
  ASSERT_NE(at, std::string::npos);
  std::memcpy(forged.data() + at + 4, &past, 8);  // at the arena's end: past it
  const absl::StatusOr<Scene> refused = DecodeScene(Bytes(forged), &*mapped);
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kDataLoss);
  EXPECT_NE(refused.status().message().find("past the arena"), std::string::npos) << refused.status();
  ::close(fd);
}

}  // namespace
}  // namespace impostor
