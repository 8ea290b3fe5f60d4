#include "client/cli/batch_spec.h"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace impostor::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

absl::Status Bad(const std::string& where, const std::string& what) {
  return absl::InvalidArgumentError(absl::StrCat(where, ": ", what));
}

// How a value appears in a message: its JSON text (cut short) and type.
std::string Shown(const json& v) {
  std::string text = v.dump(-1, ' ', false, json::error_handler_t::replace);
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  return absl::StrCat(text, " (", v.type_name(), ")");
}

absl::StatusOr<uint32_t> WholeNumber(const std::string& where, const json& v) {
  if (v.is_number_unsigned() && v.get<uint64_t>() <= UINT32_MAX) return static_cast<uint32_t>(v.get<uint64_t>());
  if (v.is_number_integer() && v.get<int64_t>() >= 0 && v.get<int64_t>() <= UINT32_MAX) {
    return static_cast<uint32_t>(v.get<int64_t>());
  }
  return Bad(where, absl::StrCat("expected a whole number, 0 or more, got ", Shown(v)));
}

absl::StatusOr<double> NumberIn(const std::string& where, const json& v, double lo, double hi) {
  if (!v.is_number()) return Bad(where, absl::StrCat("expected a number in ", lo, "..", hi, ", got ", Shown(v)));
  const double d = v.get<double>();
  if (!(d >= lo && d <= hi)) return Bad(where, absl::StrCat(d, " is out of range ", lo, "..", hi));
  return d;
}

absl::StatusOr<std::string> String(const std::string& where, const json& v) {
  if (!v.is_string() || v.get<std::string>().empty()) {
    return Bad(where, absl::StrCat("expected a non-empty string, got ", Shown(v)));
  }
  return v.get<std::string>();
}

// The settings keys shared by `defaults` and assets, each writing one field.
using Setter = std::function<absl::Status(const std::string& where, const json& v, sdk::BakeSettings& s)>;

