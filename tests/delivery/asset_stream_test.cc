// ParseWithStreamedAssets (client/delivery/asset_stream.h): the catalog
// parser's way of never holding every asset's document at once.
#include "client/delivery/asset_stream.h"

#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

namespace impostor::delivery {
namespace {

using json = nlohmann::json;

struct Streamed {
  bool ok = false;
  json doc;
  std::vector<std::pair<std::string, json>> assets;
};

Streamed Parse(const std::string& text) {
  Streamed s;
  s.ok = ParseWithStreamedAssets(text, &s.doc, [&](std::string name, json value) {
    s.assets.emplace_back(std::move(name), std::move(value));
  });
  return s;
}

TEST(AssetStream, HandsOnEachAssetInOrderAndKeepsTheRest) {
  const Streamed s = Parse(
      R"({"schema":"impostor-catalog","assets":{"b/oak":{"files":[{"n":1},{"n":2}],"assets":{"x":1}},)"
      R"("a/fir":{"k":[1,[2,{}]]}},"created_at":"now","more":{"assets":{"y":2}}})");
  ASSERT_TRUE(s.ok);
  ASSERT_EQ(s.assets.size(), 2u);
  EXPECT_EQ(s.assets[0].first, "b/oak") << "the text's order";
  EXPECT_EQ(s.assets[0].second, json::parse(R"({"files":[{"n":1},{"n":2}],"assets":{"x":1}})"))
      << "an \"assets\" inside an asset is the asset's";
  EXPECT_EQ(s.assets[1].first, "a/fir");
  EXPECT_EQ(s.assets[1].second, json::parse(R"({"k":[1,[2,{}]]})"));
  EXPECT_EQ(s.doc, json::parse(R"({"schema":"impostor-catalog","assets":{},"created_at":"now",)"
                               R"("more":{"assets":{"y":2}}})"))
      << "the document keeps an empty \"assets\", and a deeper \"assets\" whole";
}

TEST(AssetStream, AScalarAssetIsHandedOnToo) {
  const Streamed s = Parse(R"({"assets":{"a":5,"b":"x","c":null,"d":[]}})");
  ASSERT_TRUE(s.ok);
  ASSERT_EQ(s.assets.size(), 4u);
  EXPECT_EQ(s.assets[0].second, json(5));
  EXPECT_EQ(s.assets[1].second, json("x"));
  EXPECT_TRUE(s.assets[2].second.is_null());
  EXPECT_EQ(s.assets[3].second, json::array());
}

TEST(AssetStream, OtherShapesParseAsAWholeDocument) {
  for (const char* text : {R"({"assets":[{"a":1}],"x":1})", R"({"assets":"none"})", R"([{"assets":{"a":1}}])",
                           R"("just a string")", R"({"x":{"assets":{"a":1}}})"}) {
    const Streamed s = Parse(text);
    ASSERT_TRUE(s.ok) << text;
    EXPECT_TRUE(s.assets.empty()) << text;
    EXPECT_EQ(s.doc, json::parse(text)) << text;
  }
}

TEST(AssetStream, RefusesWhatIsNotJson) {
  for (const char* text : {"", "<html>502</html>", R"({"assets":{"a":{"b":1})", R"({"assets":{"a":1}} trailing)",
                           R"({"a":1,})"}) {
    EXPECT_FALSE(Parse(text).ok) << text;
  }
}

}  // namespace
}  // namespace impostor::delivery
