// The batch that `impostor bake-batch SPEC` (or `impostor bake A B ...`)
// bakes: which models, under which names, with which settings. Parsing and
// validation only; nothing here talks to a server. Pure functions apart from
// reading SPEC and checking that the listed models exist; thread-safe.
//
// SPEC is JSON or YAML (the same structure either way):
//
//   {"defaults": {"frames": 8, "resolution": 512, "priority": -50},
//    "assets": ["rock.glb",
//               {"path": "trees/oak.gltf", "name": "oak", "frames": 12,
//                "min_iou": 0.95}]}
//
// A bare list is the same as {"assets": [...]}. Keys of `defaults` and of an
// asset object, one per sdk::BakeSettings field: layout, frames (a number or
// "auto"), resolution, product, preset, point_budget, ring_views,
// quality_views, emissive, lod_ratios, lod_pixel_error, max_planes,
// tolerance, priority, min_iou, min_psnr_db; an asset also has `path` (required,
// relative to SPEC's folder, or to the working directory for stdin) and
// `name` (its output folder, default: see AssignNames). An asset's own key
// wins over --priority, which wins over `defaults`.
#ifndef IMPOSTOR_CLIENT_CLI_BATCH_SPEC_H_
#define IMPOSTOR_CLIENT_CLI_BATCH_SPEC_H_

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "impostor/client.h"

namespace impostor::cli {

struct BatchEntry {
  std::string asset;            // the path as written in SPEC or on the command line
  std::filesystem::path model;  // where it is on this machine
  std::string name;             // output folder under --out: DIR/<name>/
  sdk::BakeSettings settings;
};

struct BatchSpec {
  std::vector<BatchEntry> entries;  // in SPEC order; never empty
};

enum class SpecFormat { kJson, kYaml, kAuto };

// Parses SPEC's text. `base_dir` resolves relative model paths;
// `priority` is --priority (unset = not given). INVALID_ARGUMENT naming the
// entry and field for: invalid JSON/YAML (with line and column), an unknown
// key, a value of the wrong type or out of range (priority -100..100,
// min_iou 0..1, min_psnr_db 0..100, whole numbers for frames, resolution
// and point_budget), a missing or empty `assets`, a missing `path`, a model
// that does not exist, an invalid or duplicate `name`.
absl::StatusOr<BatchSpec> ParseBatchSpec(std::string_view text, SpecFormat format,
                                         const std::filesystem::path& base_dir, std::optional<int32_t> priority);

// Reads SPEC ("-" = standard input, format detected from the first
// character; otherwise by extension: .yaml/.yml YAML, anything else JSON)
// and parses it. INVALID_ARGUMENT also when SPEC cannot be read.
absl::StatusOr<BatchSpec> LoadBatchSpec(const std::string& spec, std::optional<int32_t> priority);

// `impostor bake A B ...`: every model with the same settings.
// INVALID_ARGUMENT naming a model that does not exist.
absl::StatusOr<BatchSpec> BatchFromModels(const std::vector<std::string>& models, const sdk::BakeSettings& settings);

// Gives every entry without an explicit name a unique folder name: the
// model's file name without extension ("scene"), prefixed with as many
// parent folders as it takes to tell it from the others
// ("TreeLowPoly_RicardoSanchez_scene"), and "-2", "-3"... for the same file
// listed twice. Explicit names are kept; `explicit_name[i]` says which.
void AssignNames(std::vector<BatchEntry>& entries, const std::vector<bool>& explicit_name);

}  // namespace impostor::cli

#endif  // IMPOSTOR_CLIENT_CLI_BATCH_SPEC_H_