const std::map<std::string, Setter>& SettingKeys() {
  static const auto* keys = new std::map<std::string, Setter>{
      {"layout",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         auto str = String(where, v);
         if (!str.ok()) return str.status();
         s.layout = *str;
         return absl::OkStatus();
       }},
      {"product",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         auto str = String(where, v);
         if (!str.ok()) return str.status();
         s.product = *str;
         return absl::OkStatus();
       }},
      {"preset",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         auto str = String(where, v);
         if (!str.ok()) return str.status();
         s.preset = *str;
         return absl::OkStatus();
       }},
      {"frames",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         if (v.is_string() && v.get<std::string>() == "auto") {
           s.frames_auto = true;
           s.frames = 0;
           return absl::OkStatus();
         }
         auto n = WholeNumber(where, v);
         if (!n.ok()) return Bad(where, absl::StrCat("expected a whole number, 0 or more, or \"auto\", got ",
                                                     Shown(v)));
         s.frames = *n;
         s.frames_auto = false;
         return absl::OkStatus();
       }},
      {"ring_views",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         auto n = WholeNumber(where, v);
         if (!n.ok()) return n.status();
         s.ring_views = *n;
         return absl::OkStatus();
       }},
      {"quality_views",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         auto n = WholeNumber(where, v);
         if (!n.ok()) return n.status();
         s.quality_views = *n;
         return absl::OkStatus();
       }},
      {"max_planes",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         auto n = WholeNumber(where, v);
         if (!n.ok()) return n.status();
         s.max_planes = *n;
         return absl::OkStatus();
       }},
      {"tolerance",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         if (!v.is_number()) return Bad(where, absl::StrCat("expected a number, got ", Shown(v)));
         s.tolerance = v.get<float>();
         return absl::OkStatus();
       }},
      {"lod_pixel_error",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         if (!v.is_number()) return Bad(where, absl::StrCat("expected a number, got ", Shown(v)));
         s.lod_pixel_error = v.get<float>();
         return absl::OkStatus();
       }},
      {"lod_ratios",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         if (!v.is_array()) return Bad(where, absl::StrCat("expected a list of numbers, got ", Shown(v)));
         s.lod_ratios.clear();
         for (size_t i = 0; i < v.size(); ++i) {
           if (!v[i].is_number()) {
             return Bad(absl::StrCat(where, "[", i, "]"), absl::StrCat("expected a number, got ", Shown(v[i])));
           }
           s.lod_ratios.push_back(v[i].get<float>());
         }
         return absl::OkStatus();
       }},
      {"emissive",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         if (!v.is_boolean()) return Bad(where, absl::StrCat("expected true or false, got ", Shown(v)));
         s.emissive = v.get<bool>();
         return absl::OkStatus();
       }},
      {"texture_array",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         if (!v.is_boolean()) return Bad(where, absl::StrCat("expected true or false, got ", Shown(v)));
         s.texture_array = v.get<bool>();
         return absl::OkStatus();
       }},
      {"texture_format",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         if (!v.is_string() || (v.get<std::string>() != "png" && v.get<std::string>() != "ktx2")) {
           return Bad(where, absl::StrCat("expected \"png\" or \"ktx2\", got ", Shown(v)));
         }
         s.texture_format = v.get<std::string>();
         return absl::OkStatus();
       }},
      {"albedo_codec",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         if (!v.is_string() || (v.get<std::string>() != "uastc" && v.get<std::string>() != "uastc-rdo")) {
           return Bad(where, absl::StrCat("expected \"uastc\" or \"uastc-rdo\", got ", Shown(v)));
         }
         s.albedo_codec = v.get<std::string>();
         return absl::OkStatus();
       }},
      {"supersampling",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         auto n = WholeNumber(where, v);
         if (!n.ok()) return n.status();
         s.supersampling = *n;
         return absl::OkStatus();
       }},
      {"resolution",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         auto n = WholeNumber(where, v);
         if (!n.ok()) return n.status();
         s.resolution = *n;
         return absl::OkStatus();
       }},
      {"point_budget",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         auto n = WholeNumber(where, v);
         if (!n.ok()) return n.status();
         s.point_budget = *n;
         return absl::OkStatus();
       }},
      {"priority",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         if (!v.is_number_integer()) {
           return Bad(where, absl::StrCat("expected a whole number in -100..100, got ", Shown(v)));
         }
         const int64_t p = v.get<int64_t>();
         if (p < -100 || p > 100) return Bad(where, absl::StrCat(p, " is out of range -100..100"));
         s.priority = static_cast<int32_t>(p);
         return absl::OkStatus();
       }},
      {"min_iou",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         auto d = NumberIn(where, v, 0, 1);
         if (!d.ok()) return d.status();
         s.min_iou = static_cast<float>(*d);
         return absl::OkStatus();
       }},
      {"min_psnr_db",
       [](const std::string& where, const json& v, sdk::BakeSettings& s) -> absl::Status {
         auto d = NumberIn(where, v, 0, 100);
         if (!d.ok()) return d.status();
         s.min_psnr_db = static_cast<float>(*d);
         return absl::OkStatus();
       }},
  };
  return *keys;
}

std::string KnownKeys(const std::vector<std::string>& extra) {
  std::vector<std::string> names = extra;
  for (const auto& [name, setter] : SettingKeys()) names.push_back(name);
  return absl::StrJoin(names, ", ");
}

// Applies every key of `object` to `settings`; `extra` are keys the caller
// handles itself (path, name).
absl::Status ApplySettings(const std::string& where, const json& object, const std::vector<std::string>& extra,
                           sdk::BakeSettings& settings, bool* priority_given) {
  for (const auto& [key, value] : object.items()) {
    if (std::find(extra.begin(), extra.end(), key) != extra.end()) continue;
    auto it = SettingKeys().find(key);
    if (it == SettingKeys().end()) {
      return Bad(where, absl::StrCat("unknown key \"", key, "\"; known keys: ", KnownKeys(extra)));
    }
    if (auto s = it->second(absl::StrCat(where, ".", key), value, settings); !s.ok()) return s;
    if (key == "priority" && priority_given != nullptr) *priority_given = true;
  }
  return absl::OkStatus();
}

