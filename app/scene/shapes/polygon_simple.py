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
sides (all n^2 / 2 pairs at once took 1.1 GB at 3000 sides)."""


def crossing_sides(p: np.ndarray) -> tuple[int, int] | None:
    """The first two sides (i, j), i < j, of the closed polygon p (n, 2) that cross, touch
    or overlap (side k runs from p[k] to p[k + 1]), first in the order i, then j; None for
    a simple polygon.

    Neighbouring sides only share their common corner: they fail when they fold back onto
    each other (collinear, opposite directions). Only pairs whose intervals overlap along
    one axis (x or y, whichever gives fewer pairs, widened by the box test's tolerance) can
    meet: the sides are sorted by their interval's low end, and each is paired with the
    sides that start within its interval (a sweep, O(n log n) plus the pairs found; all
    n^2 / 2 pairs, before, took 23.6 s of CPU at 10,000 corners). Outlines whose long
    sides overlap along both axes (a star of thin spikes) still give many pairs; they are
    tested in blocks of PAIRS_PER_BLOCK pairs at most.
    """
    q = np.roll(p, -1, axis=0)
    d = q - p
    span = float(np.sqrt(np.max(np.einsum("ij,ij->i", d, d))))  # longest side
    best = None
    for i, j in _overlapping_pairs(p, q, 1e-12 * span):
        found = _crossing_pairs(p, q, d, span, i, j)
        if found is not None and (best is None or found < best):
            best = found
    return best


def _axis_pairs(lo: np.ndarray, hi: np.ndarray, slack: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sides sorted by lo (order), and for each sorted position k the end of the run of
    sorted positions k + 1 ... end - 1 whose lo is at most hi + slack; their count."""
    order = np.argsort(lo, kind="stable")
    end = np.searchsorted(lo[order], hi[order] + slack, side="right")
    counts = np.maximum(end - np.arange(1, len(lo) + 1), 0)
    return order, counts, end


def _overlapping_pairs(p: np.ndarray, q: np.ndarray, slack: float):
    """Blocks (i, j), i < j, of every side pair whose intervals overlap (within slack)
    along the axis that gives fewer pairs; a superset of the pairs that can meet."""
    lo, hi = np.minimum(p, q), np.maximum(p, q)
    axes = [_axis_pairs(lo[:, a], hi[:, a], slack) for a in (0, 1)]
    order, counts, _ = min(axes, key=lambda t: int(t[1].sum()))
    total = np.cumsum(counts)
    start = 0
    while start < len(counts):
        stop = int(np.searchsorted(total, total[start] - counts[start] + PAIRS_PER_BLOCK,
                                   side="right"))
        stop = max(stop, start + 1)
        c = counts[start:stop]
        k = np.repeat(np.arange(start, stop), c)
        m = k + 1 + np.arange(k.size) - np.repeat(np.cumsum(c) - c, c)
        a, b = order[k], order[m]
        if k.size:
            yield np.minimum(a, b), np.maximum(a, b)
        start = stop


def _crossing_pairs(p: np.ndarray, q: np.ndarray, d: np.ndarray, span: float,
                    i: np.ndarray, j: np.ndarray) -> tuple[int, int] | None:
    """The first pair (i, j) in the order i, then j, of the given pairs (i[k] < j[k]) of
    sides that cross, touch or fold back, or None."""
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
    if not bad.size:
        return None
    k = bad[np.lexsort((j[bad], i[bad]))[0]]
    return int(i[k]), int(j[k])
