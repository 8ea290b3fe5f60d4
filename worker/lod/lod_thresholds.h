// Switch thresholds of a LOD chain from the levels' measured geometric
// errors. The unit and the selection rule are those of the SDK
// (client/include/impostor/lod.h): a threshold is a screen scale s in
// pixels per scene unit, s = viewport_height_px / (2 tan(fov_y / 2) d) for
// an object at distance d; level i is drawn while s >= threshold[i].
// Pure function; thread-safe.
#ifndef IMPOSTOR_WORKER_LOD_LOD_THRESHOLDS_H_
#define IMPOSTOR_WORKER_LOD_LOD_THRESHOLDS_H_

#include <span>
#include <vector>

namespace impostor {

// Projected bounding-sphere diameter below which the impostor takes over
// when its quality pass gave no good-for size (quality_views 0, or no size
// met its targets; lod_bake.cc).
inline constexpr float kImpostorDiameterPixels = 16.0f;

// `mesh_errors[i]`: geometric error of mesh level i in scene units (0 for
// LOD0). Returns one threshold per level plus 0 for the impostor (so
// mesh_errors.size() + 1 values):
//   mesh level i -> i+1:  pixel_error / mesh_errors[i+1]  (the next level's
//                         error projects to exactly pixel_error pixels there)
//   last mesh -> impostor: impostor_diameter_px / (2 * radius)
// made non-increasing from the end (a level whose own threshold would come
// after the next one's is skipped: its threshold equals the next one's).
// An error of 0 counts as 1e-6 * radius, so thresholds stay finite.
std::vector<float> LodThresholds(std::span<const float> mesh_errors, float radius, float pixel_error,
                                 float impostor_diameter_px = kImpostorDiameterPixels);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_LOD_LOD_THRESHOLDS_H_