bool ValidName(const std::string& name) {
  return !name.empty() && name != "." && name != ".." && name.find('/') == std::string::npos &&
         name.find('\\') == std::string::npos && name.find('\0') == std::string::npos && name.size() <= 200;
}

// YAML scalars carry no type: a plain (unquoted) one is read as null, a
// boolean or a number when it looks like one (YAML 1.2 core schema), a
// quoted one is always a string.
json YamlToJson(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
    case YAML::NodeType::Undefined: return nullptr;
    case YAML::NodeType::Sequence: {
      json out = json::array();
      for (const auto& item : node) out.push_back(YamlToJson(item));
      return out;
    }
    case YAML::NodeType::Map: {
      json out = json::object();
      for (const auto& kv : node) out[kv.first.as<std::string>()] = YamlToJson(kv.second);
      return out;
    }
    case YAML::NodeType::Scalar: break;
  }
  const std::string text = node.Scalar();
  if (node.Tag() == "!") return text;  // quoted
  if (text == "null" || text == "~" || text.empty()) return nullptr;
  if (text == "true") return true;
  if (text == "false") return false;
  try {
    size_t used = 0;
    const long long i = std::stoll(text, &used);
    if (used == text.size()) return i;
    const double d = std::stod(text, &used);
    if (used == text.size() && std::isfinite(d)) return d;
  } catch (const std::exception&) {
  }
  return text;
}

absl::StatusOr<json> ParseText(std::string_view text, SpecFormat format) {
  if (format == SpecFormat::kAuto) {
    const size_t first = text.find_first_not_of(" \t\r\n");
    format = first != std::string_view::npos && (text[first] == '{' || text[first] == '[') ? SpecFormat::kJson
                                                                                            : SpecFormat::kYaml;
  }
  if (format == SpecFormat::kJson) {
    json parsed = json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (parsed.is_discarded()) {
      // Parse again for the message with line and column.
      try {
        json again = json::parse(text);
        (void)again;
      } catch (const json::parse_error& e) {
        return absl::InvalidArgumentError(absl::StrCat("SPEC: invalid JSON: ", e.what()));
      }
      return absl::InvalidArgumentError("SPEC: invalid JSON");
    }
    return parsed;
  }
  try {
    return YamlToJson(YAML::Load(std::string(text)));
  } catch (const YAML::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat("SPEC: invalid YAML at line ", e.mark.line + 1, ", column ",
                                                   e.mark.column + 1, ": ", e.msg));
  }
}

// The last `depth` components of the model's path without extension, joined
// with '_': depth 1 = "scene", 2 = "TreeLowPoly_RicardoSanchez_scene".
std::string NameAtDepth(const fs::path& model, int depth) {
  std::vector<std::string> parts;
  fs::path p = model.lexically_normal();
  parts.push_back(p.stem().string());
  p = p.parent_path();
  for (int d = 1; d < depth && !p.empty() && p.filename() != "" && p != p.root_path(); ++d) {
    parts.insert(parts.begin(), p.filename().string());
    p = p.parent_path();
  }
  std::string name = absl::StrJoin(parts, "_");
  return ValidName(name) ? name : "model";
}

absl::Status CheckModel(const std::string& where, const fs::path& model, const std::string& as_written) {
  std::error_code ec;
  if (fs::is_regular_file(model, ec)) return absl::OkStatus();
  if (fs::exists(model, ec)) return Bad(where, absl::StrCat("\"", as_written, "\" is not a file"));
  return Bad(where, absl::StrCat("\"", as_written, "\" not found (looked at ", fs::absolute(model, ec).lexically_normal().string(), ")"));
}

}  // namespace

