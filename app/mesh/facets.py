"""Boundaries that look like a curve given by its chords (app/mesh/refine.py's split of a
mesh read from mesh.file keeps them): nodes where a body's boundary turns by a small
angle. A split puts its new boundary nodes on the straight edges, so such a side stays
the file's polygon at every level and a study converges to that polygon, not to the
curve (the gmsh-built scenes project them onto their arcs; a file has no arcs).
"""

from __future__ import annotations

import numpy as np

from app.mesh.model import Mesh

TURN_MIN_DEG = 0.05  # below: a straight side (round-off of collinear nodes)
TURN_MAX_DEG = 45.0  # above: a corner of a polygon
MIN_NODES = 3  # a body with fewer such nodes has corners, not a curve


def boundary_turns(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """(nodes, turns): every boundary node that has one incoming and one outgoing boundary
    edge, and the angle (degrees, >= 0) by which the boundary turns there."""
    q = np.asarray(mesh.quads, dtype=np.int64)
    a, b = q.ravel(), np.roll(q, -1, axis=1).ravel()  # every quad edge a -> b, CCW
    n = max(mesh.n_nodes, 1)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    _, inv, count = np.unique(lo * n + hi, return_inverse=True, return_counts=True)
    on = count[inv] == 1  # boundary edges, oriented with their body on the left
    a, b = a[on], b[on]
    out_of = np.full(mesh.n_nodes, -1, dtype=np.int64)
    starts, k = np.unique(a, return_counts=True)
    single = starts[k == 1]  # nodes with one outgoing boundary edge
    first = np.full(mesh.n_nodes, -1, dtype=np.int64)
    first[a] = np.arange(a.size)
    out_of[single] = first[single]
    nxt = out_of[b]  # the edge leaving each edge's end
    ok = nxt >= 0
    p = mesh.points
    d1 = p[b[ok]] - p[a[ok]]
    d2 = p[b[nxt[ok]]] - p[a[nxt[ok]]]
    turn = np.degrees(np.abs(np.arctan2(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0],
                                        np.einsum("ij,ij->i", d1, d2))))
    return b[ok], turn


def faceted_sides(mesh: Mesh) -> dict[str, tuple[int, float, float, list[float]]]:
    """body name -> (number of boundary nodes turning by TURN_MIN_DEG..TURN_MAX_DEG, the
    smallest and largest such turn in degrees, the first such node's [x, y]) for every
    body with at least MIN_NODES of them."""
    nodes, turn = boundary_turns(mesh)
    small = (turn > TURN_MIN_DEG) & (turn < TURN_MAX_DEG)
    owner = mesh.node_body()[nodes]
    out = {}
    for i, name in enumerate(mesh.body_names):
        sel = small & (owner == i)
        if sel.sum() >= MIN_NODES:
            first = nodes[np.flatnonzero(sel)[0]]
            out[name] = (int(sel.sum()), float(turn[sel].min()), float(turn[sel].max()),
                         [float(v) for v in mesh.points[first]])
    return out


def faceted_split_warnings(mesh: Mesh, file: str, times: int) -> list[str]:
    """The warnings for a mesh.file split `times` times (one per body with a side that
    looks like a curve given by chords)."""
    return [
        f"body '{name}': mesh file {file} is split {times} time(s), and the split puts its "
        f"new boundary nodes on the file's straight edges: {k} of its boundary nodes turn "
        f"by {lo:.2g} to {hi:.2g} deg, as on a curve given by chords (first at "
        f"x={xy[0]:.4g}, y={xy[1]:.4g}), and such a side stays that polygon at every "
        "level, so the answers converge to the polygon's, not to the curve's; for a curved "
        "side mesh the file finer in gmsh instead of splitting it"
        for name, (k, lo, hi, xy) in faceted_sides(mesh).items()
    ]
