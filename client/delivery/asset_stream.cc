#include "client/delivery/asset_stream.h"

#include <optional>
#include <utility>

namespace impostor::delivery {
namespace {

using json = nlohmann::json;
// nlohmann's own DOM builder (what json::parse uses), fed the events of one
// value at a time.
using DomBuilder = nlohmann::detail::json_sax_dom_parser<json>;

class StreamingHandler final : public nlohmann::json_sax<json> {
 public:
  StreamingHandler(json* doc, const std::function<void(std::string, json)>& on_asset)
      : doc_builder_(*doc, /*allow_exceptions=*/false), on_asset_(on_asset) {}

  bool null() override { return Scalar([](DomBuilder& b) { return b.null(); }); }
  bool boolean(bool v) override { return Scalar([v](DomBuilder& b) { return b.boolean(v); }); }
  bool number_integer(number_integer_t v) override {
    return Scalar([v](DomBuilder& b) { return b.number_integer(v); });
  }
  bool number_unsigned(number_unsigned_t v) override {
    return Scalar([v](DomBuilder& b) { return b.number_unsigned(v); });
  }
  bool number_float(number_float_t v, const string_t& s) override {
    return Scalar([&](DomBuilder& b) { return b.number_float(v, s); });
  }
  bool string(string_t& v) override { return Scalar([&](DomBuilder& b) { return b.string(v); }); }
  bool binary(binary_t& v) override { return Scalar([&](DomBuilder& b) { return b.binary(v); }); }

  bool start_object(std::size_t n) override {
    return Open(/*object=*/true, [n](DomBuilder& b) { return b.start_object(n); });
  }
  bool start_array(std::size_t n) override {
    return Open(/*object=*/false, [n](DomBuilder& b) { return b.start_array(n); });
  }
  bool end_object() override { return Close([](DomBuilder& b) { return b.end_object(); }); }
  bool end_array() override { return Close([](DomBuilder& b) { return b.end_array(); }); }

  bool key(string_t& k) override {
    if (asset_depth_ > 0) return asset_builder_->key(k);
    if (doc_depth_ == 2 && in_assets_) {
      asset_name_ = k;  // the next value is an asset's: not the document's
      return true;
    }
    if (doc_depth_ == 1) top_key_ = k;
    return doc_builder_.key(k);
  }

  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override { return false; }

 private:
  // Whether the next value starts an asset: a member of "assets".
  bool AtAsset() const { return asset_depth_ == 0 && doc_depth_ == 2 && in_assets_; }

  template <typename F>
  bool Scalar(F event) {
    if (asset_depth_ > 0) return event(*asset_builder_);
    if (AtAsset()) {
      json value;
      DomBuilder builder(value, false);
      if (!event(builder)) return false;
      on_asset_(std::move(asset_name_), std::move(value));
      return true;
    }
    return event(doc_builder_);
  }

  template <typename F>
  bool Open(bool object, F event) {
    if (asset_depth_ > 0) {
      ++asset_depth_;
      return event(*asset_builder_);
    }
    if (AtAsset()) {
      asset_ = json();
      asset_builder_.emplace(asset_, false);
      asset_depth_ = 1;
      return event(*asset_builder_);
    }
    ++doc_depth_;
    // "assets" opened as an object right under the top-level object (keys
    // at depth 1 come only from an object).
    if (doc_depth_ == 2 && object && top_key_ == "assets") in_assets_ = true;
    return event(doc_builder_);
  }

  template <typename F>
  bool Close(F event) {
    if (asset_depth_ > 0) {
      if (!event(*asset_builder_)) return false;
      if (--asset_depth_ == 0) {
        asset_builder_.reset();
        on_asset_(std::move(asset_name_), std::move(asset_));
        asset_ = json();
      }
      return true;
    }
    if (doc_depth_ == 2) in_assets_ = false;
    --doc_depth_;
    return event(doc_builder_);
  }

  DomBuilder doc_builder_;
  const std::function<void(std::string, json)>& on_asset_;
  int doc_depth_ = 0;    // containers open in the document
  std::string top_key_;  // the last key of the top-level object
  bool in_assets_ = false;  // the document's open container is the top-level "assets" object
  std::string asset_name_;
  json asset_;
  std::optional<DomBuilder> asset_builder_;
  int asset_depth_ = 0;  // containers open in the current asset (0: none being built)
};

}  // namespace

bool ParseWithStreamedAssets(absl::string_view text, json* doc,
                             const std::function<void(std::string name, json value)>& on_asset) {
  StreamingHandler handler(doc, on_asset);
  return json::sax_parse(text.begin(), text.end(), &handler, json::input_format_t::json, /*strict=*/true);
}

}  // namespace impostor::delivery
