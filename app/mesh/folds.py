"""A mesh that folds over itself: an element inverted among its neighbours.

The .msh reader (and the gmsh builder) turn every quad counter-clockwise one by one, so
an element that a tangled mesh gives inverted (its nodes moved past its neighbours') is
turned too and then passes every per-element check, while the body covers that region
twice: the run went on with a body that overlaps itself and no word. In a mesh that does
not fold, the elements sharing an edge run it in opposite directions; a directed edge
used twice marks the fold.
"""

from __future__ import annotations

import numpy as np

from app.errors import InputError
from app.mesh.model import Mesh


def check_no_folds(mesh: Mesh) -> None:
    """InputError naming the body and place of the first edge that two counter-clockwise
    elements run in the same direction."""
    q = np.asarray(mesh.quads, dtype=np.int64)
    if not len(q):
        return
    key = (q * mesh.n_nodes + np.roll(q, -1, axis=1)).ravel()
    order = np.argsort(key, kind="stable")
    same = np.flatnonzero(key[order][1:] == key[order][:-1])
    if not same.size:
        return
    e = int(order[same[0]] // 4)
    c = mesh.points[q[e]].mean(axis=0)
    raise InputError(
        f"body '{mesh.body_names[mesh.body[e]]}': the mesh folds over itself: {same.size} "
        f"element edge(s) are run in the same direction by two elements (first near "
        f"x={c[0]:.4g}, y={c[1]:.4g}): an element is inverted among its neighbours; fix "
        "the mesh")
