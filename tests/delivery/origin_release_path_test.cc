// Which request paths name a file of a release tree (ParseReleasePath), and
// the If-None-Match comparison of the origin (IfNoneMatchMatches): tables
// whose failures name the case.
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "server/http/release_files.h"
#include "server/http/release_response.h"

namespace impostor {
namespace {

// A digest that starts "ab", and the same in upper case.
const std::string kHex = "ab" + std::string(62, '0').replace(0, 10, "0123456789");
const std::string kUpperHex = "AB" + kHex.substr(2);

TEST(ReleasePathTest, NamesExactlyTheThreeShapes) {
  struct Case {
    std::string path;
    ReleaseFileKind kind;
    std::string name;
  };
  const std::vector<Case> cases = {
      {"v1/blobs/sha256/ab/" + kHex, ReleaseFileKind::kBlob, kHex},
      {"v1/catalogs/sha256/ab/" + kHex, ReleaseFileKind::kCatalog, kHex},
      {"v1/blobs/sha256/e3/e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855", ReleaseFileKind::kBlob,
       "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"},
      {"v1/channels/nightly.json", ReleaseFileKind::kChannel, "nightly"},
      {"v1/channels/A.json", ReleaseFileKind::kChannel, "A"},
      {"v1/channels/7.json", ReleaseFileKind::kChannel, "7"},
      {"v1/channels/Release-2.0_rc.1.json", ReleaseFileKind::kChannel, "Release-2.0_rc.1"},
      {"v1/channels/a..b.json", ReleaseFileKind::kChannel, "a..b"},
      {"v1/channels/stable.json.json", ReleaseFileKind::kChannel, "stable.json"},
      {"v1/channels/" + std::string(64, 'c') + ".json", ReleaseFileKind::kChannel, std::string(64, 'c')},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.path);
    const std::optional<ReleasePath> parsed = ParseReleasePath(c.path);
    ASSERT_TRUE(parsed.has_value());
    EXPECT_EQ(parsed->kind, c.kind);
    EXPECT_EQ(parsed->name, c.name);
    EXPECT_EQ(parsed->relative, c.path);
    EXPECT_EQ(parsed->immutable(), c.kind != ReleaseFileKind::kChannel);
  }
}

TEST(ReleasePathTest, RefusesEveryOtherShape) {
  const std::string blob = "v1/blobs/sha256/ab/" + kHex;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"empty", ""},
      {"the root", "/"},
      {"v1 alone", "v1"},
      {"v1 folder", "v1/"},
      {"blobs folder", "v1/blobs"},
      {"sha256 folder", "v1/blobs/sha256"},
      {"prefix folder", "v1/blobs/sha256/ab"},
      {"prefix folder with slash", "v1/blobs/sha256/ab/"},
      {"channels folder", "v1/channels/"},
      {"leading slash", "/" + blob},
      {"trailing slash", blob + "/"},
      {"a segment after the digest", blob + "/x"},
      {"double slash", "v1//blobs/sha256/ab/" + kHex},
      {"double slash before digest", "v1/blobs/sha256/ab//" + kHex},
      {"other version", "v2/blobs/sha256/ab/" + kHex},
      {"upper-case version", "V1/blobs/sha256/ab/" + kHex},
      {"singular blob", "v1/blob/sha256/ab/" + kHex},
      {"other folder", "v1/manifests/sha256/ab/" + kHex},
      {"other algorithm", "v1/blobs/sha512/ab/" + kHex},
      {"upper-case algorithm", "v1/blobs/SHA256/ab/" + kHex},
      {"upper-case digest", "v1/blobs/sha256/AB/" + kUpperHex},
      {"upper-case digest, lower prefix", "v1/blobs/sha256/ab/" + kUpperHex},
      {"upper-case prefix", "v1/blobs/sha256/AB/" + kHex},
      {"63 hex", "v1/blobs/sha256/ab/" + kHex.substr(0, 63)},
      {"65 hex", "v1/blobs/sha256/ab/" + kHex + "0"},
      {"not hex", "v1/blobs/sha256/ab/" + kHex.substr(0, 63) + "g"},
      {"prefix not the digest's", "v1/blobs/sha256/cd/" + kHex},
      {"three-character prefix", "v1/blobs/sha256/ab0/" + kHex},
      {"one-character prefix", "v1/blobs/sha256/a/" + kHex},
      {"no prefix folder", "v1/blobs/sha256/" + kHex},
      {"extension on a blob", blob + ".json"},
      {"catalog under channels", "v1/channels/" + kHex},
      {"dot-dot first", "../" + blob},
      {"dot-dot inside", "v1/blobs/sha256/ab/../ab/" + kHex},
      {"dot-dot as prefix", "v1/blobs/sha256/../" + kHex},
      {"dot segment", "v1/./blobs/sha256/ab/" + kHex},
      {"dot-dot out of channels", "v1/channels/../blobs/sha256/ab/" + kHex},
      {"dot-dot channel", "v1/channels/...json"},
      {"encoded dot-dot", "%2e%2e/%2e%2e/etc/passwd"},
      {"encoded dot-dot upper", "v1/channels/%2E%2E/%2E%2E/secret.json"},
      {"encoded slashes", "v1%2fchannels%2fnightly.json"},
      {"encoded slash in a blob path", "v1/blobs/sha256/ab%2F" + kHex},
      {"encoded letter", "v1/channels/nightl%79.json"},
      {"encoded dot", "v1/channels/nightly%2ejson"},
      {"backslash", "v1\\channels\\nightly.json"},
      {"query left on", "v1/channels/nightly.json?x=1"},
      {"channel without .json", "v1/channels/nightly"},
      {"upper-case .JSON", "v1/channels/nightly.JSON"},
      {"empty channel name", "v1/channels/.json"},
      {"hidden channel", "v1/channels/.nightly.json"},
      {"channel starting with -", "v1/channels/-nightly.json"},
      {"channel starting with _", "v1/channels/_nightly.json"},
      {"space in channel", "v1/channels/night ly.json"},
      {"channel in a folder", "v1/channels/a/b.json"},
      {"65-character channel", "v1/channels/" + std::string(65, 'c') + ".json"},
      {"publisher's temporary file", "v1/channels/nightly.json.tmp"},
      {"channel with trailing slash", "v1/channels/nightly.json/"},
      {"non-ASCII channel", "v1/channels/n\xc3\xa9.json"},
      {"NUL in channel", std::string("v1/channels/a\0b.json", 20)},
      {"newline in channel", "v1/channels/a\nb.json"},
      {"channel under blobs", "v1/blobs/nightly.json"},
  };
  for (const auto& [what, path] : cases) {
    EXPECT_FALSE(ParseReleasePath(path).has_value()) << what << ": \"" << path << "\"";
  }
}

TEST(IfNoneMatchTest, WeakComparisonOfAListOrStar) {
  const std::string etag = "\"" + kHex + "\"";
  struct Case {
    std::string header;
    bool matches;
  };
  const std::vector<Case> cases = {
      {etag, true},
      {"W/" + etag, true},
      {"*", true},
      {" " + etag + " ", true},
      {"\"other\", " + etag, true},
      {"\"other\",W/" + etag, true},
      {"", false},
      {"\"other\"", false},
      {kHex, false},  // unquoted
      {"W/\"other\"", false},
      {"\"" + kHex, false},
      {"\"" + kUpperHex + "\"", false},
      {",", false},
  };
  for (const Case& c : cases) EXPECT_EQ(IfNoneMatchMatches(c.header, etag), c.matches) << "If-None-Match: " << c.header;
}

}  // namespace
}  // namespace impostor
