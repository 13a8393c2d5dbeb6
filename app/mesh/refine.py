"""Uniform refinement of a quadrilateral mesh by splitting: every quad into four.

Each edge gets a mid node (shared by the two quads of an interior edge), each quad a
centre node; the old nodes keep their indices, so levels are nested (point groups carry
over unchanged) and a split costs O(n) (sorting of edge keys aside). Mid nodes of
boundary edges lying on a circular arc of the scene geometry are projected onto the
circle, so curved boundaries converge to the geometry. Named curves are split edge by
edge with their orientation kept; body ids are repeated four times.
"""

from __future__ import annotations

import numpy as np

from app.mesh.model import Mesh
from app.scene import Scene

ARC_TOL = 1e-6  # relative to the radius: an edge end is on an arc within ARC_TOL * radius
Arc = tuple[int, np.ndarray, float, float, float]  # body index, centre, radius, a0, a1


def split_quads(mesh: Mesh) -> tuple[Mesh, np.ndarray, np.ndarray]:
    """One uniform split of every quad, nodes placed by linear interpolation.

    Returns the new mesh, the (n_edges, 2) unique edges (old node pairs, sorted) and, for
    every new node index n_old + k (k < n_edges), its edge k: the caller may move the
    mid nodes of boundary edges (see `boundary_edges`).
    New quad j of old quad e (j = 0..3) is [c_j, m_j, z, m_{j-1}] with c the corners,
    m_j the mid node of edge c_j -> c_{j+1} and z the centre: counter-clockwise if e is.
    """
    n = mesh.n_nodes
    q = np.asarray(mesh.quads, dtype=np.int64)
    ne = q.shape[0]
    a, b = q, np.roll(q, -1, axis=1)  # (ne, 4) edge j: a[:, j] -> b[:, j]
    lo, hi = np.minimum(a, b).ravel(), np.maximum(a, b).ravel()
    keys, inverse = np.unique(lo * n + hi, return_inverse=True)
    edges = np.stack([keys // n, keys % n], axis=1)
    mid = (n + inverse).reshape(ne, 4)
    centre = n + len(keys) + np.arange(ne)
    pts = mesh.points
    points = np.concatenate([pts, 0.5 * (pts[edges[:, 0]] + pts[edges[:, 1]]),
                             pts[q].mean(axis=1)])
    m_prev = np.roll(mid, 1, axis=1)
    quads = np.stack([q, mid, np.repeat(centre[:, None], 4, axis=1), m_prev], axis=2)
    quads = quads.reshape(-1, 4)
    curves = {}
    for name, ce in mesh.curves.items():
        ce = np.asarray(ce, dtype=np.int64)
        k = np.searchsorted(keys, np.minimum(ce[:, 0], ce[:, 1]) * n
                            + np.maximum(ce[:, 0], ce[:, 1]))
        m = n + k
        curves[name] = np.stack([np.stack([ce[:, 0], m], 1), np.stack([m, ce[:, 1]], 1)],
                                axis=1).reshape(-1, 2)
    out = Mesh(points=points, quads=quads, body=np.repeat(np.asarray(mesh.body), 4),
               body_names=list(mesh.body_names), curves=curves,
               point_groups={k: np.asarray(v).copy() for k, v in mesh.point_groups.items()},
               dropped_nodes=mesh.dropped_nodes)
    return out, edges, inverse


def boundary_edges(inverse: np.ndarray, n_edges: int) -> np.ndarray:
    """(n_edges,) True for edges used by one quad only (`inverse` from split_quads)."""
    return np.bincount(inverse, minlength=n_edges) == 1


def project_on_arcs(points: np.ndarray, edges: np.ndarray, mids: np.ndarray,
                    edge_body: np.ndarray, arcs: list[Arc]) -> np.ndarray:
    """Move mid nodes of boundary edges whose two ends lie on an arc of their own body onto
    the circle (another body's edges, e.g. a flat touching the arc, are left alone).

    points: (n, 2) coordinates; edges: (k, 2) node pairs with mid node indices mids (k,)
    and body index edge_body (k,). arcs: (body, centre (2,), radius, a0, a1) counter-
    clockwise arcs (rad). Returns a copy.
    """
    out = points.copy()
    for body, c, r, a0, a1 in arcs:
        ends = points[edges] - c  # (k, 2, 2)
        rad = np.hypot(ends[..., 0], ends[..., 1])
        on = np.all(np.abs(rad - r) <= ARC_TOL * r, axis=1) & (edge_body == body)
        v = points[mids] - c
        ang = (np.arctan2(v[:, 1], v[:, 0]) - a0) % (2 * np.pi)
        chord = np.hypot(*(ends[:, 1] - ends[:, 0]).T)
        on &= (ang <= a1 - a0) & (chord < r)  # mid inside the piece, not a chord across it
        if not on.any():
            continue
        v = v[on]
        out[mids[on]] = c + r * v / np.hypot(v[:, 0], v[:, 1])[:, None]
    return out


def refine_mesh(mesh: Mesh, times: int = 1, arcs: list[Arc] | None = None) -> Mesh:
    """`times` uniform splits; boundary mid nodes on `arcs` are put on the circles.

    The centre node of a quad is the mean of its four (possibly projected) mid nodes.
    """
    for _ in range(times):
        n = mesh.n_nodes
        new, edges, inverse = split_quads(mesh)
        if arcs:
            bnd = np.flatnonzero(boundary_edges(inverse, len(edges)))
            edge_body = np.empty(len(edges), dtype=np.int64)
            edge_body[inverse] = np.repeat(np.asarray(mesh.body), 4)
            pts = project_on_arcs(new.points, edges[bnd], n + bnd, edge_body[bnd], arcs)
            ne = mesh.n_elements
            mid = (n + inverse).reshape(ne, 4)
            pts[n + len(edges):] = pts[mid].mean(axis=1)
            new.points = pts
        mesh = new
    return mesh


def scene_arcs(scene: Scene) -> list[Arc]:
    """Circular arcs (body index, centre, radius, a0, a1) of the body shapes of a scene,
    bodies in config order as in the Mesh; empty for a mesh read from a file."""
    if scene.file is not None:
        return []
    return [(i, p.center, p.radius, p.a0, p.a1) for i, b in enumerate(scene.bodies)
            for s in b.sides for p in s.pieces if p.kind == "arc"]
