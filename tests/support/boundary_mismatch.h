// The figure the ground-crossing tests of the reference material share
// (issue 22: the Vulkan example scene, the GLSL material and the three.js
// port): how many pixels of a coverage mask disagree with a reference mask
// farther than a tolerance from the reference's own boundary. A depth
// offset that puts the impostor's ground crossing where the mesh has it
// leaves only boundary-hugging differences; a flat card leaves thousands.
#ifndef IMPOSTOR_TESTS_SUPPORT_BOUNDARY_MISMATCH_H_
#define IMPOSTOR_TESTS_SUPPORT_BOUNDARY_MISMATCH_H_

#include <cstddef>
#include <cstdint>
#include <vector>

namespace impostor::testing {

// Pixels (where `valid` is non-zero) at which `a` differs from `b` and that
// lie more than `radius` px from any pixel where `b` changes value (b's
// boundary). All three masks are `size` x `size`, row-major, one byte each.
inline int FarMismatches(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b,
                         const std::vector<uint8_t>& valid, int size, int radius) {
  auto at = [size](int x, int y) { return static_cast<size_t>(y) * size + x; };
  int far = 0;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      if (!valid[at(x, y)] || a[at(x, y)] == b[at(x, y)]) continue;
      bool near = false;
      for (int dy = -radius - 1; dy <= radius + 1 && !near; ++dy) {
        for (int dx = -radius - 1; dx <= radius + 1 && !near; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= size || yy >= size) continue;
          near = b[at(xx, yy)] != b[at(x, y)] && dx * dx + dy * dy <= (radius + 1) * (radius + 1);
        }
      }
      far += !near;
    }
  }
  return far;
}

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_SUPPORT_BOUNDARY_MISMATCH_H_
