// Request normalisation and cache-key line of the maps' file format
// (BakeParameters.texture_format and albedo_codec, types.proto).
#ifndef IMPOSTOR_COMMON_REQUEST_TEXTURE_FORMAT_PARAMETERS_H_
#define IMPOSTOR_COMMON_REQUEST_TEXTURE_FORMAT_PARAMETERS_H_

#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "common/request/ktx2_encoder_version.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// With product, frames, resolution and texture_array normalised:
// texture_format unset -> PNG; KTX2 only for PRODUCT_ATLAS without
// texture_array or frames_auto (INVALID_ARGUMENT naming the field
// otherwise), and its resolution is rounded down to frames x
// BlockAlignedTileSize. albedo_codec only with KTX2; unset -> UASTC.
// Unknown enum values are INVALID_ARGUMENT.
absl::Status NormalizeTextureFormat(const v1::BakeParameters& in, v1::BakeParameters* out);

// The cache-key line of a normalised request: empty for PNG (so PNG keys
// stay as they were), else the format, albedo codec and encoder version.
std::string TextureFormatCacheKeyLine(const v1::BakeParameters& normalized);

// "uastc" / "uastc_rdo": the manifest's codec name.
std::string_view AlbedoCodecName(v1::AlbedoCodec codec);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_REQUEST_TEXTURE_FORMAT_PARAMETERS_H_
