// An analytic test object (two spheres inside a bounding sphere, coloured by
// position so every frame looks different) ray-cast on the CPU with the bake
// camera conventions of common/atlas/frame_camera.h, so runtime tests need no GPU:
// the same code bakes the atlas tiles and renders the "mesh" ground truth for
// any view.
#ifndef IMPOSTOR_TESTS_RUNTIME_SYNTHETIC_ATLAS_H_
#define IMPOSTOR_TESTS_RUNTIME_SYNTHETIC_ATLAS_H_

#include "common/runtime/reference_renderer.h"

namespace impostor::testing {

// The object's bounding sphere (centre off the origin on purpose).
BoundingSphere SyntheticSphere();

// Ray-casts the object for `camera` into a pixels x pixels image with the
// AtlasImages encodings (empty texels 0 / 0.5,0.5,0.5,1 / 0).
ViewImages RenderSyntheticView(const FrameCamera& camera, int pixels);

// Bakes every frame of a layout into an atlas of `resolution` pixels.
ImpostorAtlas BakeSyntheticAtlas(LayoutKind layout, int frames, int resolution);
// Any layout: frame i in tile FrameTile(layout, i) of side
// TileSize(resolution, GridSide(layout)); atlas.frames = GridSide for the
// ring layouts, as the bake request carries it.
ImpostorAtlas BakeSyntheticAtlas(const ViewLayout& layout, int resolution);

// Copies the tile of frame `index` out of an atlas as a ViewImages.
ViewImages ExtractTile(const ImpostorAtlas& atlas, int index);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_RUNTIME_SYNTHETIC_ATLAS_H_
