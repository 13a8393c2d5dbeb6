"""Self-intersection test of a polygon's sides (plain numpy, config units).

gmsh meshes a crossing or back-tracking outline into nothing (or into triangles), and the
builder then failed with a traceback; a polygon body must be simple.
"""

from __future__ import annotations

import numpy as np


def _orient(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Twice the signed area of triangles (a, b, c); arrays (..., 2)."""
    return ((b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1])
            - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0]))


def crossing_sides(p: np.ndarray) -> tuple[int, int] | None:
    """The first two sides (i, j), i < j, of the closed polygon p (n, 2) that cross, touch
    or overlap (side k runs from p[k] to p[k + 1]); None for a simple polygon.

    Neighbouring sides only share their common corner: they fail when they fold back onto
    each other (collinear, opposite directions).
    """
    n = len(p)
    q = np.roll(p, -1, axis=0)
    d = q - p
    span = float(np.sqrt(np.max(np.einsum("ij,ij->i", d, d))))  # longest side
    tol = 1e-12 * span**2  # on the orientation values (areas)
    i, j = np.triu_indices(n, 1)
    adjacent = (j == i + 1) | ((i == 0) & (j == n - 1))
    a, b, c, e = p[i], q[i], p[j], q[j]
    o1, o2 = _orient(a, b, c), _orient(a, b, e)
    o3, o4 = _orient(c, e, a), _orient(c, e, b)
    lo_ab, hi_ab = np.minimum(a, b), np.maximum(a, b)
    lo_ce, hi_ce = np.minimum(c, e), np.maximum(c, e)
    boxes = np.all((lo_ab <= hi_ce + 1e-12 * span) & (lo_ce <= hi_ab + 1e-12 * span), axis=1)
    meet = (boxes & (o1 * o2 <= tol * tol) & (o3 * o4 <= tol * tol)) & ~adjacent
    first, second = np.where(j == i + 1, i, j), np.where(j == i + 1, j, i)  # corner order
    cross = d[first, 0] * d[second, 1] - d[first, 1] * d[second, 0]
    dot = np.einsum("ij,ij->i", d[first], d[second])
    fold = adjacent & (np.abs(cross) <= tol) & (dot < 0)
    bad = np.flatnonzero(meet | fold)
    return (int(i[bad[0]]), int(j[bad[0]])) if bad.size else None
