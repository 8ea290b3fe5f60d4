#include "client/cache/manifest_summary.h"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace impostor::sdk {
namespace {

// Picks the summary's fields out of the token stream (nlohmann's SAX
// interface) instead of building the whole document: a baked result's
// manifest is mostly its per-view quality records (72 KB for a 12 x 12
// atlas), which a summary only counts. The document parse was 3.6 % of the
// CPU of a fleet of first fetches (bench/fleet_bench), each entry's view
// built once after its install.
class SummaryReader : public nlohmann::json_sax<nlohmann::json> {
 public:
  // The summary the whole document gives; defaults when it was not an object.
  ManifestSummary Finish() const {
    ManifestSummary out;
    if (!top_is_object_) return out;
    if (product_) out.product = *product_;
    out.view_count = views_ ? *views_ : 0;
    // A strip one tile wide and a tile per view high: what the manifest says
    // of texture-array maps (there is no flag of its own). The last
    // albedo_alpha map decides, as its key order may not.
    if (tile_size_ && maps_are_array_ && out.view_count > 1) {
      const uint64_t t = *tile_size_;
      for (const Map& map : maps_) {
        if (map.semantic == "albedo_alpha") {
          out.texture_array = map.width == t && map.height == t * out.view_count;
        }
      }
    }
    return out;
  }

  bool null() override { return Value(); }
  bool boolean(bool) override { return Value(); }
  bool number_integer(number_integer_t v) override { return Number(static_cast<uint64_t>(v), false); }
  bool number_unsigned(number_unsigned_t v) override { return Number(v, true); }
  bool number_float(number_float_t v, const string_t&) override { return Number(static_cast<uint64_t>(v), false); }
  bool string(string_t& v) override {
    Value();
    if (depth_ == 1 && key_ == "product") product_ = v;
    if (InMap() && key_ == "semantic") maps_.back().semantic = v;
    return true;
  }
  bool binary(binary_t&) override { return Value(); }
  bool start_object(std::size_t) override { return Open(/*object=*/true); }
  bool end_object() override { return Close(); }
  bool start_array(std::size_t) override { return Open(/*object=*/false); }
  bool end_array() override { return Close(); }
  bool key(string_t& k) override {
    if (depth_ == 1 || InMap()) key_ = k;
    return true;
  }
  // A document that does not parse summarises as none.
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override { return false; }

 private:
  // An element of "maps" (one that is no object keeps no semantic).
  struct Map {
    std::string semantic;
    uint64_t width = 0;
    uint64_t height = 0;
  };

  // Inside one element of the top-level "maps" array, at its own level.
  bool InMap() const { return depth_ == 3 && in_maps_; }

  // Every value, where it starts. A top-level key given twice counts with
  // its last value, as in a parsed document: what an earlier one set goes.
  // An element of "views" is counted, one of "maps" gets its record.
  bool Value() {
    if (depth_ == 1) {
      if (key_ == "product") product_.reset();
      if (key_ == "tile_size") tile_size_.reset();
      if (key_ == "views") views_.reset();
      if (key_ == "maps") {
        maps_are_array_ = false;
        maps_.clear();
      }
    } else if (depth_ == 2 && in_views_) {
      *views_ += 1;
    } else if (depth_ == 2 && in_maps_) {
      maps_.emplace_back();
    }
    return true;
  }
  bool Number(uint64_t v, bool is_unsigned) {
    Value();
    if (depth_ == 1 && key_ == "tile_size" && is_unsigned) tile_size_ = v;
    if (InMap() && key_ == "width") maps_.back().width = v;
    if (InMap() && key_ == "height") maps_.back().height = v;
    return true;
  }
  bool Open(bool object) {
    if (depth_ == 0) top_is_object_ = object;
    Value();
    if (depth_ == 1 && !object) {
      in_views_ = key_ == "views";
      in_maps_ = key_ == "maps";
      if (in_views_) views_ = 0;
      if (in_maps_) maps_are_array_ = true;
    }
    ++depth_;
    return true;
  }
  bool Close() {
    --depth_;
    if (depth_ == 1) in_views_ = in_maps_ = false;
    return true;
  }

  int depth_ = 0;
  std::string key_;  // the last key at the top level, or inside a map
  bool top_is_object_ = false;
  std::optional<std::string> product_;
  std::optional<uint32_t> views_;
  std::optional<uint64_t> tile_size_;
  bool in_views_ = false;
  bool in_maps_ = false;
  bool maps_are_array_ = false;
  std::vector<Map> maps_;
};

}  // namespace

ManifestSummary SummarizeManifest(std::string_view manifest_json) {
  SummaryReader reader;
  if (!nlohmann::json::sax_parse(manifest_json, &reader)) return ManifestSummary{};
  return reader.Finish();
}

}  // namespace impostor::sdk
