// Writes one level of a LOD chain as a binary glTF 2.0 (.glb): the input
// model with each triangle primitive's indices replaced and its vertices
// compacted to the ones still used; materials, textures, samplers, nodes and
// their extensions unchanged.
//
// Images are never embedded: every level references the same flat image
// files ("texture_<image>.<ext>", the input's encoded bytes) by relative
// URI, so a result directory and the blob store hold each texture once,
// whatever the number of levels. Flat names because result files are plain
// names in one directory (client/transfer/result_fetch.cc refuses '/').
//
// Attributes are written as FLOAT (TEXCOORD/COLOR included), indices as
// UNSIGNED_SHORT or UNSIGNED_INT; KHR_mesh_quantization, skins, morph
// targets, animations and EXT_mesh_gpu_instancing are dropped (see
// LodSource::warnings). Pure functions; thread-safe.
#ifndef IMPOSTOR_WORKER_LOD_LOD_GLB_WRITER_H_
#define IMPOSTOR_WORKER_LOD_LOD_GLB_WRITER_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "worker/lod/lod_source.h"

namespace impostor {

// One file name per model image, in image order: "texture_<i>.png", ".jpg",
// ".webp", ".ktx2" by the image's magic bytes (".bin" when unknown).
std::vector<std::string> LodTextureFileNames(const tinygltf::Model& model);

// The .glb bytes of one level. `indices[k]` replaces the triangles of
// source.primitives[k] (non-empty, indices into that primitive's original
// vertices). `texture_files` as LodTextureFileNames. INTERNAL when tinygltf
// cannot serialise the model; INVALID_ARGUMENT when an attribute cannot be
// read.
absl::StatusOr<std::string> EncodeLodGlb(const LodSource& source, const std::vector<std::vector<uint32_t>>& indices,
                                         const std::vector<std::string>& texture_files);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_LOD_LOD_GLB_WRITER_H_
