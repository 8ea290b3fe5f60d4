#include "worker/scene/scene_wire.h"

#include <cstring>
#include <type_traits>

#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "worker/scene/scene_invariants.h"

namespace impostor {
namespace {

constexpr char kMagic[8] = {'I', 'M', 'P', 'S', 'C', 'N', '1', '\0'};
// Names and warnings are one line each in logs and the manifest.
constexpr uint64_t kMaxStringBytes = 64 * 1024;

using Out = const SceneByteSink&;

template <typename T>
void Put(Out out, const T& value) {
  static_assert(std::is_trivially_copyable_v<T>);
  out(std::string_view(reinterpret_cast<const char*>(&value), sizeof(T)));
}

template <typename T>
void PutArray(Out out, const std::vector<T>& values) {
  static_assert(std::is_trivially_copyable_v<T>);
  Put<uint64_t>(out, values.size());
  out(std::string_view(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T)));
}

void PutString(Out out, const std::string& s) {
  Put<uint64_t>(out, s.size());
  out(s);
}

// Reads what Put wrote, refusing to read or allocate past the end.
class Reader {
 public:
  explicit Reader(std::span<const uint8_t> bytes) : bytes_(bytes) {}

  template <typename T>
  absl::Status Get(T* value, absl::string_view what) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (Left() < sizeof(T)) return Truncated(what);
    std::memcpy(value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return absl::OkStatus();
  }

  // A count of records of at least `min_record_bytes` each, refused when
  // the bytes left cannot hold that many (before anything is allocated).
  absl::Status GetCount(uint64_t* count, size_t min_record_bytes, absl::string_view what) {
    if (auto s = Get(count, what); !s.ok()) return s;
    if (*count > Left() / min_record_bytes) {
      return absl::DataLossError(absl::StrCat("scene bytes: ", what, " count ", *count, " runs past the end"));
    }
    return absl::OkStatus();
  }

  template <typename T>
  absl::Status GetArray(std::vector<T>* values, absl::string_view what) {
    uint64_t count = 0;
    if (auto s = GetCount(&count, sizeof(T), what); !s.ok()) return s;
    if constexpr (std::is_same_v<T, uint8_t>) {
      // Texels, most of a scene's bytes: copied once, not zero-filled first.
      values->assign(bytes_.data() + at_, bytes_.data() + at_ + count);
    } else {
      values->resize(count);
      if (count == 0) return absl::OkStatus();  // an empty vector's data() may be null
      std::memcpy(values->data(), bytes_.data() + at_, count * sizeof(T));
    }
    at_ += count * sizeof(T);
    return absl::OkStatus();
  }

  absl::Status GetString(std::string* s, absl::string_view what) {
    uint64_t size = 0;
    if (auto st = Get(&size, what); !st.ok()) return st;
    if (size > kMaxStringBytes || size > Left()) {
      return absl::DataLossError(absl::StrCat("scene bytes: ", what, " of ", size, " bytes is too long"));
    }
    s->assign(reinterpret_cast<const char*>(bytes_.data() + at_), size);
    at_ += size;
    return absl::OkStatus();
  }

  size_t Left() const { return bytes_.size() - at_; }

 private:
  static absl::Status Truncated(absl::string_view what) {
    return absl::DataLossError(absl::StrCat("scene bytes: truncated at ", what));
  }

