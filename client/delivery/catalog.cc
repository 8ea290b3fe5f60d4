#include "client/delivery/catalog.h"

#include <algorithm>
#include <ctime>

#include "absl/strings/string_view.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/delivery/asset_stream.h"
#include "client/delivery/release_paths.h"
#include "common/manifest/manifest_json.h"
#include "common/util/sha256.h"
#include "nlohmann/json.hpp"

namespace impostor::delivery {
namespace {

using json = nlohmann::json;

constexpr char kManifestName[] = "manifest.json";
// A catalog lists files by name; a name is a plain file name (no "/"), the
// way the cache and the manifest refer to it.
constexpr size_t kMaxFileNameLength = 255;
constexpr size_t kMaxFilesPerAsset = 4096;

// Reads fields of an untrusted document, remembering the first problem as
// an error naming its path ("assets[\"trees/oak\"].files[2].sha256").
class Reader {
 public:
  explicit Reader(absl::string_view source) : source_(source) {}

  // `object[key]` when it is of `type` (a path in a refusal is `path` + `key`).
  json* Field(json& object, absl::string_view key, const std::string& path, json::value_t type) {
    if (!error_.ok()) return nullptr;
    if (!object.is_object()) return Fail(path, "must be an object");
    auto it = object.find(key);
    if (it == object.end()) return Fail(absl::StrCat(path, key), "is missing");
    const bool type_ok = type == json::value_t::number_unsigned
                             ? it->is_number_unsigned() || (it->is_number_integer() && it->get<int64_t>() >= 0)
                             : it->type() == type;
    if (!type_ok) return Fail(absl::StrCat(path, key), absl::StrCat("must be ", TypeName(type)));
    return &*it;
  }
  std::string String(json& o, absl::string_view key, const std::string& path) {
    const json* v = Field(o, key, path, json::value_t::string);
    return v == nullptr ? std::string() : v->get<std::string>();
  }
  // As String, moving the value out of `o` (which is thrown away after).
  std::string TakeString(json& o, absl::string_view key, const std::string& path) {
    json* v = Field(o, key, path, json::value_t::string);
    return v == nullptr ? std::string() : std::move(v->get_ref<std::string&>());
  }
  int64_t Count(json& o, absl::string_view key, const std::string& path) {
    const json* v = Field(o, key, path, json::value_t::number_unsigned);
    return v == nullptr ? 0 : v->get<int64_t>();
  }
  void Hex(const std::string& value, const std::string& path, absl::string_view key) {
    if (error_.ok() && !IsSha256Hex(value)) Fail(absl::StrCat(path, key), "must be 64 lowercase hex characters");
  }
  json* Fail(const std::string& path, absl::string_view why) {
    if (error_.ok()) error_ = absl::InvalidArgumentError(absl::StrCat(source_, ": ", path, " ", why));
    return nullptr;
  }
  const absl::Status& error() const { return error_; }

