"""The mesh data model shared by every later stage.

A `Mesh` holds one quadrilateral mesh of all bodies of a scene. Bodies never share
nodes. Element connectivity is counter-clockwise (positive area). Named curves are
lists of boundary edges (node pairs); named points are node indices.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from app.errors import InputError
from app.scene.geometry import polygon_areas


@dataclass
class Mesh:
    """All-quadrilateral multi-body mesh.

    points: (n_nodes, 2) float coordinates, in the config's length unit.
    quads: (n_elements, 4) int node indices, counter-clockwise.
    body: (n_elements,) int body index into `body_names`.
    body_names: names of the bodies (physical surfaces), in body-index order.
    curves: physical curve name -> (n_edges, 2) int node pairs (boundary edges).
    point_groups: physical point name -> (k,) int node indices.
    dropped_nodes: (k, 2) coordinates of a mesh.file's nodes on no quadrilateral, which
        the reader dropped (they carry no DOF; kept to be reported).
    """

    points: np.ndarray
    quads: np.ndarray
    body: np.ndarray
    body_names: list[str]
    curves: dict[str, np.ndarray] = field(default_factory=dict)
    point_groups: dict[str, np.ndarray] = field(default_factory=dict)
    dropped_nodes: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    @property
    def n_nodes(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_elements(self) -> int:
        return int(self.quads.shape[0])

    def node_body(self) -> np.ndarray:
        """(n_nodes,) body index of every node (-1 for a node used by no element)."""
        nb = np.full(self.n_nodes, -1, dtype=np.int64)
        nb[self.quads.ravel()] = np.repeat(self.body, 4)
        return nb

    def curve_nodes(self, name: str) -> np.ndarray:
        """Sorted unique node indices of a named curve."""
        return np.unique(self.curves[name])



def orient_ccw(points: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Quads (ne, 4) reordered counter-clockwise (positive shoelace area) where needed."""
    out = quads.copy()
    flip = polygon_areas(points[quads]) < 0
    out[flip] = out[flip][:, ::-1]
    return out


def orient_boundary_edges(mesh: Mesh, edges: np.ndarray, what: str) -> np.ndarray:
    """Order each boundary edge (A, B) so that its owning element lies on the left of A -> B.

    The owning element is found by looking the edge up among the directed edges of the
    elements that touch the curve. Raises InputError for an edge owned by no element or
    shared by two elements (an interior edge); `what` names the curve in the message,
    e.g. "interface 'contact': master curve 'block_top'". For an oriented edge (A, B) the
    outward unit normal of the body is (dy, -dx) / length.
    """
    n = mesh.n_nodes
    quads = np.asarray(mesh.quads, dtype=np.int64)
    on_curve = np.zeros(n, dtype=bool)
    on_curve[edges.ravel()] = True
    sel = np.flatnonzero(on_curve[quads].any(axis=1))
    q = quads[sel]
    keys = (q * n + np.roll(q, -1, axis=1)).ravel()
    elem = np.repeat(sel, 4)
    order = np.argsort(keys, kind="stable")
    keys, elem = keys[order], elem[order]

    def lookup(k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if keys.size == 0:
            return np.zeros(k.shape, dtype=bool), np.zeros(k.shape, dtype=np.int64)
        pos = np.minimum(np.searchsorted(keys, k), keys.size - 1)
        return keys[pos] == k, elem[pos]

    fwd, el_f = lookup(edges[:, 0] * n + edges[:, 1])
    bwd, el_b = lookup(edges[:, 1] * n + edges[:, 0])
    bad = ~(fwd | bwd)
    if bad.any():
        raise InputError(f"{what}: {bad.sum()} edges are not element edges (first: "
                         f"{_edge_place(mesh, edges[np.argmax(bad)])})")
    inner = fwd & bwd
    if inner.any():
        raise InputError(f"{what}: {inner.sum()} edges are interior edges shared by two "
                         f"elements (first: {_edge_place(mesh, edges[np.argmax(inner)])})")
    owner = np.where(fwd, el_f, el_b)
    xy = mesh.points[quads[owner]]  # (k, 4, 2) owning element corners
    # the owner lists (A, B) in its own node order; that order is CCW if its area is positive
    keep = fwd == (polygon_areas(xy) > 0)
    return np.where(keep[:, None], edges, edges[:, ::-1])


def _edge_place(mesh: Mesh, edge: np.ndarray) -> str:
    """'the edge from (x0, y0) to (x1, y1)': where an edge is, for a user (the internal
    node numbers, which the error named before, are not a mesh file's)."""
    (x0, y0), (x1, y1) = mesh.points[edge[0]], mesh.points[edge[1]]
    return f"the edge from ({x0:.6g}, {y0:.6g}) to ({x1:.6g}, {y1:.6g})"