  std::span<const uint8_t> bytes_;
  size_t at_ = 0;
};

// The material's fields without its name, in one trivially copyable block.
struct MaterialFields {
  glm::vec4 base_color_factor;
  int32_t base_color_texture;
  float metallic_factor;
  float roughness_factor;
  int32_t metallic_roughness_texture;
  int32_t normal_texture;
  float normal_scale;
  int32_t occlusion_texture;
  float occlusion_strength;
  uint32_t alpha_mode;
  float alpha_cutoff;
  uint32_t double_sided;
  glm::vec3 emissive_factor;
  int32_t emissive_texture;
  float emissive_strength;
  std::array<SlotUv, kTextureSlotCount> uv;
};

MaterialFields FieldsOf(const SceneMaterial& m) {
  return {m.base_color_factor, m.base_color_texture, m.metallic_factor, m.roughness_factor,
          m.metallic_roughness_texture, m.normal_texture, m.normal_scale, m.occlusion_texture,
          m.occlusion_strength, static_cast<uint32_t>(m.alpha_mode), m.alpha_cutoff,
          m.double_sided ? 1u : 0u, m.emissive_factor, m.emissive_texture, m.emissive_strength, m.uv};
}

void SetFields(const MaterialFields& f, SceneMaterial* m) {
  m->base_color_factor = f.base_color_factor;
  m->base_color_texture = f.base_color_texture;
  m->metallic_factor = f.metallic_factor;
  m->roughness_factor = f.roughness_factor;
  m->metallic_roughness_texture = f.metallic_roughness_texture;
  m->normal_texture = f.normal_texture;
  m->normal_scale = f.normal_scale;
  m->occlusion_texture = f.occlusion_texture;
  m->occlusion_strength = f.occlusion_strength;
  m->alpha_mode = static_cast<AlphaMode>(f.alpha_mode);  // checked with the scene
  m->alpha_cutoff = f.alpha_cutoff;
  m->double_sided = f.double_sided != 0;
  m->emissive_factor = f.emissive_factor;
  m->emissive_texture = f.emissive_texture;
  m->emissive_strength = f.emissive_strength;
  m->uv = f.uv;
}

struct TextureFields {
  int32_t width;
  int32_t height;
  uint32_t srgb;
  uint32_t has_alpha_channel;
  int32_t wrap_s;
  int32_t wrap_t;
};

struct BatchFields {
  uint32_t first_index;
  uint32_t index_count;
  int32_t material;
  uint32_t flipped_winding;
};

// How a texture's bytes travel: inline, or as their place in the arena.
constexpr uint32_t kTexelsInline = 0;
constexpr uint32_t kTexelsInArena = 1;

absl::Status Invalid(absl::string_view what) { return absl::DataLossError(absl::StrCat("scene bytes: ", what)); }

}  // namespace

void EncodeScene(const Scene& scene, std::string* out) {
  EncodeScene(scene, [out](std::string_view bytes) { out->append(bytes); });
}

void EncodeScene(const Scene& scene, const SceneByteSink& out, const TexelArena* arena) {
  out(std::string_view(kMagic, sizeof(kMagic)));
  PutArray(out, scene.vertices);
  PutArray(out, scene.indices);
  Put<uint64_t>(out, scene.batches.size());
  for (const SceneBatch& b : scene.batches) {
    Put(out, BatchFields{b.first_index, b.index_count, b.material, b.flipped_winding ? 1u : 0u});
  }
  Put<uint64_t>(out, scene.materials.size());
  for (const SceneMaterial& m : scene.materials) {
    Put(out, FieldsOf(m));
    PutString(out, m.name);
  }
  Put<uint64_t>(out, scene.textures.size());
  for (const SceneTexture& t : scene.textures) {
    Put(out, TextureFields{t.width, t.height, t.srgb ? 1u : 0u, t.has_alpha_channel ? 1u : 0u, t.wrap_s,
                           t.wrap_t});
    PutString(out, t.name);
    if (arena != nullptr && !t.rgba8.empty() && t.rgba8.arena() == arena) {
      Put(out, kTexelsInArena);
      Put<uint64_t>(out, t.rgba8.arena_offset());
      Put<uint64_t>(out, t.rgba8.size());
    } else {
      Put(out, kTexelsInline);
      Put<uint64_t>(out, t.rgba8.size());
      out(std::string_view(reinterpret_cast<const char*>(t.rgba8.data()), t.rgba8.size()));
    }
  }
  Put(out, scene.bounds_min);
  Put(out, scene.bounds_max);
  Put<uint64_t>(out, scene.warnings.size());
  for (const std::string& w : scene.warnings) PutString(out, w);
}