 private:
  static std::string TypeName(json::value_t t) {
    switch (t) {
      case json::value_t::string: return "a string";
      case json::value_t::object: return "an object";
      case json::value_t::array: return "an array";
      case json::value_t::number_unsigned: return "a whole number >= 0";
      default: return "of another type";
    }
  }
  std::string source_;
  absl::Status error_;
};

absl::Status NotAJsonObject(absl::string_view source, absl::string_view what) {
  return absl::InvalidArgumentError(
      absl::StrCat(source, ": not a JSON object (a ", what, " was expected; an HTML error page?)"));
}

absl::StatusOr<json> ParseJson(absl::string_view text, absl::string_view source, absl::string_view what) {
  json doc = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) return NotAJsonObject(source, what);
  return doc;
}

absl::Status CheckSchema(Reader& r, json& doc, absl::string_view schema, int known_version,
                         absl::string_view source, int* version) {
  const std::string name = r.String(doc, "schema", "");
  if (r.error().ok() && name != schema) {
    r.Fail("schema", absl::StrCat("is \"", name.substr(0, 40), "\", expected \"", schema, "\""));
  }
  *version = static_cast<int>(r.Count(doc, "schema_version", ""));
  if (!r.error().ok()) return r.error();
  if (*version > known_version) {
    return absl::FailedPreconditionError(absl::StrCat(source, ": schema_version ", *version,
                                                      " is newer than this reader's (", known_version,
                                                      "); update the SDK"));
  }
  if (*version < 1) return absl::InvalidArgumentError(absl::StrCat(source, ": schema_version must be >= 1"));
  return absl::OkStatus();
}

json FileToJson(const CatalogFile& f) {
  return json{{"name", f.name},     {"semantic", f.semantic}, {"sha256", f.sha256}, {"size_bytes", f.size_bytes},
              {"media_type", f.media_type}, {"width", f.width}, {"height", f.height}, {"format", f.format}};
}

// One member of a catalog's "assets", checked (its fields named by path in
// a refusal) and converted; its strings are moved out of `a`.
absl::StatusOr<CatalogAsset> ParseAsset(const std::string& name, json& a, absl::string_view source) {
  if (absl::Status s = ValidateAssetName(name, absl::StrCat(source, ": asset name")); !s.ok()) return s;
  Reader r(source);
  const std::string path = absl::StrCat("assets[\"", name.substr(0, 80), "\"].");
  CatalogAsset asset;
  asset.cache_key = r.TakeString(a, "cache_key", path);
  r.Hex(asset.cache_key, path, "cache_key");
  asset.product = r.TakeString(a, "product", path);
  asset.layout = r.TakeString(a, "layout", path);
  asset.frames = static_cast<uint32_t>(r.Count(a, "frames", path));
  asset.resolution = static_cast<uint32_t>(r.Count(a, "resolution", path));
  if (a.is_object() && a.contains("baker_version")) asset.baker_version = r.TakeString(a, "baker_version", path);
  if (json* manifest = r.Field(a, "manifest", path, json::value_t::object); manifest != nullptr) {
    const std::string mpath = path + "manifest.";
    asset.manifest_sha256 = r.TakeString(*manifest, "sha256", mpath);
    r.Hex(asset.manifest_sha256, mpath, "sha256");
    asset.manifest_size_bytes = r.Count(*manifest, "size_bytes", mpath);
  }
  json* files = r.Field(a, "files", path, json::value_t::array);
  if (files != nullptr && files->size() > kMaxFilesPerAsset) {
    r.Fail(path + "files", absl::StrCat("lists ", files->size(), " files; the limit is ", kMaxFilesPerAsset));
  }
  bool has_manifest = false;
  for (size_t i = 0; files != nullptr && i < files->size() && r.error().ok(); ++i) {
    const std::string fpath = absl::StrCat(path, "files[", i, "].");
    json& f = (*files)[i];
    CatalogFile file;
    file.name = r.TakeString(f, "name", fpath);
    file.semantic = r.TakeString(f, "semantic", fpath);
    file.sha256 = r.TakeString(f, "sha256", fpath);
    r.Hex(file.sha256, fpath, "sha256");
    file.size_bytes = r.Count(f, "size_bytes", fpath);
    if (!r.error().ok()) break;
    file.media_type = f.contains("media_type") ? r.TakeString(f, "media_type", fpath) : MediaTypeForFile(file.name);
    if (f.contains("width")) file.width = static_cast<uint32_t>(r.Count(f, "width", fpath));
    if (f.contains("height")) file.height = static_cast<uint32_t>(r.Count(f, "height", fpath));
    if (f.contains("format")) file.format = r.TakeString(f, "format", fpath);
    if (!r.error().ok()) break;
    if (file.name.empty() || file.name.size() > kMaxFileNameLength || file.name == "." || file.name == ".." ||
        file.name.find_first_of(std::string("/\\\0", 3)) != std::string::npos || file.name.front() == '.') {
      r.Fail(fpath + "name", "must be a plain file name (no path, not hidden, at most 255 characters)");
      break;
    }
    if (std::any_of(asset.files.begin(), asset.files.end(), [&](const CatalogFile& g) { return g.name == file.name; })) {
      r.Fail(fpath + "name", absl::StrCat("\"", file.name, "\" is listed twice"));
      break;
    }
    if (file.name == kManifestName) {
      has_manifest = true;
      if (file.sha256 != asset.manifest_sha256 || file.size_bytes != asset.manifest_size_bytes) {
        r.Fail(fpath + "sha256", "differs from the asset's manifest digest");
      }
    }
    asset.files.push_back(std::move(file));
  }
  if (r.error().ok() && !has_manifest) r.Fail(path + "files", "must list manifest.json");
  if (!r.error().ok()) return r.error();
  return asset;
}

}  // namespace

