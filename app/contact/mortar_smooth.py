"""Dual mortar against a smoothed master (`discretisation = "mortar-smooth"`).

The same rows as `mortar` (app/contact/mortar.py) except, on an interface whose master
segments are more than COARSE_RATIO x the slave's, the master's interpolation in the
mortar integrals: the linear trace plus, at every master node k with two neighbours on
a smooth stretch of the curve, a cubic kernel times the node's divided second difference,

    w = N_lin + sum_k c(t_k) v_k,   c(t) = (1 - |t|)^2 (1/6 - 2 |t| / 3),   |t| <= 1,
    v_k = (h_k, -(h_{k-1} + h_k), h_{k-1}) / (h_{k-1} + h_k)  on nodes (k-1, k, k+1),

t_k the distance from node k in units of the segment on that side, h_{k-1}, h_k the
lengths of the segments before and after k (`smooth_weights`). On segment [a, b] the
rows reach (prev, a, b, next). c's slope jump at t = 0 cancels the linear trace's kink,
so the interpolation is C1 in arclength; c = c' = 0 at |t| = 1 and int c = 0 on each
side of the node. Hence, on any master spacing: rows sum to 1, fields linear along a
straight master are reproduced (v_k annihilates them), and every master node keeps the
linear trace's share of a traction (int w_l ds = int N_l ds), at the curve's ends and
corners too, where the end or corner node has no kernel: the curve passes through it.
So the non-matching patch test holds wherever the contact reaches (before, a quadratic
B-spline with a reflected end node gave the end node 13/24 of a segment instead of 1/2:
the patch test failed by 8-55% at a master's ends, and bonded pairs there debonded
early). The kernel is a cubic on each master segment: 4 Gauss points per mortar piece
(cut at the master nodes) integrate the rows exactly.

Why: a slave much finer than its master follows the master's piecewise-linear surface,
kinks included, and its tractions oscillate with the master's element period (multibody
`indent`, master elements 4.4x the slave's: 30% of max p off a local quadratic fit, max
p 86 where a master of the slave's size gives 58). The smoothed master has no kinks for
the slave nodes to follow (2.5%, max p 60.3; README "Smoothed master"). The master body
is still the piecewise-linear finite element: the contact sees a surface within
O(h_master^2 x curvature) of it. Opt in per interface; `mortar` stays the default.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from app.contact.constraints import ContactConstraints
from app.contact.mortar import MasterBasis, linear_master, mortar_constraints
from app.contact.resolution import SIZE_RATIO_WARN, median_size_ratio
from app.mesh.model import Mesh

if TYPE_CHECKING:  # app.contact.discretisation imports this module
    from app.contact.discretisation import InterfaceSpec

COARSE_RATIO = SIZE_RATIO_WARN
"""The whole master curve is smoothed when its segments facing the slave are longer
than this times the slave's (medians; the stripe check's threshold,
app/contact/resolution.py); else it keeps the linear trace. One choice per interface:
switching segment by segment would shift nodal forces where the choice changes."""
MAX_KINK_DEG = 30.0
"""Master nodes where the curve turns by more than this (degrees) are corners: the
smoothing does not round them off (each side is smoothed on its own)."""
SMOOTHED = "quadratic B-spline"
"""`master_interpolation` (summary.json) of an interface whose master is smoothed. The
name of the first smoothing (a quadratic B-spline), kept for the users' scripts that
read it; the interpolation is `smooth_weights`'."""
KINK_COS_TOL = 1e-9
"""Round-off allowed in the MAX_KINK_DEG test (on the cosine): a turn of exactly 30 deg
(a regular 12-gon, a 12-segment circle) is smooth at every node, not at the ones whose
rounding happens to fall on the smooth side."""