absl::StatusOr<Scene> DecodeScene(std::span<const uint8_t> bytes, const MappedTexels* texels) {
  if (bytes.size() < sizeof(kMagic) || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
    return Invalid("not a scene (magic)");
  }
  Reader in(bytes.subspan(sizeof(kMagic)));
  Scene scene;
  if (auto s = in.GetArray(&scene.vertices, "vertices"); !s.ok()) return s;
  if (auto s = in.GetArray(&scene.indices, "indices"); !s.ok()) return s;

  uint64_t count = 0;
  if (auto s = in.GetCount(&count, sizeof(BatchFields), "batches"); !s.ok()) return s;
  scene.batches.resize(count);
  for (SceneBatch& b : scene.batches) {
    BatchFields f{};
    if (auto s = in.Get(&f, "batch"); !s.ok()) return s;
    b = {.first_index = f.first_index, .index_count = f.index_count, .material = f.material,
         .flipped_winding = f.flipped_winding != 0};
  }

  if (auto s = in.GetCount(&count, sizeof(MaterialFields), "materials"); !s.ok()) return s;
  scene.materials.resize(count);
  for (SceneMaterial& m : scene.materials) {
    MaterialFields f{};
    if (auto s = in.Get(&f, "material"); !s.ok()) return s;
    SetFields(f, &m);
    if (auto s = in.GetString(&m.name, "material name"); !s.ok()) return s;
  }

  if (auto s = in.GetCount(&count, sizeof(TextureFields), "textures"); !s.ok()) return s;
  scene.textures.resize(count);
  for (SceneTexture& t : scene.textures) {
    TextureFields f{};
    if (auto s = in.Get(&f, "texture"); !s.ok()) return s;
    t.width = f.width;
    t.height = f.height;
    t.srgb = f.srgb != 0;
    t.has_alpha_channel = f.has_alpha_channel != 0;
    t.wrap_s = f.wrap_s;
    t.wrap_t = f.wrap_t;
    if (auto s = in.GetString(&t.name, "texture name"); !s.ok()) return s;
    uint32_t where = 0;
    if (auto s = in.Get(&where, "texels"); !s.ok()) return s;
    if (where == kTexelsInline) {
      std::vector<uint8_t> bytes;
      if (auto s = in.GetArray(&bytes, "texels"); !s.ok()) return s;
      t.rgba8 = TexelBuffer(std::move(bytes));
    } else if (where == kTexelsInArena) {
      uint64_t offset = 0, size = 0;
      if (auto s = in.Get(&offset, "texels"); !s.ok()) return s;
      if (auto s = in.Get(&size, "texels"); !s.ok()) return s;
      if (texels == nullptr) return Invalid("texels in an arena, but no arena was handed over");
      if (offset > texels->bytes.size() || size > texels->bytes.size() - offset) {
        return Invalid(absl::StrCat("texels at ", offset, " + ", size, " bytes past the arena's ",
                                    texels->bytes.size()));
      }
      t.rgba8 = TexelBuffer(texels->owner, texels->bytes.subspan(offset, size));
    } else {
      return Invalid(absl::StrCat("texels stored as ", where));
    }
  }

  if (auto s = in.Get(&scene.bounds_min, "bounds"); !s.ok()) return s;
  if (auto s = in.Get(&scene.bounds_max, "bounds"); !s.ok()) return s;
  if (auto s = in.GetCount(&count, sizeof(uint64_t), "warnings"); !s.ok()) return s;
  scene.warnings.resize(count);
  for (std::string& w : scene.warnings) {
    if (auto s = in.GetString(&w, "warning"); !s.ok()) return s;
  }
  if (in.Left() != 0) return Invalid(absl::StrCat(in.Left(), " bytes after the scene"));
  // What the loader guarantees, the bytes must too.
  if (absl::Status s = CheckSceneInvariants(scene); !s.ok()) return Invalid(s.message());
  return scene;
}

}  // namespace impostor
