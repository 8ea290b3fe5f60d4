#include "common/request/layout_parameters.h"

#include <string>

#include "absl/strings/str_cat.h"

namespace impostor {

LayoutKind LayoutKindOf(v1::Layout layout) {
  switch (layout) {
    case v1::LAYOUT_HEMI_OCTAHEDRAL: return LayoutKind::kHemiOctahedral;
    case v1::LAYOUT_AZIMUTH_ELEVATION: return LayoutKind::kAzimuthElevation;
    case v1::LAYOUT_RING_TOP: return LayoutKind::kRingTop;
    case v1::LAYOUT_BILLBOARD: return LayoutKind::kBillboard;
    default: return LayoutKind::kOctahedral;
  }
}

ViewLayout ViewLayoutOf(const v1::BakeParameters& p) {
  ViewLayout layout{.kind = LayoutKindOf(p.layout()), .frames = static_cast<int>(p.frames())};
  if (layout.kind == LayoutKind::kRingTop) layout.ring_views = static_cast<int>(p.ring_views());
  if (layout.kind == LayoutKind::kBillboard) layout.ring_views = kBillboardRingViews;
  return layout;
}

absl::Status NormalizeSupersampling(v1::BakeParameters* out) {
  const bool filtered = out->product() == v1::PRODUCT_ATLAS || out->product() == v1::PRODUCT_LOD_CHAIN;
  if (!filtered && out->texture_array()) {
    return absl::InvalidArgumentError(
        "parameters.texture_array: only for products PRODUCT_ATLAS and PRODUCT_LOD_CHAIN");
  }
  if (!filtered) {
    if (out->has_supersampling()) {
      return absl::InvalidArgumentError(
          "parameters.supersampling: only for products PRODUCT_ATLAS and PRODUCT_LOD_CHAIN");
    }
    return absl::OkStatus();
  }
  if (!out->has_supersampling()) out->set_supersampling(kDefaultSupersampling);
  const uint32_t s = out->supersampling();
  if (s < 1 || s > kMaxSupersampling) {
    return absl::InvalidArgumentError(
        absl::StrCat("parameters.supersampling: ", s, " is out of range 1..", kMaxSupersampling));
  }
  if (static_cast<uint64_t>(out->resolution()) * s > kMaxRenderPixels) {
    return absl::InvalidArgumentError(absl::StrCat(
        "parameters.supersampling: ", s, " x resolution ", out->resolution(), " = ",
        static_cast<uint64_t>(out->resolution()) * s, " px exceeds the ", kMaxRenderPixels,
        " px render limit; lower supersampling (1 renders at the resolution itself) or the resolution"));
  }
  return absl::OkStatus();
}

absl::Status NormalizeLayoutFrames(v1::BakeParameters* out) {
  const LayoutKind kind = LayoutKindOf(out->layout());
  const std::string name(LayoutName(kind));
  const bool octahedral = kind == LayoutKind::kOctahedral || kind == LayoutKind::kHemiOctahedral;
  if (out->product() == v1::PRODUCT_SURFELS && !octahedral) {
    return absl::InvalidArgumentError(absl::StrCat(
        "parameters.layout: surfel captures use octahedral or hemi-octahedral, not ", name));
  }
  if (kind != LayoutKind::kRingTop && out->has_ring_views()) {
    return absl::InvalidArgumentError(
        absl::StrCat("parameters.ring_views: only for layout ring-top, not ", name));
  }
  switch (kind) {
    case LayoutKind::kOctahedral:
      // The octahedral grid puts its frames on the map's corners, edges and
      // centre; with 2 per axis only the corners are left, which all fold
      // onto one point: four copies of the view from straight below. (Cards
      // keep the layout's name but take no frames from it.)
      if (out->frames() == 2 && out->product() != v1::PRODUCT_CARDS) {
        return absl::InvalidArgumentError(
            "parameters.frames: octahedral needs at least 3 frames per axis (with 2 all four frames are the "
            "view from straight below); got 2 (use 3 or more, or hemi-octahedral)");
      }
      return absl::OkStatus();
    case LayoutKind::kHemiOctahedral: return absl::OkStatus();
    case LayoutKind::kAzimuthElevation: {
      if (out->frames() == 0) out->set_frames(kDefaultAzimuthElevationFrames);
      const uint32_t n = out->frames();
      if (n % 2 == 0) {
        return absl::InvalidArgumentError(absl::StrCat(
            "parameters.frames: azimuth-elevation needs an odd row count so that a row sits at 0 "
            "degrees elevation; got ",
            n, " (use ", n - 1, " or ", n + 1, ")"));
      }
      if (n < 3 || n > 63) {
        return absl::InvalidArgumentError(
            absl::StrCat("parameters.frames: ", n, " is out of range 3..63 for azimuth-elevation"));
      }
      return absl::OkStatus();
    }
    case LayoutKind::kRingTop:
    case LayoutKind::kBillboard: {
      if (out->frames() != 0) {
        return absl::InvalidArgumentError(absl::StrCat(
            "parameters.frames: ", name, " derives its atlas grid from ",
            kind == LayoutKind::kRingTop ? "ring_views" : "its 9 views", "; leave frames unset"));
      }
      if (kind == LayoutKind::kRingTop) {
        if (!out->has_ring_views()) out->set_ring_views(kDefaultRingViews);
        if (out->ring_views() < kMinRingViews || out->ring_views() > kMaxRingViews) {
          return absl::InvalidArgumentError(absl::StrCat("parameters.ring_views: ", out->ring_views(),
                                                         " is out of range ", kMinRingViews, "..",
                                                         kMaxRingViews));
        }
      }
      out->set_frames(static_cast<uint32_t>(GridSide(ViewLayoutOf(*out))));
      return absl::OkStatus();
    }
  }
  return absl::OkStatus();
}

}  // namespace impostor
