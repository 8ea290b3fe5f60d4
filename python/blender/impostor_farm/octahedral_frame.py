"""The atlas frame an octahedral or hemi-octahedral impostor shows for a view
direction: the baked frame whose direction is nearest (largest dot product),
the one the runtime's NearestFrame picks (common/atlas/atlas_layout.cc).

Rounding the direction's grid position to the nearest vertex (the baker's
EncodeFrame) is not that: the octahedral map stretches the sphere unevenly,
so at 8 x 8 frames 16 % of view directions would get a frame up to 16.5
degrees farther than the nearest. The nearest frame is always one of the
four vertices of the grid cell the direction falls in (test_atlas_material.py
checks that against every frame, for both layouts, on and around the
octahedron's folded border and below the hemi-octahedron's horizon), so those
four are decoded back to directions with the baker's math and compared.

Written against node_math's interface, so the same lines build the
material's nodes (NodeMath) and compute the frame in Python (FloatMath).
Conventions as in common/atlas/atlas_layout.h: glTF axes (Y up), the direction
from the bounding sphere's centre toward the camera, frame (col, row) at grid
vertex (col, row) / (frames - 1) of the square.
"""
from __future__ import annotations

from typing import Tuple

from .node_math import Value

Vec3 = Tuple[Value, Value, Value]


def encode(m: Value, layout: str, d: Vec3) -> Tuple[Value, Value]:
    """DirectionToOctahedral or DirectionToHemiOctahedral: the square [-1, 1]^2."""
    dx, dy, dz = d
    if layout == "hemi-octahedral":
        up = m.math("MAXIMUM", dy, 0.0)  # below the horizon: clamped onto it
        total = m.math("ADD", m.math("ADD", m.math("ABSOLUTE", dx), up), m.math("ABSOLUTE", dz))
        total = m.math("MAXIMUM", total, 1e-6)
        return m.math("DIVIDE", m.math("ADD", dx, dz), total), m.math("DIVIDE", m.math("SUBTRACT", dx, dz), total)
    total = m.math("ADD", m.math("ADD", m.math("ABSOLUTE", dx), m.math("ABSOLUTE", dy)), m.math("ABSOLUTE", dz))
    px, py, pz = (m.math("DIVIDE", v, total) for v in (dx, dy, dz))
    lower_x = m.math("MULTIPLY", m.math("SUBTRACT", 1.0, m.math("ABSOLUTE", pz)), m.sign_not_zero(px))
    lower_y = m.math("MULTIPLY", m.math("SUBTRACT", 1.0, m.math("ABSOLUTE", px)), m.sign_not_zero(pz))
    below = m.math("LESS_THAN", py, 0.0)
    return m.lerp(px, lower_x, below), m.lerp(pz, lower_y, below)


def decode(m: Value, layout: str, ox: Value, oy: Value) -> Value:
    """OctahedralToDirection or HemiOctahedralToDirection: a unit vector."""
    if layout == "hemi-octahedral":
        x = m.math("MULTIPLY", m.math("ADD", ox, oy), 0.5)
        z = m.math("MULTIPLY", m.math("SUBTRACT", ox, oy), 0.5)
        y = m.math("SUBTRACT", m.math("SUBTRACT", 1.0, m.math("ABSOLUTE", x)), m.math("ABSOLUTE", z))
        return m.normalize(m.combine(x, y, z))
    abs_x, abs_y = m.math("ABSOLUTE", ox), m.math("ABSOLUTE", oy)
    y = m.math("SUBTRACT", m.math("SUBTRACT", 1.0, abs_x), abs_y)
    below = m.math("LESS_THAN", y, 0.0)
    x = m.lerp(ox, m.math("MULTIPLY", m.math("SUBTRACT", 1.0, abs_y), m.sign_not_zero(ox)), below)
    z = m.lerp(oy, m.math("MULTIPLY", m.math("SUBTRACT", 1.0, abs_x), m.sign_not_zero(oy)), below)
    return m.normalize(m.combine(x, y, z))


def grid_position(m: Value, layout: str, frames: int, d: Vec3) -> Tuple[Value, Value]:
    """DirectionToGrid: in frame units, 0..frames-1 on each axis."""
    last = float(frames - 1)

    def scaled(o: Value) -> Value:
        g = m.math("MULTIPLY", m.math("ADD", m.math("MULTIPLY", o, 0.5), 0.5), last)
        return m.math("MINIMUM", m.math("MAXIMUM", g, 0.0), last)

    ox, oy = encode(m, layout, d)
    return scaled(ox), scaled(oy)


def nearest_frame(m: Value, layout: str, frames: int, d: Vec3) -> Tuple[Value, Value]:
    """(col, row) of the frame nearest `d` (need not be unit length). Ties go
    to the lowest frame index, as in NearestFrame. Of the two copies of a
    frame on the octahedron's folded border this returns the one on d's side,
    not always NearestFrame's lowest-numbered one: both tiles are baked by
    the same camera, so they show the same image."""
    gx, gy = grid_position(m, layout, frames, d)
    # The cell's lower corner; a direction on the last grid line is in the last cell.
    c0 = m.math("MINIMUM", m.math("FLOOR", gx), float(frames - 2))
    r0 = m.math("MINIMUM", m.math("FLOOR", gy), float(frames - 2))
    c1, r1 = m.math("ADD", c0, 1.0), m.math("ADD", r0, 1.0)
    view = m.normalize(m.combine(*d))
    to_square = 2.0 / float(frames - 1)

    def dot_with_view(col: Value, row: Value) -> Value:
        ox = m.math("SUBTRACT", m.math("MULTIPLY", col, to_square), 1.0)
        oy = m.math("SUBTRACT", m.math("MULTIPLY", row, to_square), 1.0)
        return m.dot(view, decode(m, layout, ox, oy))

    corners = ((c0, r0), (c1, r0), (c0, r1), (c1, r1))  # ascending frame index
    best_col, best_row = corners[0]
    best_dot = dot_with_view(best_col, best_row)
    for col, row in corners[1:]:
        dot = dot_with_view(col, row)
        nearer = m.math("GREATER_THAN", dot, best_dot)  # strictly: a tie keeps the lower index
        best_col = m.lerp(best_col, col, nearer)
        best_row = m.lerp(best_row, row, nearer)
        best_dot = m.math("MAXIMUM", best_dot, dot)
    return best_col, best_row
