#include "worker/gpu/texture_filter.h"

namespace impostor::gpu {

TextureFilter TextureFilterFor(int supersampling, float device_max_anisotropy) {
  TextureFilter f;
  if (supersampling >= 2) {
    f.mip_lod_bias = kSupersampledLodBias;
    return f;
  }
  if (device_max_anisotropy > 1.0f) {
    f.anisotropy = true;
    f.max_anisotropy = device_max_anisotropy;
  }
  return f;
}

}  // namespace impostor::gpu
