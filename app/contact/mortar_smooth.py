"""Dual mortar against a smoothed master (`discretisation = "mortar-smooth"`).

The same rows as `mortar` (app/contact/mortar.py) except, on an interface whose master
segments are more than COARSE_RATIO x the slave's, the master's interpolation in the
mortar integrals: a uniform quadratic B-spline whose control points are the master
nodes, instead of the master's piecewise-linear trace. On master segment [a, b] at
parameter eta the point (and the displacement) is

    eta < 1/2:  B0(u) x_prev + B1(u) x_a + B2(u) x_b,   u = eta + 1/2,
    eta >= 1/2: B0(u) x_a + B1(u) x_b + B2(u) x_next,   u = eta - 1/2,

with B0 = (1 - u)^2 / 2, B1 = (1 + 2u - 2u^2) / 2, B2 = u^2 / 2: C1 along the curve,
through the midpoints of the master segments, with the segment's own slope there. At an
end of the master curve, or at a corner sharper than MAX_KINK_DEG, the missing neighbour
is the reflection 2 x_a - x_b, which makes the half segment there linear.

Why: a slave much finer than its master follows the master's piecewise-linear surface,
kinks included, and its tractions oscillate with the master's element period (multibody
`indent`, master elements 4.4x the slave's: 30% of max p off a local quadratic fit, max
p 86 where a master of the slave's size gives 58). The smoothed master has no kinks for
the slave nodes to follow (1.7%, max p 60; README "Smoothed master"). The master body is
still the piecewise-linear finite element: the contact sees a surface within
O(h_master^2 x curvature) of it.

What it costs: the B-spline reproduces rigid motions and linear fields (the rows keep
sum w = 1 and the gap of a uniform approach is exact), and its nodal force weights
int B_l ds equal the master's own int N_l ds on uniform master segments away from the
curve's ends and corners. At a master curve's end they differ: the end node takes
13/24 of a segment instead of 1/2 and the next node 23/24 instead of 1, so the
non-matching patch test is passed only where the contact stays away from the master's
ends (and corners). Opt in per interface; `mortar` stays the default.
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
B-spline does not round them off (each side is smoothed on its own)."""
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


def bspline_weights(eta: np.ndarray, has_prev: np.ndarray,
                    has_next: np.ndarray) -> np.ndarray:
    """Weights (4, p, g) on (prev, a, b, next) of the quadratic B-spline at parameters eta
    (p, g) of segments [a, b]; has_prev, has_next (p,) bool. A missing neighbour is the
    reflection 2 x_a - x_b (2 x_b - x_a), folded into the weights of a and b."""
    left = eta < 0.5
    u = np.where(left, eta + 0.5, eta - 0.5)
    b0, b1, b2 = 0.5 * (1 - u) ** 2, 0.5 * (1 + 2 * u - 2 * u * u), 0.5 * u * u
    hp, hn = has_prev[:, None], has_next[:, None]
    zero = np.zeros_like(eta)
    w_prev = np.where(left & hp, b0, zero)
    w_next = np.where(~left & hn, b2, zero)
    w_a = np.where(left, b1 + np.where(hp, 0, 2 * b0), b0 - np.where(hn, 0, b2))
    w_b = np.where(left, b2 - np.where(hp, 0, b0), b1 + np.where(hn, 0, 2 * b2))
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


def bspline_master(pts: np.ndarray, m_edges: np.ndarray, facing: np.ndarray,
                   slave_length: np.ndarray) -> MasterBasis:
    """The master interpolation over (prev, a, b, next) of each segment: the quadratic
    B-spline on every segment when `master_slave_ratio` exceeds COARSE_RATIO, else the
    linear trace (1 - eta, eta) (arguments as app.contact.mortar.linear_master)."""
    if master_slave_ratio(pts, m_edges, facing, slave_length) <= COARSE_RATIO:
        return linear_master(pts, m_edges, facing, slave_length)
    prev, nxt = master_neighbours(pts, m_edges)
    nodes = np.column_stack([prev, m_edges[:, 0], m_edges[:, 1], nxt])  # (F, 4)

    def basis(f: np.ndarray, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return nodes[f], bspline_weights(eta, prev[f] >= 0, nxt[f] >= 0)

    basis.label = "quadratic B-spline"
    return basis


def mortar_smooth_constraints(mesh: Mesh, itf: InterfaceSpec,
                              index: int) -> ContactConstraints:
    """Dual mortar rows of one interface with the smoothed master `bspline_master`."""
    return mortar_constraints(mesh, itf, index, master_basis=bspline_master)