std::string Rfc3339Utc(int64_t unix_seconds) {
  const std::time_t t = static_cast<std::time_t>(unix_seconds);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buffer[32];
  std::strftime(buffer, sizeof buffer, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buffer;
}

std::string CatalogToJson(const Catalog& catalog) {
  json assets = json::object();
  for (const auto& [name, a] : catalog.assets) {
    json files = json::array();
    for (const CatalogFile& f : a.files) files.push_back(FileToJson(f));
    assets[name] = json{{"cache_key", a.cache_key},
                        {"product", a.product},
                        {"layout", a.layout},
                        {"frames", a.frames},
                        {"resolution", a.resolution},
                        {"baker_version", a.baker_version},
                        {"manifest", {{"sha256", a.manifest_sha256}, {"size_bytes", a.manifest_size_bytes}}},
                        {"files", std::move(files)}};
  }
  const json doc{{"schema", "impostor-catalog"},
                 {"schema_version", catalog.schema_version},
                 {"created_at", catalog.created_at},
                 {"baker_version", catalog.baker_version},
                 {"assets", std::move(assets)}};
  return doc.dump();
}

absl::StatusOr<Catalog> ParseCatalog(absl::string_view text, absl::string_view source) {
  // Each asset is checked and converted as soon as the parser has it (its
  // document dropped right after); the first refusal is kept, and reported
  // after the schema's, which the text may hold after the assets.
  Catalog catalog;
  absl::Status asset_error;
  json doc;
  const bool parsed = ParseWithStreamedAssets(text, &doc, [&](std::string name, json value) {
    if (!asset_error.ok()) return;
    absl::StatusOr<CatalogAsset> asset = ParseAsset(name, value, source);
    if (!asset.ok()) {
      asset_error = asset.status();
      return;
    }
    if (!catalog.assets.try_emplace(std::move(name), std::move(*asset)).second) {  // name kept when not moved
      asset_error = absl::InvalidArgumentError(
          absl::StrCat(source, ": assets[\"", name.substr(0, 80), "\"] is listed twice"));
    }
  });
  if (!parsed || !doc.is_object()) return NotAJsonObject(source, "catalog");
  Reader r(source);
  if (absl::Status s = CheckSchema(r, doc, "impostor-catalog", kCatalogSchemaVersion, source,
                                   &catalog.schema_version);
      !s.ok()) {
    return s;
  }
  catalog.created_at = r.String(doc, "created_at", "");
  catalog.baker_version = r.String(doc, "baker_version", "");
  (void)r.Field(doc, "assets", "", json::value_t::object);
  if (!r.error().ok()) return r.error();
  if (!asset_error.ok()) return asset_error;
  return catalog;
}

std::string ChannelToJson(const ChannelPointer& channel) {
  json doc{{"schema", "impostor-channel"},
           {"schema_version", channel.schema_version},
           {"channel", channel.channel},
           {"catalog", {{"sha256", channel.catalog_sha256}, {"size_bytes", channel.catalog_size_bytes}}},
           {"published_at", channel.published_at}};
  if (channel.signature.has_value()) {
    doc["signature"] = json{{"algorithm", channel.signature->algorithm},
                            {"key_id", channel.signature->key_id},
                            {"value", channel.signature->value}};
  }
  return doc.dump(2) + "\n";
}

absl::StatusOr<ChannelPointer> ParseChannel(absl::string_view text, absl::string_view source) {
  absl::StatusOr<json> doc = ParseJson(text, source, "channel file");
  if (!doc.ok()) return doc.status();
  Reader r(source);
  ChannelPointer channel;
  if (absl::Status s = CheckSchema(r, *doc, "impostor-channel", kChannelSchemaVersion, source,
                                   &channel.schema_version);
      !s.ok()) {
    return s;
  }
  channel.channel = r.String(*doc, "channel", "");
  json* catalog = r.Field(*doc, "catalog", "", json::value_t::object);
  if (catalog != nullptr) {
    channel.catalog_sha256 = r.String(*catalog, "sha256", "catalog.");
    r.Hex(channel.catalog_sha256, "catalog.", "sha256");
    channel.catalog_size_bytes = r.Count(*catalog, "size_bytes", "catalog.");
    if (r.error().ok() && channel.catalog_size_bytes > kMaxCatalogBytes) {
      r.Fail("catalog.size_bytes", absl::StrCat(channel.catalog_size_bytes, " is over the limit of ",
                                                kMaxCatalogBytes, " bytes"));
    }
  }
  if (doc->contains("published_at")) channel.published_at = r.String(*doc, "published_at", "");
  if (doc->contains("signature")) {
    json* sig = r.Field(*doc, "signature", "", json::value_t::object);
    if (sig != nullptr) {
      CatalogSignature s;
      s.algorithm = r.String(*sig, "algorithm", "signature.");
      s.key_id = r.String(*sig, "key_id", "signature.");
      s.value = r.String(*sig, "value", "signature.");
      channel.signature = std::move(s);
    }
  }
  if (!r.error().ok()) return r.error();
  if (absl::Status s = ValidateChannelName(channel.channel, absl::StrCat(source, ": channel")); !s.ok()) return s;
  return channel;
}

absl::StatusOr<CatalogAsset> AssetFromManifest(const v1::Manifest& manifest, bool include_quality_views) {
  CatalogAsset asset;
  asset.cache_key = manifest.cache_key();
  asset.product = std::string(ProductJsonName(manifest.product()));
  asset.layout = std::string(LayoutJsonName(manifest.layout()));
  asset.frames = manifest.frames();
  asset.resolution = manifest.resolution();
  asset.baker_version = manifest.baker_version();
  for (const v1::MapFile& map : manifest.maps()) {
    if (!include_quality_views && IsQualityViewSemantic(map.semantic())) continue;
    if (map.file().empty() || map.file().find('/') != std::string::npos || map.file() == kManifestName) {
      return absl::InvalidArgumentError(
          absl::StrCat("result ", manifest.cache_key(), ": map file \"", map.file().substr(0, 80),
                       "\" is not a plain file name"));
    }
    if (!IsSha256Hex(map.digest().hash())) {
      return absl::InvalidArgumentError(
          absl::StrCat("result ", manifest.cache_key(), ": map ", map.file(), " has no SHA-256 digest"));
    }
    asset.files.push_back(CatalogFile{map.file(), map.semantic(), map.digest().hash(), map.digest().size_bytes(),
                                      MediaTypeForFile(map.file()), map.width(), map.height(), map.format()});
  }
  if (!IsSha256Hex(manifest.manifest_json().hash())) {
    return absl::InvalidArgumentError(absl::StrCat("result ", manifest.cache_key(), ": manifest.json has no digest"));
  }
  asset.manifest_sha256 = manifest.manifest_json().hash();
  asset.manifest_size_bytes = manifest.manifest_json().size_bytes();
  asset.files.push_back(CatalogFile{kManifestName, "manifest", asset.manifest_sha256, asset.manifest_size_bytes,
                                    "application/json", 0, 0, "json"});
  return asset;
}

v1::Manifest ManifestFromAsset(const CatalogAsset& asset) {
  v1::Manifest m;
  m.set_cache_key(asset.cache_key);
  m.set_baker_version(asset.baker_version);
  m.set_frames(asset.frames);
  m.set_resolution(asset.resolution);
  for (v1::Layout l : {v1::LAYOUT_OCTAHEDRAL, v1::LAYOUT_HEMI_OCTAHEDRAL, v1::LAYOUT_AZIMUTH_ELEVATION,
                       v1::LAYOUT_RING_TOP, v1::LAYOUT_BILLBOARD}) {
    if (asset.layout == LayoutJsonName(l)) m.set_layout(l);
  }
  for (v1::Product p : {v1::PRODUCT_ATLAS, v1::PRODUCT_SURFELS, v1::PRODUCT_CARDS, v1::PRODUCT_LOD_CHAIN}) {
    if (asset.product == ProductJsonName(p)) m.set_product(p);
  }
  for (const CatalogFile& f : asset.files) {
    if (f.name == kManifestName) continue;
    v1::MapFile* map = m.add_maps();
    map->set_semantic(f.semantic);
    map->set_file(f.name);
    map->mutable_digest()->set_hash(f.sha256);
    map->mutable_digest()->set_size_bytes(f.size_bytes);
    map->set_width(f.width);
    map->set_height(f.height);
    map->set_format(f.format);
  }
  m.mutable_manifest_json()->set_hash(asset.manifest_sha256);
  m.mutable_manifest_json()->set_size_bytes(asset.manifest_size_bytes);
  return m;
}

}  // namespace impostor::delivery