void AssignNames(std::vector<BatchEntry>& entries, const std::vector<bool>& explicit_name) {
  std::set<std::string> taken;
  for (size_t i = 0; i < entries.size(); ++i) {
    if (explicit_name[i]) taken.insert(entries[i].name);
  }
  // Each implicit name starts as the bare file stem; names shared by
  // different files (or taken by an explicit one) grow by a parent folder,
  // for those files only, until they differ.
  auto normal = [](const fs::path& p) {
    std::error_code ec;
    return fs::weakly_canonical(p, ec).string();
  };
  std::vector<int> depth(entries.size(), 1);
  for (int round = 0; round < 8; ++round) {
    std::map<std::string, std::set<std::string>> models_by_name;  // name -> distinct model files
    for (size_t i = 0; i < entries.size(); ++i) {
      if (!explicit_name[i]) models_by_name[NameAtDepth(entries[i].model, depth[i])].insert(normal(entries[i].model));
    }
    bool grew = false;
    for (size_t i = 0; i < entries.size(); ++i) {
      if (explicit_name[i]) continue;
      const std::string name = NameAtDepth(entries[i].model, depth[i]);
      if ((models_by_name[name].size() > 1 || taken.contains(name)) &&
          NameAtDepth(entries[i].model, depth[i] + 1) != name) {
        ++depth[i];
        grew = true;
      }
    }
    if (!grew) break;
  }
  for (size_t i = 0; i < entries.size(); ++i) {
    if (!explicit_name[i]) entries[i].name = NameAtDepth(entries[i].model, depth[i]);
  }
  // The same file twice (or a clash no depth resolves): number them.
  std::set<std::string> used = taken;
  for (size_t i = 0; i < entries.size(); ++i) {
    if (explicit_name[i]) continue;
    std::string name = entries[i].name;
    for (int n = 2; used.contains(name); ++n) name = absl::StrCat(entries[i].name, "-", n);
    entries[i].name = name;
    used.insert(name);
  }
}

