// How the bake samples the mesh's textures, chosen per Render() from the
// supersampling factor (pure data; no Vulkan calls).
//
// Why not always anisotropic: an orthographic bake shows oblique surfaces
// only near silhouettes, and a supersampled bake already takes 4+ samples
// per output texel, which is what anisotropic filtering approximates. On
// lavapipe anisotropic filtering was 45% of the whole bake's render CPU time
// (DamagedHelmet 12x12 at 2048 px, 2x2 supersampling: 19.0 -> 10.5 CPU s),
// and against a 4x4-supersampled anisotropic reference the albedo of
// covered texels was no closer with it (mean error 3.69 levels, 29.4 dB)
// than with trilinear filtering biased half a mip level sharper (3.48 levels,
// 29.4 dB); unbiased trilinear was slightly blurrier (4.04 levels). The
// same rule holds on every device, so a bake looks the same wherever it ran.
// Without supersampling each texel has one sample and anisotropic filtering
// is what keeps oblique textures sharp, so it stays.
#ifndef IMPOSTOR_WORKER_GPU_TEXTURE_FILTER_H_
#define IMPOSTOR_WORKER_GPU_TEXTURE_FILTER_H_

namespace impostor::gpu {

struct TextureFilter {
  bool anisotropy = false;
  float max_anisotropy = 1.0f;  // 1 when anisotropy is off
  float mip_lod_bias = 0.0f;
  friend bool operator==(const TextureFilter&, const TextureFilter&) = default;
};

// Mip bias of supersampled bakes: half a level sharper (measured above).
inline constexpr float kSupersampledLodBias = -0.5f;

// `supersampling`: tiles rendered at that many times the output size (1 =
// none; values below 1 count as 1). `device_max_anisotropy`: what the device
// enabled (<= 1 = no anisotropic filtering).
TextureFilter TextureFilterFor(int supersampling, float device_max_anisotropy);

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_TEXTURE_FILTER_H_
