#include "common/request/texture_format_parameters.h"

#include "absl/strings/str_cat.h"
#include "common/atlas/frame_camera.h"

namespace impostor {

absl::Status NormalizeTextureFormat(const v1::BakeParameters& in, v1::BakeParameters* out) {
  switch (in.texture_format()) {
    case v1::TEXTURE_FORMAT_UNSPECIFIED: out->set_texture_format(v1::TEXTURE_FORMAT_PNG); break;
    case v1::TEXTURE_FORMAT_PNG:
    case v1::TEXTURE_FORMAT_KTX2: break;
    default:
      return absl::InvalidArgumentError(
          absl::StrCat("parameters.texture_format: unknown value ", static_cast<int>(in.texture_format()),
                       "; expected TEXTURE_FORMAT_PNG (1) or TEXTURE_FORMAT_KTX2 (2)"));
  }
  const bool ktx2 = out->texture_format() == v1::TEXTURE_FORMAT_KTX2;
  switch (in.albedo_codec()) {
    case v1::ALBEDO_CODEC_UNSPECIFIED:
      if (ktx2) out->set_albedo_codec(v1::ALBEDO_CODEC_UASTC);
      break;
    case v1::ALBEDO_CODEC_UASTC:
    case v1::ALBEDO_CODEC_UASTC_RDO:
      if (!ktx2) return absl::InvalidArgumentError("parameters.albedo_codec: only with TEXTURE_FORMAT_KTX2");
      break;
    default:
      return absl::InvalidArgumentError(
          absl::StrCat("parameters.albedo_codec: unknown value ", static_cast<int>(in.albedo_codec()),
                       "; expected ALBEDO_CODEC_UASTC (1) or ALBEDO_CODEC_UASTC_RDO (2)"));
  }
  if (!ktx2) return absl::OkStatus();
  if (out->product() != v1::PRODUCT_ATLAS) {
    return absl::InvalidArgumentError("parameters.texture_format: TEXTURE_FORMAT_KTX2 is only for PRODUCT_ATLAS");
  }
  if (out->texture_array()) {
    return absl::InvalidArgumentError(
        "parameters.texture_format: TEXTURE_FORMAT_KTX2 cannot be combined with texture_array");
  }
  if (out->frames_auto()) {
    return absl::InvalidArgumentError(
        "parameters.texture_format: TEXTURE_FORMAT_KTX2 needs an explicit frame count (not frames_auto)");
  }
  // The grid's side in tiles (ring-top and billboard derive it into frames).
  const int frames = static_cast<int>(out->frames());
  const int tile = BlockAlignedTileSize(static_cast<int>(out->resolution()), frames);
  out->set_resolution(static_cast<uint32_t>(tile * frames));
  return absl::OkStatus();
}

std::string TextureFormatCacheKeyLine(const v1::BakeParameters& p) {
  if (p.texture_format() != v1::TEXTURE_FORMAT_KTX2) return "";
  return absl::StrCat("texture_format ktx2 albedo ", std::string(AlbedoCodecName(p.albedo_codec())), " encoder ",
                      std::string(kKtx2EncoderVersion));
}

std::string_view AlbedoCodecName(v1::AlbedoCodec codec) {
  return codec == v1::ALBEDO_CODEC_UASTC_RDO ? "uastc_rdo" : "uastc";
}

}  // namespace impostor
