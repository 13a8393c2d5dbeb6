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


PAIRS_PER_BLOCK = 1 << 18
"""Side pairs tested at once: the test's arrays stay near 60 MB whatever the number of
sides (all n^2 / 2 pairs at once took 1.1 GB at 3000 sides, and 15,000 sides would have
needed more memory than the machine has, before any size check)."""


def crossing_sides(p: np.ndarray) -> tuple[int, int] | None:
    """The first two sides (i, j), i < j, of the closed polygon p (n, 2) that cross, touch
    or overlap (side k runs from p[k] to p[k + 1]); None for a simple polygon.

    Neighbouring sides only share their common corner: they fail when they fold back onto
    each other (collinear, opposite directions). The pairs are tested in blocks of rows i
    (PAIRS_PER_BLOCK pairs at most), in the order i, then j.
    """
    n = len(p)
    q = np.roll(p, -1, axis=0)
    d = q - p
    span = float(np.sqrt(np.max(np.einsum("ij,ij->i", d, d))))  # longest side
    rows = max(1, PAIRS_PER_BLOCK // max(n, 1))
    for start in range(0, n - 1, rows):
        i, j = _pairs(n, start, start + rows)
        found = _crossing_pairs(p, q, d, span, i, j)
        if found is not None:
            return found
    return None


def _pairs(n: int, lo: int, hi: int) -> tuple[np.ndarray, np.ndarray]:
    """The pairs (i, j), lo <= i < min(hi, n), i < j < n, in the order i, then j."""
    i = np.arange(lo, min(hi, n))
    counts = n - 1 - i
    ii = np.repeat(i, counts)
    offsets = np.arange(ii.size) - np.repeat(np.cumsum(counts) - counts, counts)
    return ii, ii + 1 + offsets


def _crossing_pairs(p: np.ndarray, q: np.ndarray, d: np.ndarray, span: float,
                    i: np.ndarray, j: np.ndarray) -> tuple[int, int] | None:
    """The first pair (i[k], j[k]) of sides that cross, touch or fold back, or None."""
    n = len(p)
    tol = 1e-12 * span**2  # on the orientation values (areas)
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