def master_neighbours(pts: np.ndarray, m_edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per master segment (F,) the node before its first end and after its second along
    the oriented master curve (m_edges (F, 2), pts (n, 2)), -1 at a curve end or where
    the curve turns by more than MAX_KINK_DEG."""
    n = pts.shape[0]
    a, b = m_edges[:, 0], m_edges[:, 1]
    d = pts[b] - pts[a]
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    into = np.full(n, -1, dtype=np.int64)  # segment ending at the node
    out = np.full(n, -1, dtype=np.int64)  # segment starting at the node
    seg = np.arange(m_edges.shape[0])
    into[b], out[a] = seg, seg
    cos_max = np.cos(np.radians(MAX_KINK_DEG)) - KINK_COS_TOL
    before, after = into[a], out[b]
    smooth_before = (before >= 0) & (np.einsum("ij,ij->i", d[before], d) >= cos_max)
    smooth_after = (after >= 0) & (np.einsum("ij,ij->i", d[after], d) >= cos_max)
    prev = np.where(smooth_before, a[before], -1)
    nxt = np.where(smooth_after, b[after], -1)
    return prev, nxt


def smooth_kernel(t: np.ndarray) -> np.ndarray:
    """c(t) = (1 - |t|)^2 (1/6 - 2 |t| / 3) on |t| <= 1 (t: distance from a master node
    in units of the segment on that side), the one cubic per side with slope -1 / +1
    at t = 0 (a jump that cancels the linear trace's kink), c = c' = 0 at |t| = 1, and
    int_0^1 c = int_-1^0 c = 0. A cubic on each master segment: the 4 Gauss points of
    a mortar piece (cut at the master nodes) integrate it against the dual functions
    exactly."""
    r = np.abs(t)
    return (1.0 - r) ** 2 * (1.0 / 6.0 - 2.0 * r / 3.0)


def smooth_weights(eta: np.ndarray, has_prev: np.ndarray, has_next: np.ndarray,
                   lengths: np.ndarray | None = None) -> np.ndarray:
    """Weights (4, p, g) on (prev, a, b, next) of the smoothed master at parameters eta
    (p, g) of segments [a, b]: the linear trace plus, at each of a and b that has both
    neighbours (has_prev, has_next (p,) bool), `smooth_kernel` times the node's divided
    second difference. lengths (p, 3): |a - prev|, |b - a|, |next - b| (None: equal).

    Rows sum to 1 and reproduce fields linear along a straight master of any spacing
    (the second differences vanish there); each node's integral over the curve is its
    linear-trace share, at the curve's ends and corners too (the kernel has zero mean
    on each side); the curve is C1 in arclength and passes through end and corner nodes.
    """
    if lengths is None:
        lengths = np.ones((eta.shape[0], 3))
    hp, h, hn = (lengths[:, k, None] for k in range(3))
    ca = np.where(has_prev[:, None], smooth_kernel(eta), 0.0)
    cb = np.where(has_next[:, None], smooth_kernel(eta - 1.0), 0.0)
    w_prev = ca * h / (h + hp)
    w_next = cb * h / (h + hn)
    w_a = (1.0 - eta) - ca + cb * hn / (h + hn)
    w_b = eta + ca * hp / (h + hp) - cb
    return np.stack([w_prev, w_a, w_b, w_next])


def master_slave_ratio(pts: np.ndarray, m_edges: np.ndarray, facing: np.ndarray,
                       slave_length: np.ndarray) -> float:
    """Median length of the master segments faced by slave nodes (facing (q,)) over the
    median tributary length of those nodes (slave_length (q,)): the stripe check's ratio
    (app/contact/resolution.py), here over the slave nodes nearest the master
    (app.contact.mortar.nearest_slave_nodes); 0 with none."""
    if facing.size == 0:
        return 0.0
    return median_size_ratio(pts[m_edges[facing]], slave_length)


def neighbour_lengths(pts: np.ndarray, m_edges: np.ndarray, prev: np.ndarray,
                      nxt: np.ndarray) -> np.ndarray:
    """(F, 3) lengths |a - prev|, |b - a|, |next - b| of each master segment [a, b] and
    its neighbours (`master_neighbours`; the segment's own length where one is missing)."""
    a, b = pts[m_edges[:, 0]], pts[m_edges[:, 1]]
    h = np.linalg.norm(b - a, axis=1)
    hp = np.where(prev >= 0, np.linalg.norm(a - pts[np.maximum(prev, 0)], axis=1), h)
    hn = np.where(nxt >= 0, np.linalg.norm(pts[np.maximum(nxt, 0)] - b, axis=1), h)
    return np.column_stack([hp, h, hn])


def smooth_master(pts: np.ndarray, m_edges: np.ndarray, facing: np.ndarray,
                  slave_length: np.ndarray) -> MasterBasis:
    """The master interpolation over (prev, a, b, next) of each segment: `smooth_weights`
    on every segment when `master_slave_ratio` exceeds COARSE_RATIO, else the
    linear trace (1 - eta, eta) (arguments as app.contact.mortar.linear_master)."""
    if master_slave_ratio(pts, m_edges, facing, slave_length) <= COARSE_RATIO:
        return linear_master(pts, m_edges, facing, slave_length)
    prev, nxt = master_neighbours(pts, m_edges)
    nodes = np.column_stack([prev, m_edges[:, 0], m_edges[:, 1], nxt])  # (F, 4)
    lengths = neighbour_lengths(np.asarray(pts, dtype=float), m_edges, prev, nxt)

    def basis(f: np.ndarray, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return nodes[f], smooth_weights(eta, prev[f] >= 0, nxt[f] >= 0, lengths[f])

    basis.label = SMOOTHED
    return basis


def mortar_smooth_constraints(mesh: Mesh, itf: InterfaceSpec,
                              index: int) -> ContactConstraints:
    """Dual mortar rows of one interface with the smoothed master `smooth_master`."""
    return mortar_constraints(mesh, itf, index, master_basis=smooth_master)
