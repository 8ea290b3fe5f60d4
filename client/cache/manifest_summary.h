// The two facts of a result's manifest.json a cache user needs beside the
// ones the .entry record keeps (layout, frames, resolution): which product
// it is and how many views its atlas holds, so a game can build the
// runtime's AtlasLayout (ring-top's ring count is views - 1) and tell cards
// or surfels from an atlas without parsing the manifest itself.
#ifndef IMPOSTOR_CLIENT_CACHE_MANIFEST_SUMMARY_H_
#define IMPOSTOR_CLIENT_CACHE_MANIFEST_SUMMARY_H_

#include <cstdint>
#include <string>
#include <string_view>

namespace impostor::sdk {

struct ManifestSummary {
  std::string product = "atlas";  // absent in manifests older than products: an atlas
  uint32_t view_count = 0;        // length of `views` (0 for cards and surfels)
  // The maps are texture arrays (BakeParameters.texture_array): layer strips
  // one tile wide, one tile per view, not atlases (common/manifest/manifest_format.md).
  bool texture_array = false;
};

// Never fails: the manifest was verified against its digest before it was
// installed; a field that is missing or of the wrong type keeps its default.
ManifestSummary SummarizeManifest(std::string_view manifest_json);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_MANIFEST_SUMMARY_H_
