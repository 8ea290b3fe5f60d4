#include "common/manifest/cards_manifest_json.h"

#include <string>
#include <vector>

#include "absl/strings/str_cat.h"

namespace impostor {

using nlohmann::json;

json CardsToJson(const v1::CardCluster& c) {
  json planes = json::array();
  for (const v1::CardPlane& p : c.planes()) planes.push_back(std::vector<float>(p.plane().begin(), p.plane().end()));
  json cards = json::array();
  for (const v1::Card& card : c.cards()) {
    cards.push_back({{"corners", std::vector<float>(card.corners().begin(), card.corners().end())},
                     {"triangles", card.triangles()},
                     {"texels", card.texels()},
                     {"tile", {card.tile().x(), card.tile().y(), card.tile().width(), card.tile().height()}},
                     {"max_distance", card.max_distance()},
                     {"mean_distance", card.mean_distance()}});
  }
  const v1::CardQuality& q = c.quality();
  return {{"file", c.file()},
          {"digest", {{"hash", c.digest().hash()}, {"size_bytes", c.digest().size_bytes()}}},
          {"tolerance", c.tolerance()},
          {"max_distance", c.max_distance()},
          {"mean_distance", c.mean_distance()},
          {"budget_exhausted", c.budget_exhausted()},
          {"triangles", c.triangles()},
          {"planes", planes},
          {"triangle_plane", std::vector<uint32_t>(c.triangle_plane().begin(), c.triangle_plane().end())},
          {"cards", cards},
          {"quality",
           {{"views", q.views()},
            {"silhouette_iou_mean", q.silhouette_iou_mean()},
            {"silhouette_iou_min", q.silhouette_iou_min()},
            {"albedo_psnr_db", q.albedo_psnr_db()}}}};
}

absl::Status ReadCards(const json& manifest, v1::Manifest* m) {
  auto it = manifest.find("cards");
  if (it == manifest.end() || !it->is_object()) {
    return absl::InvalidArgumentError("manifest.json: cards: missing or not an object for product cards");
  }
  const json& j = *it;
  v1::CardCluster* c = m->mutable_cards();
  std::string key = "cards.";
  try {
    key = "cards.file";
    c->set_file(j.at("file").get<std::string>());
    key = "cards.digest";
    c->mutable_digest()->set_hash(j.at("digest").at("hash").get<std::string>());
    c->mutable_digest()->set_size_bytes(j.at("digest").at("size_bytes").get<int64_t>());
    key = "cards.tolerance";
    c->set_tolerance(j.at("tolerance").get<float>());
    key = "cards.max_distance";
    c->set_max_distance(j.at("max_distance").get<float>());
    key = "cards.mean_distance";
    c->set_mean_distance(j.at("mean_distance").get<float>());
    key = "cards.budget_exhausted";
    c->set_budget_exhausted(j.at("budget_exhausted").get<bool>());
    key = "cards.triangles";
    c->set_triangles(j.at("triangles").get<uint32_t>());
    key = "cards.planes";
    const json& planes = j.at("planes");
    if (!planes.is_array()) return absl::InvalidArgumentError("manifest.json: cards.planes: not an array");
    for (size_t i = 0; i < planes.size(); ++i) {
      key = absl::StrCat("cards.planes[", i, "]");
      const auto p = planes[i].get<std::vector<float>>();
      if (p.size() != 4) return absl::InvalidArgumentError("manifest.json: " + key + ": expected [nx, ny, nz, d]");
      v1::CardPlane* plane = c->add_planes();
      for (float f : p) plane->add_plane(f);
    }
    key = "cards.triangle_plane";
    for (uint32_t t : j.at("triangle_plane").get<std::vector<uint32_t>>()) {
      if (t >= static_cast<uint32_t>(c->planes_size())) {
        return absl::InvalidArgumentError(absl::StrCat("manifest.json: cards.triangle_plane: plane ", t,
                                                       " does not exist (", c->planes_size(), " planes)"));
      }
      c->add_triangle_plane(t);
    }
    key = "cards.cards";
    const json& cards = j.at("cards");
    if (!cards.is_array()) return absl::InvalidArgumentError("manifest.json: cards.cards: not an array");
    for (size_t i = 0; i < cards.size(); ++i) {
      const std::string path = absl::StrCat("cards.cards[", i, "].");
      v1::Card* card = c->add_cards();
      key = path + "corners";
      const auto corners = cards[i].at("corners").get<std::vector<float>>();
      if (corners.size() != 12) return absl::InvalidArgumentError("manifest.json: " + key + ": expected 12 numbers");
      for (float f : corners) card->add_corners(f);
      key = path + "triangles";
      card->set_triangles(cards[i].at("triangles").get<uint32_t>());
      key = path + "texels";
      card->set_texels(cards[i].at("texels").get<uint64_t>());
      key = path + "tile";
      const auto tile = cards[i].at("tile").get<std::vector<uint32_t>>();
      if (tile.size() != 4) return absl::InvalidArgumentError("manifest.json: " + key + ": expected [x, y, w, h]");
      card->mutable_tile()->set_x(tile[0]);
      card->mutable_tile()->set_y(tile[1]);
      card->mutable_tile()->set_width(tile[2]);
      card->mutable_tile()->set_height(tile[3]);
      key = path + "max_distance";
      card->set_max_distance(cards[i].at("max_distance").get<float>());
      key = path + "mean_distance";
      card->set_mean_distance(cards[i].at("mean_distance").get<float>());
    }
  } catch (const json::exception&) {
    return absl::InvalidArgumentError("manifest.json: " + key + ": missing or wrong type");
  }
  if (auto q = j.find("quality"); q != j.end() && q->is_object()) {
    v1::CardQuality* quality = c->mutable_quality();
    quality->set_views(q->value("views", 0u));
    quality->set_silhouette_iou_mean(q->value("silhouette_iou_mean", 0.0f));
    quality->set_silhouette_iou_min(q->value("silhouette_iou_min", 0.0f));
    quality->set_albedo_psnr_db(q->value("albedo_psnr_db", 0.0f));
  }
  return absl::OkStatus();
}

}  // namespace impostor
