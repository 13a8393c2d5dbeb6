"""Nodes of one body at the same place in a read mesh: the body is cut there.

A .msh whose body was meshed in pieces that do not share their common lines (gmsh
without coherence, or two surfaces of one physical group with their own points) has two
nodes at every place along the common line, and the elements on the two sides are not
joined: the body has a crack that nothing in the config asks for, and the run is softer
than the body it stands for, without a word. Bodies that touch other bodies have such
nodes by design (they share no node); only pairs within one body are an error.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from app.errors import InputError

COINCIDENT_TOL = 1e-8
"""Two nodes closer than this times the body's smallest element edge are at one place."""


def check_coincident_nodes(points: np.ndarray, quads: np.ndarray, body: np.ndarray,
                           body_names: list[str], fname: str) -> None:
    """InputError naming the body and place of the first two nodes of one body that sit
    at the same place. points (n, 2); quads (ne, 4) node ids; body (ne,) body index."""
    for b, name in enumerate(body_names):
        q = quads[body == b]
        if not len(q):
            continue
        edges = points[np.roll(q, -1, axis=1)] - points[q]
        lengths = np.hypot(edges[..., 0], edges[..., 1])
        positive = lengths[lengths > 0]
        if not positive.size:
            continue
        nodes = np.unique(q)
        pairs = cKDTree(points[nodes]).query_pairs(COINCIDENT_TOL * positive.min(),
                                                   output_type="ndarray")
        if len(pairs):
            x, y = points[nodes[pairs[0, 0]]]
            raise InputError(
                f"mesh file {fname}: body '{name}' has {len(pairs)} pair(s) of nodes at the "
                f"same place (first near x={x:.4g}, y={y:.4g}): its elements are not joined "
                "there, a cut in the body; merge the duplicate nodes (gmsh: let the pieces "
                "of one body share their common lines, e.g. Coherence)")
