#include "common/manifest/manifest_json.h"

#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "common/manifest/cards_manifest_json.h"
#include "common/manifest/geometry_manifest_json.h"
#include "common/manifest/quality_manifest_json.h"
#include "common/manifest/lod_manifest_json.h"

namespace impostor {
namespace {

using nlohmann::json;

json DigestJson(const v1::Digest& d) { return {{"hash", d.hash()}, {"size_bytes", d.size_bytes()}}; }

json Vec(const google::protobuf::RepeatedField<float>& v) { return json(std::vector<float>(v.begin(), v.end())); }

// Reads `j[key]` as T or records the first error.
class Reader {
 public:
  template <typename T>
  T Get(const json& j, const char* key, std::string_view path) {
    if (!error_.empty()) return T{};
    auto it = j.find(key);
    if (it == j.end()) {
      error_ = absl::StrCat(std::string(path), key, ": missing");
      return T{};
    }
    try {
      return it->get<T>();
    } catch (const json::exception&) {
      error_ = absl::StrCat(std::string(path), key, ": wrong type");
      return T{};
    }
  }
  const json& Obj(const json& j, const char* key, std::string_view path) {
    static const json kEmpty = json::object();
    if (!error_.empty()) return kEmpty;
    auto it = j.find(key);
    if (it == j.end() || !(it->is_object() || it->is_array())) {
      error_ = absl::StrCat(std::string(path), key, ": missing or not an object/array");
      return kEmpty;
    }
    return *it;
  }
  void Floats(const json& j, const char* key, std::string_view path, size_t n,
              google::protobuf::RepeatedField<float>* out) {
    auto v = Get<std::vector<float>>(j, key, path);
    if (error_.empty() && v.size() != n) {
      error_ = absl::StrCat(std::string(path), key, ": expected ", n, " numbers");
    }
    for (float f : v) out->Add(f);
  }
  void Digest(const json& j, std::string_view path, v1::Digest* d) {
    const json& o = Obj(j, "digest", path);
    d->set_hash(Get<std::string>(o, "hash", absl::StrCat(std::string(path), "digest.")));
    d->set_size_bytes(Get<int64_t>(o, "size_bytes", absl::StrCat(std::string(path), "digest.")));
  }
  const std::string& error() const { return error_; }