absl::StatusOr<BatchSpec> ParseBatchSpec(std::string_view text, SpecFormat format, const fs::path& base_dir,
                                         std::optional<int32_t> priority) {
  absl::StatusOr<json> parsed = ParseText(text, format);
  if (!parsed.ok()) return parsed.status();
  json root = std::move(*parsed);
  if (root.is_array()) root = json{{"assets", root}};
  if (!root.is_object()) {
    return Bad("SPEC", absl::StrCat("expected an object {\"defaults\": {...}, \"assets\": [...]} or a list, got ",
                                    Shown(root)));
  }
  for (const auto& [key, value] : root.items()) {
    if (key != "defaults" && key != "assets") {
      return Bad("SPEC", absl::StrCat("unknown key \"", key, "\"; known keys: defaults, assets"));
    }
  }
  sdk::BakeSettings defaults;
  if (root.contains("defaults")) {
    const json& d = root["defaults"];
    if (!d.is_object()) return Bad("defaults", absl::StrCat("expected an object, got ", Shown(d)));
    if (auto s = ApplySettings("defaults", d, {}, defaults, nullptr); !s.ok()) return s;
  }
  if (priority.has_value()) defaults.priority = *priority;  // --priority beats the spec's defaults
  if (!root.contains("assets")) return Bad("SPEC", "missing \"assets\": the list of models to bake");
  const json& assets = root["assets"];
  if (!assets.is_array()) return Bad("assets", absl::StrCat("expected a list, got ", Shown(assets)));
  if (assets.empty()) return Bad("assets", "the list is empty; nothing to bake");

  BatchSpec spec;
  std::vector<bool> explicit_name;
  std::map<std::string, size_t> names;
  for (size_t i = 0; i < assets.size(); ++i) {
    const json& a = assets[i];
    std::string where = absl::StrCat("assets[", i, "]");
    BatchEntry entry;
    entry.settings = defaults;
    bool named = false;
    if (a.is_string()) {
      entry.asset = a.get<std::string>();
      if (entry.asset.empty()) return Bad(where, "empty path");
    } else if (a.is_object()) {
      if (!a.contains("path")) return Bad(where, "missing \"path\" (the model file)");
      auto path = String(absl::StrCat(where, ".path"), a["path"]);
      if (!path.ok()) return path.status();
      entry.asset = *path;
      where = absl::StrCat(where, " (\"", entry.asset, "\")");
      if (auto s = ApplySettings(where, a, {"path", "name"}, entry.settings, nullptr); !s.ok()) return s;
      if (a.contains("name")) {
        auto name = String(absl::StrCat(where, ".name"), a["name"]);
        if (!name.ok()) return name.status();
        if (!ValidName(*name)) {
          return Bad(absl::StrCat(where, ".name"),
                     absl::StrCat("\"", *name, "\" is not a folder name (no '/', '\\', \".\" or \"..\")"));
        }
        if (auto [it, fresh] = names.emplace(*name, i); !fresh) {
          return Bad(absl::StrCat(where, ".name"), absl::StrCat("\"", *name, "\" is also the name of assets[",
                                                                 it->second, "]"));
        }
        entry.name = *name;
        named = true;
      }
    } else {
      return Bad(where, absl::StrCat("expected a model path or an object with \"path\", got ", Shown(a)));
    }
    // As `bake --product lod-chain` without --layout: a LOD chain's
    // impostor takes the server's default (hemi-octahedral), not the SDK's
    // "octahedral" sent as given.
    const bool layout_given =
        (root.contains("defaults") && root["defaults"].contains("layout")) || (a.is_object() && a.contains("layout"));
    if (entry.settings.product == "lod-chain" && !layout_given) entry.settings.layout.clear();
    entry.model = fs::path(entry.asset).is_absolute() ? fs::path(entry.asset) : base_dir / entry.asset;
    if (auto s = CheckModel(a.is_object() ? absl::StrCat(where, ".path") : where, entry.model, entry.asset); !s.ok()) {
      return s;
    }
    spec.entries.push_back(std::move(entry));
    explicit_name.push_back(named);
  }
  AssignNames(spec.entries, explicit_name);
  return spec;
}

absl::StatusOr<BatchSpec> LoadBatchSpec(const std::string& spec, std::optional<int32_t> priority) {
  std::string text;
  SpecFormat format = SpecFormat::kAuto;
  fs::path base_dir = ".";
  if (spec == "-") {
    text.assign(std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>());
  } else {
    std::ifstream in(spec, std::ios::binary);
    if (!in) return Bad("SPEC", absl::StrCat("cannot read ", spec, ": ", std::strerror(errno)));
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    const std::string ext = fs::path(spec).extension().string();
    format = ext == ".yaml" || ext == ".yml" ? SpecFormat::kYaml : SpecFormat::kJson;
    base_dir = fs::path(spec).parent_path();
    if (base_dir.empty()) base_dir = ".";
  }
  return ParseBatchSpec(text, format, base_dir, priority);
}

absl::StatusOr<BatchSpec> BatchFromModels(const std::vector<std::string>& models, const sdk::BakeSettings& settings) {
  BatchSpec spec;
  for (size_t i = 0; i < models.size(); ++i) {
    BatchEntry entry{.asset = models[i], .model = models[i], .name = "", .settings = settings};
    if (auto s = CheckModel(absl::StrCat("MODEL ", i + 1), entry.model, entry.asset); !s.ok()) return s;
    spec.entries.push_back(std::move(entry));
  }
  AssignNames(spec.entries, std::vector<bool>(spec.entries.size(), false));
  return spec;
}

}  // namespace impostor::cli
