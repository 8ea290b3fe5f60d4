// The A/B split view: the mesh render (left of the split line) and the
// impostor render (right) in one canvas, composited from the two viewer
// canvases, which share one camera. Drag the line to move it; a drag
// elsewhere on the canvas orbits (the caller's OrbitControls).

const GRAB_PX = 10;  // how near the line (CSS pixels) a drag moves it

// Returns {draw(), split (fraction 0..1 of the width), setSplit(f)}.
const clamp01 = (f) => (Number.isFinite(f) ? Math.min(1, Math.max(0, f)) : 0.5);

export function createAbSplit(canvas, meshCanvas, impostorCanvas, split = 0.5) {
  const ctx = canvas.getContext('2d');
  const view = {
    split: clamp01(split),
    // Composite: black, the mesh left of the split, the impostor (over
    // black) right of it, then a 1-pixel line on the split.
    draw() {
      const w = canvas.width, h = canvas.height;
      const x = Math.round(view.split * w);
      ctx.globalCompositeOperation = 'source-over';
      ctx.fillStyle = '#000';
      ctx.fillRect(0, 0, w, h);
      if (x > 0) ctx.drawImage(meshCanvas, 0, 0, x, meshCanvas.height, 0, 0, x, h);
      if (x < w) ctx.drawImage(impostorCanvas, x, 0, w - x, impostorCanvas.height, x, 0, w - x, h);
      ctx.fillStyle = '#fff';
      ctx.fillRect(Math.min(w - 1, x), 0, 1, h);
      canvas.dataset.splitPx = String(x);
    },
    setSplit(f) {
      view.split = clamp01(f);
      view.draw();
    },
  };
  let dragging = false;
  const fraction = (ev) => {
    const rect = canvas.getBoundingClientRect();
    return (ev.clientX - rect.left) / rect.width;
  };
  // Registered before OrbitControls (created after this), so a grab of the
  // line never orbits.
  canvas.addEventListener('pointerdown', (ev) => {
    const rect = canvas.getBoundingClientRect();
    if (Math.abs(ev.clientX - rect.left - view.split * rect.width) > GRAB_PX) return;
    dragging = true;
    if (canvas.setPointerCapture && ev.isTrusted) canvas.setPointerCapture(ev.pointerId);
    ev.stopImmediatePropagation();
    ev.preventDefault();
  });
  canvas.addEventListener('pointermove', (ev) => {
    if (!dragging) return;
    view.setSplit(fraction(ev));
    ev.stopImmediatePropagation();
  });
  const end = (ev) => {
    if (!dragging) return;
    dragging = false;
    ev.stopImmediatePropagation();
  };
  canvas.addEventListener('pointerup', end);
  canvas.addEventListener('pointercancel', end);
  canvas.style.cursor = 'crosshair';
  return view;
}