 private:
  std::string error_;
};

json SurfelsJson(const v1::SurfelCloud& s) {
  const v1::SurfelQuality& q = s.quality();
  return {{"file", s.file()},
          {"digest", DigestJson(s.digest())},
          {"ply_file", s.ply_file()},
          {"ply_digest", DigestJson(s.ply_digest())},
          {"point_count", s.point_count()},
          {"point_budget", s.point_budget()},
          {"budget_fill", s.budget_fill()},
          {"voxel_size", s.voxel_size()},
          {"point_diameter", s.point_diameter()},
          {"bounds_min", Vec(s.bounds_min())},
          {"bounds_max", Vec(s.bounds_max())},
          {"stride_bytes", s.stride_bytes()},
          {"sample_count", s.sample_count()},
          {"capture", {{"layout", std::string(LayoutJsonName(s.capture_layout()))},
                       {"frames", s.capture_frames()},
                       {"resolution", s.capture_resolution()}}},
          {"quality", {{"views", q.views()},
                       {"view_pixels", q.view_pixels()},
                       {"silhouette_iou_mean", q.silhouette_iou_mean()},
                       {"silhouette_iou_min", q.silhouette_iou_min()},
                       {"albedo_psnr_db", q.albedo_psnr_db()}}}};
}

v1::Layout LayoutFromJsonName(const std::string& name) {
  for (v1::Layout l : {v1::LAYOUT_OCTAHEDRAL, v1::LAYOUT_HEMI_OCTAHEDRAL, v1::LAYOUT_AZIMUTH_ELEVATION,
                       v1::LAYOUT_RING_TOP, v1::LAYOUT_BILLBOARD}) {
    if (name == LayoutJsonName(l)) return l;
  }
  return v1::LAYOUT_UNSPECIFIED;
}

// Reads the `surfels` block (required fields: the files, their digests and
// the numbers a renderer needs; quality is informative and optional).
void ReadSurfels(Reader& r, const json& j, v1::SurfelCloud* s) {
  const std::string path = "surfels.";
  s->set_file(r.Get<std::string>(j, "file", path));
  r.Digest(j, path, s->mutable_digest());
  s->set_ply_file(r.Get<std::string>(j, "ply_file", path));
  const json& ply = r.Obj(j, "ply_digest", path);
  s->mutable_ply_digest()->set_hash(r.Get<std::string>(ply, "hash", path + "ply_digest."));
  s->mutable_ply_digest()->set_size_bytes(r.Get<int64_t>(ply, "size_bytes", path + "ply_digest."));
  s->set_point_count(r.Get<uint32_t>(j, "point_count", path));
  s->set_point_budget(r.Get<uint32_t>(j, "point_budget", path));
  s->set_budget_fill(r.Get<float>(j, "budget_fill", path));
  s->set_voxel_size(r.Get<float>(j, "voxel_size", path));
  s->set_point_diameter(r.Get<float>(j, "point_diameter", path));
  r.Floats(j, "bounds_min", path, 3, s->mutable_bounds_min());
  r.Floats(j, "bounds_max", path, 3, s->mutable_bounds_max());
  s->set_stride_bytes(r.Get<uint32_t>(j, "stride_bytes", path));
  s->set_sample_count(r.Get<uint64_t>(j, "sample_count", path));
  const json& capture = r.Obj(j, "capture", path);
  s->set_capture_layout(LayoutFromJsonName(r.Get<std::string>(capture, "layout", path + "capture.")));
  s->set_capture_frames(r.Get<uint32_t>(capture, "frames", path + "capture."));
  s->set_capture_resolution(r.Get<uint32_t>(capture, "resolution", path + "capture."));
  if (auto it = j.find("quality"); it != j.end() && it->is_object()) {
    v1::SurfelQuality* q = s->mutable_quality();
    q->set_views(it->value("views", 0u));
    q->set_view_pixels(it->value("view_pixels", 0u));
    q->set_silhouette_iou_mean(it->value("silhouette_iou_mean", 0.0f));
    q->set_silhouette_iou_min(it->value("silhouette_iou_min", 0.0f));
    q->set_albedo_psnr_db(it->value("albedo_psnr_db", 0.0f));
  }
}

}  // namespace

std::string_view ProductJsonName(v1::Product product) {
  switch (product) {
    case v1::PRODUCT_UNSPECIFIED:
    case v1::PRODUCT_ATLAS: return "atlas";
    case v1::PRODUCT_SURFELS: return "surfels";
    case v1::PRODUCT_CARDS: return "cards";
    case v1::PRODUCT_LOD_CHAIN: return "lod-chain";
    default: return "unknown";
  }
}

std::string_view LayoutJsonName(v1::Layout layout) {
  switch (layout) {
    case v1::LAYOUT_OCTAHEDRAL: return "octahedral";
    case v1::LAYOUT_HEMI_OCTAHEDRAL: return "hemi-octahedral";
    case v1::LAYOUT_AZIMUTH_ELEVATION: return "azimuth-elevation";
    case v1::LAYOUT_RING_TOP: return "ring-top";
    case v1::LAYOUT_BILLBOARD: return "billboard";
    default: return "unspecified";
  }
}

std::string ManifestToJson(const v1::Manifest& m) {
  json j;
  j["format_version"] = m.format_version();
  j["cache_key"] = m.cache_key();
  j["baker_version"] = m.baker_version();
  j["product"] = std::string(ProductJsonName(m.product()));
  j["layout"] = std::string(LayoutJsonName(m.layout()));
  j["frames"] = m.frames();
  j["resolution"] = m.resolution();
  j["tile_size"] = m.tile_size();
  j["bounding_sphere"] = {{"center", Vec(m.bounding_sphere().center())},
                          {"radius", m.bounding_sphere().radius()}};
  json maps = json::array();
  for (const auto& map : m.maps()) {
    maps.push_back({{"semantic", map.semantic()},
                    {"file", map.file()},
                    {"digest", DigestJson(map.digest())},
                    {"width", map.width()},
                    {"height", map.height()},
                    {"format", map.format()},
                    {"channels", std::vector<std::string>(map.channels().begin(), map.channels().end())}});
    // KTX2 maps only: PNG maps' JSON stays as it was.
    if (map.levels() > 0) {
      maps.back()["codec"] = map.codec();
      maps.back()["levels"] = map.levels();
      maps.back()["precision"] = map.precision();
      // Maps whose A is coverage only (albedo_alpha, orm, emissive).
      if (map.coverage_by_level_size() > 0) {
        maps.back()["coverage_by_level"] =
            std::vector<double>(map.coverage_by_level().begin(), map.coverage_by_level().end());
      }
    }
  }
  j["maps"] = maps;
  json views = json::array();
  for (const auto& v : m.views()) {
    views.push_back({{"index", v.index()},
                     {"direction", Vec(v.direction())},
                     {"up", Vec(v.up())},
                     {"tile", {v.tile().x(), v.tile().y(), v.tile().width(), v.tile().height()}},
                     {"same_view_as", v.same_view_as()}});
  }
  j["views"] = views;
  j["mesh"] = {{"triangles", m.mesh().triangles()},
               {"materials", m.mesh().materials()},
               {"textures", m.mesh().textures()}};
  const auto& t = m.timings();
  j["timings_seconds"] = {{"download", t.download_seconds()}, {"load", t.load_seconds()},
                          {"render", t.render_seconds()},     {"readback", t.readback_seconds()},
                          {"encode", t.encode_seconds()},     {"store", t.store_seconds()},
                          {"total", t.total_seconds()}};
  j["device"] = m.device();
  // The server stamps it (server/scheduler/manifest_stamp.h); workers leave it out.
  if (!m.baked_by().empty()) j["baked_by"] = m.baked_by();
  if (m.product() == v1::PRODUCT_SURFELS) j["surfels"] = SurfelsJson(m.surfels());
  if (m.product() == v1::PRODUCT_CARDS) j["cards"] = CardsToJson(m.cards());
  if (m.product() == v1::PRODUCT_LOD_CHAIN) j["lods"] = LodLevelsToJson(m.lods());
  AddQualityJson(m, &j);
  AddGeometryJson(m, &j);
  return j.dump(2) + "\n";
}

absl::StatusOr<v1::Manifest> ManifestFromJson(std::string_view text) {
  json j = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) {
    return absl::InvalidArgumentError("manifest.json: not a JSON object");
  }
  Reader r;
  v1::Manifest m;
  m.set_format_version(r.Get<uint32_t>(j, "format_version", ""));
  if (r.error().empty() &&
      (m.format_version() < kOldestManifestFormatVersion || m.format_version() > kManifestFormatVersion)) {
    return absl::InvalidArgumentError(absl::StrCat("manifest.json: format_version ", m.format_version(),
                                                   " is not supported (expected ", kOldestManifestFormatVersion,
                                                   "..", kManifestFormatVersion, ")"));
  }
  // "product" is absent from manifests written before products existed.
  if (auto it = j.find("product"); it != j.end()) {
    const std::string product = it->is_string() ? it->get<std::string>() : std::string();
    if (product == "atlas") m.set_product(v1::PRODUCT_ATLAS);
    else if (product == "surfels") m.set_product(v1::PRODUCT_SURFELS);
    else if (product == "cards") m.set_product(v1::PRODUCT_CARDS);
    else if (product == "lod-chain") m.set_product(v1::PRODUCT_LOD_CHAIN);
    else return absl::InvalidArgumentError("manifest.json: product: unknown \"" + product + "\"");
  }
  m.set_cache_key(r.Get<std::string>(j, "cache_key", ""));
  m.set_baker_version(r.Get<std::string>(j, "baker_version", ""));
  const std::string layout = r.Get<std::string>(j, "layout", "");
  m.set_layout(LayoutFromJsonName(layout));
  if (m.layout() == v1::LAYOUT_UNSPECIFIED && r.error().empty()) return absl::InvalidArgumentError("manifest.json: layout: unknown \"" + layout + "\"");
  m.set_frames(r.Get<uint32_t>(j, "frames", ""));
  m.set_resolution(r.Get<uint32_t>(j, "resolution", ""));
  m.set_tile_size(r.Get<uint32_t>(j, "tile_size", ""));
  const json& sphere = r.Obj(j, "bounding_sphere", "");
  r.Floats(sphere, "center", "bounding_sphere.", 3, m.mutable_bounding_sphere()->mutable_center());
  m.mutable_bounding_sphere()->set_radius(r.Get<float>(sphere, "radius", "bounding_sphere."));
  const json& maps = r.Obj(j, "maps", "");
  for (size_t i = 0; r.error().empty() && i < maps.size(); ++i) {
    const std::string path = absl::StrCat("maps[", i, "].");
    v1::MapFile* map = m.add_maps();
    map->set_semantic(r.Get<std::string>(maps[i], "semantic", path));
    map->set_file(r.Get<std::string>(maps[i], "file", path));
    r.Digest(maps[i], path, map->mutable_digest());
    map->set_width(r.Get<uint32_t>(maps[i], "width", path));
    map->set_height(r.Get<uint32_t>(maps[i], "height", path));
    map->set_format(r.Get<std::string>(maps[i], "format", path));
    for (const auto& c : r.Get<std::vector<std::string>>(maps[i], "channels", path)) map->add_channels(c);
    if (maps[i].contains("levels")) {
      map->set_codec(r.Get<std::string>(maps[i], "codec", path));
      map->set_levels(r.Get<uint32_t>(maps[i], "levels", path));
      map->set_precision(r.Get<std::string>(maps[i], "precision", path));
      // Absent from maps whose A is not coverage, and from KTX2 results
      // baked before it was measured.
      if (maps[i].contains("coverage_by_level")) {
        for (double v : r.Get<std::vector<double>>(maps[i], "coverage_by_level", path)) map->add_coverage_by_level(v);
      }
    }
  }
  const json& views = r.Obj(j, "views", "");
  for (size_t i = 0; r.error().empty() && i < views.size(); ++i) {
    const std::string path = absl::StrCat("views[", i, "].");
    v1::View* v = m.add_views();
    v->set_index(r.Get<uint32_t>(views[i], "index", path));
    r.Floats(views[i], "direction", path, 3, v->mutable_direction());
    r.Floats(views[i], "up", path, 3, v->mutable_up());
    auto tile = r.Get<std::vector<uint32_t>>(views[i], "tile", path);
    if (r.error().empty() && tile.size() != 4) return absl::InvalidArgumentError("manifest.json: " + path + "tile: expected [x, y, w, h]");
    if (tile.size() == 4) {
      v->mutable_tile()->set_x(tile[0]);
      v->mutable_tile()->set_y(tile[1]);
      v->mutable_tile()->set_width(tile[2]);
      v->mutable_tile()->set_height(tile[3]);
    }
    v->set_same_view_as(r.Get<uint32_t>(views[i], "same_view_as", path));
  }
  if (m.product() == v1::PRODUCT_SURFELS) ReadSurfels(r, r.Obj(j, "surfels", ""), m.mutable_surfels());
  if (r.error().empty() && m.product() == v1::PRODUCT_CARDS) {
    if (absl::Status s = ReadCards(j, &m); !s.ok()) return s;
  }
  if (r.error().empty() && m.product() == v1::PRODUCT_LOD_CHAIN) {
    if (absl::Status s = ReadLodLevels(j, &m); !s.ok()) return s;
  }
  if (!r.error().empty()) return absl::InvalidArgumentError("manifest.json: " + r.error());
  if (absl::Status s = ReadQualityJson(j, &m); !s.ok()) return s;
  if (absl::Status s = ReadGeometryJson(j, &m); !s.ok()) return s;
  if (auto it = j.find("device"); it != j.end() && it->is_string()) m.set_device(it->get<std::string>());
  if (auto it = j.find("baked_by"); it != j.end() && it->is_string()) m.set_baked_by(it->get<std::string>());
  if (auto it = j.find("mesh"); it != j.end() && it->is_object()) {
    m.mutable_mesh()->set_triangles(it->value("triangles", uint64_t{0}));
    m.mutable_mesh()->set_materials(it->value("materials", 0u));
    m.mutable_mesh()->set_textures(it->value("textures", 0u));
  }
  return m;
}

}  // namespace impostor
