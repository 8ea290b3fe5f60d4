#include "common/runtime/depth_reconstruction.h"

#include <string>


#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace impostor {

absl::StatusOr<Reconstruction> ParseReconstruction(std::string_view name) {
  if (name == "plain") return Reconstruction::kPlain;
  if (name == "depth") return Reconstruction::kDepth;
  return absl::InvalidArgumentError(
      absl::StrCat("reconstruction: '", std::string(name), "' is not one of plain, depth"));
}

std::string_view ReconstructionName(Reconstruction mode) {
  return mode == Reconstruction::kDepth ? "depth" : "plain";
}

}  // namespace impostor
