// Wires the result page's debug views to its viewer: the atlas panel with
// the active frames marked (atlas_panel.js, frames from blend_probe.js) and
// the A/B split (ab_split.js). Kept apart from result.js so the viewer's
// material code and these views change independently.
//
// Test hooks (window.impostorViewer): activeFrames() (what the panel marks),
// setBlend(mode), setSplit(fraction), pngs() (data URLs of the mesh,
// impostor and A/B canvases, and the split column).
import { createAtlasPanel } from './atlas_panel.js';
import { createAbSplit } from './ab_split.js';
import { createBlendProbe } from './blend_probe.js';

// viewer = {manifest, fileUrl, impostor, camera, centre (THREE.Vector3), radius, meshCanvas, impostorCanvas, redraw()}.
// Returns {afterDraw(), abCanvas}: call afterDraw() after every redraw.
export async function attachDebugViews(viewer) {
  const { manifest, impostor, camera, centre, radius } = viewer;
  const query = new URLSearchParams(location.search);
  const probe = await createBlendProbe(impostor.layout);
  const panel = await createAtlasPanel(document.getElementById('atlas'), document.getElementById('active-frames'),
    manifest, viewer.fileUrl);
  const abCanvas = document.getElementById('ab');
  const ab = createAbSplit(abCanvas, viewer.meshCanvas, viewer.impostorCanvas, Number(query.get('split') ?? 0.5));

  const compare = document.getElementById('compare');
  const showCompare = (mode) => {
    document.getElementById('ab-figure').hidden = mode !== 'ab';
    for (const id of ['mesh-figure', 'impostor-figure']) document.getElementById(id).hidden = mode === 'ab';
  };
  compare.value = query.get('compare') === 'ab' ? 'ab' : 'side';
  showCompare(compare.value);
  compare.addEventListener('change', () => showCompare(compare.value));

  const afterDraw = () => {
    // The direction the viewer's material computes: eye - centre in radii.
    const eye = camera.position;
    const dir = [(eye.x - centre.x) / radius, (eye.y - centre.y) / radius, (eye.z - centre.z) / radius];
    panel.update(probe(dir, impostor.options.blend));
    ab.draw();
  };
  window.impostorViewer = {
    activeFrames: () => panel.marked,
    setBlend(mode) {
      impostor.options.blend = Number(mode);
      document.getElementById('blend').value = String(impostor.options.blend);
      viewer.redraw();
      return panel.marked;
    },
    setSplit(fraction) {
      ab.setSplit(fraction);
      return ab.split;
    },
    split: () => ab.split,
    pngs: () => ({
      mesh: viewer.meshCanvas.toDataURL('image/png'),
      impostor: viewer.impostorCanvas.toDataURL('image/png'),
      ab: abCanvas.toDataURL('image/png'),
      split_px: Number(abCanvas.dataset.splitPx),
    }),
  };
  return { afterDraw, abCanvas };
}
