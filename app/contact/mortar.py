"""Dual mortar (segment-to-segment) contact rows in 2D, linear segments.

One multiplier per slave node j, with the dual shape functions phi_j of the linear slave
segments (biorthogonal to the standard ones N_k: int phi_j N_k ds = delta_jk D_j, so the
mortar matrix D is diagonal, D_j = tributary length of node j). The weighted gap and slip
of node j are

    g~_j = n_j . (D_j x_j - sum_l M_jl x_l),   M_jl = int_slave phi_j N_l(eta(s)) ds,

(N_l: the master's linear trace, or the interpolation passed as `master_basis`),
integrated over the segmentation of the slave segments by the master segments: master
nodes are projected onto each slave segment along the interpolated contact normal
n(s) = (1 - s) n_1 + s n_2, each slave Gauss point onto the master segment along the same
n(s) (eta = master parameter). Rows are divided by the covered weight sum_l M_jl (= D_j
when the master covers the node's support), so a row reads
n_j . (u_j - sum_l w_jl u_l) with sum_l w_jl = 1: gaps stay lengths, the multiplier is the
force at the slave node and force / (D_j x thickness) its traction. On a slave segment
the master covers only in part, the dual functions are those biorthogonal over the
covered pieces, and a node without a row that faces the master over less than half its
support (or lies beyond a free end of it) gives its share to the nearest carrier along
the slave (`covered_tests`, `share_owners`): the row sums add up to the covered length.

Contact normal (choice, see README): the averaged nodal outward normals of both sides
(nu_s of the slave node, nu_m of the master interpolated at the node's closest point),
weighted by the other side's curvature (`contact_normal`): the flatter side's normal
wins, equal curvatures give the mean. Against a flat side this is the flat side's normal,
the common normal of the linear (Hertz, Cattaneo-Mindlin) theories, so a frictionless
contact cannot hold a tangential load through tilted normals whichever side is the slave;
the formula is symmetric in the two sides. Tangent t_j = (-n_y, n_x) as in
`app.contact.pairs`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from app.contact.constraints import ContactConstraints
from app.contact.pairs import (
    XI_EPS,
    ContactPairs,
    _beyond_free_end,
    _curve_edges,
    closest_segments,
    continued_end_gaps,
    end_overlaps,
    master_segments,
    no_slave_error,
    refuse_penetration,
    tributary_length,
)
from app.errors import InputError
from app.mesh.model import Mesh, orient_boundary_edges

if TYPE_CHECKING:  # app.contact.discretisation imports this module
    from app.contact.discretisation import InterfaceSpec

_GAUSS_S, _GAUSS_W = np.polynomial.legendre.leggauss(4)
NEAR_BAND = 0.1
"""Slave nodes within this fraction of search_distance of the smallest nodal gap are the
ones a master-basis factory judges the interface by (`nearest_slave_nodes`)."""
MIN_COVER = 0.5
"""Slave nodes whose support is covered by less than this fraction of D_j are dropped."""
COVER_RTOL = 1e-9
"""Relative round-off allowed in the MIN_COVER test: a slave node right above a master
end has exactly half its support covered, and is kept whatever the rounding of its
integrals (else a symmetric scene kept one end node and dropped its mirror image)."""


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)


def nodal_normals(points: np.ndarray, edges: np.ndarray,
                  n_nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Averaged outward unit normals (n_nodes, 2) and curvatures (n_nodes,) (1/length) of
    a curve whose edges (k, 2) are oriented with the body on the left; zero off the curve.
    The curvature of a node is the angle between its two edge normals over its tributary
    length (0 at the ends of the curve, and where the angle is round-off: `kink_angles`)."""
    d = points[edges[:, 1]] - points[edges[:, 0]]
    le = np.linalg.norm(d, axis=1)
    ne = np.column_stack([d[:, 1], -d[:, 0]]) / le[:, None]
    acc = np.zeros((n_nodes, 2))
    for c in range(2):
        acc[:, c] = np.bincount(edges.ravel(), weights=np.repeat(ne[:, c], 2),
                                minlength=n_nodes)
    norm = np.linalg.norm(acc, axis=1)
    on = norm > 0
    trib = np.bincount(edges.ravel(), weights=np.repeat(0.5 * le, 2), minlength=n_nodes)
    angle = kink_angles(points, edges, ne, le, acc, n_nodes)
    kappa = np.where(trib > 0, angle / np.where(trib > 0, trib, 1.0), 0.0)
    acc[on] = acc[on] / norm[on, None]
    return acc, kappa


def kink_angles(points: np.ndarray, edges: np.ndarray, ne: np.ndarray, le: np.ndarray,
                acc: np.ndarray, n_nodes: int) -> np.ndarray:
    """(n_nodes,) angle (rad, >= 0) between the two edge normals ne (k, 2) at each node of
    a curve (edges (k, 2) oriented head to tail, lengths le (k,), acc the sum of a node's
    edge normals); 0 at the curve's ends and where the angle is below the round-off of
    the coordinates (64 eps |x| / edge length), so that a straight side reads flat at any
    position and angle (with arccos(|n1 + n2| / 2), a straight side turned by 30 deg read
    kinks of 3e-8 rad at random nodes, and the curvature weights of `contact_normal`
    then swung a flat-on-flat normal: p changed by 1.4% on turning the scene).
    """
    count = np.bincount(edges.ravel(), minlength=n_nodes)
    dif = np.zeros((n_nodes, 2))  # n_next - n_prev: |n1 - n2| = 2 sin(angle / 2)
    for c in range(2):
        dif[:, c] = (np.bincount(edges[:, 0], weights=ne[:, c], minlength=n_nodes)
                     - np.bincount(edges[:, 1], weights=ne[:, c], minlength=n_nodes))
    angle = 2 * np.arctan2(np.linalg.norm(dif, axis=1), np.linalg.norm(acc, axis=1))
    le_min = np.full(n_nodes, np.inf)
    np.minimum.at(le_min, edges.ravel(), np.repeat(le, 2))
    size = np.maximum(np.abs(points).max(axis=1), np.where(np.isfinite(le_min), le_min, 0.0))
    noise = 64 * np.finfo(float).eps * size / np.where(np.isfinite(le_min), le_min, 1.0)
    return np.where((count == 2) & (angle > noise), angle, 0.0)


def contact_normal(nu_s: np.ndarray, kappa_s: np.ndarray, nu_m: np.ndarray,
                   kappa_m: np.ndarray) -> np.ndarray:
    """(p, 2) unit contact normals (master -> slave) from the outward normals and
    curvatures of both sides at the same points: the flatter side weighs more,
    n = unit(k_s nu_m - k_m nu_s); equal curvatures give the mean, a flat side its own
    normal. Symmetric in the two sides, so swapping slave and master keeps it."""
    ks, km = kappa_s[:, None], kappa_m[:, None]
    tot = ks + km
    flat = tot <= 0
    ws = np.where(flat, 0.5, km / np.where(flat, 1.0, tot))
    return _unit((1 - ws) * nu_m - ws * nu_s)


def project_onto_segment(x: np.ndarray, x1: np.ndarray, x2: np.ndarray, n1: np.ndarray,
                         n2: np.ndarray) -> np.ndarray:
    """Parameter s of the point x1 + s (x2 - x1) whose interpolated normal
    (1 - s) n1 + s n2 passes through x (all (p, 2)); the root nearest 0.5, nan if none."""
    r, dx, dn = x - x1, x2 - x1, n2 - n1
    a = -_cross(dx, dn)
    b = _cross(r, dn) - _cross(dx, n1)
    c = _cross(r, n1)
    disc = b * b - 4 * a * c
    sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
    q = -0.5 * (b + np.where(b >= 0, 1.0, -1.0) * sq)
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = np.where(a != 0, q / a, np.nan)
        r2 = np.where(q != 0, c / q, np.nan)
    d1 = np.where(np.isfinite(r1), np.abs(r1 - 0.5), np.inf)
    d2 = np.where(np.isfinite(r2), np.abs(r2 - 0.5), np.inf)
    return np.where(d1 < d2, r1, r2)


def _candidates(xs1, xs2, xa, xb, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """(slave segment e, master segment f) index pairs whose midpoints are close enough
    for the segments to come within `reach` of each other (both (p,) int64)."""
    ls = np.linalg.norm(xs2 - xs1, axis=1)
    lm = np.linalg.norm(xb - xa, axis=1)
    ms, mm = 0.5 * (xs1 + xs2), 0.5 * (xa + xb)
    radius = reach + 0.5 * (ls.max() + lm.max())
    hits = cKDTree(ms).sparse_distance_matrix(cKDTree(mm), radius, output_type="ndarray")
    e, f = hits["i"].astype(np.int64), hits["j"].astype(np.int64)
    near = hits["v"] <= reach + 0.5 * (ls[e] + lm[f])
    return e[near], f[near]


MasterBasis = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
"""The master-side interpolation: (f (p,) master segments, eta (p, g) parameters on them)
-> (nodes (p, k) master node ids, -1 for none; weights (k, p, g), summing to 1). An
attribute `label` names it in the summary (none: "linear")."""
BasisFactory = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], MasterBasis]
"""(pts, m_edges, facing, slave_length) -> MasterBasis (see `linear_master`)."""
NormalRule = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]
"""(nu_s, k_s, nu_m, k_m) -> (p, 2) unit contact normals, master -> slave (see
`contact_normal`)."""


def linear_master(pts: np.ndarray, m_edges: np.ndarray, facing: np.ndarray,
                  slave_length: np.ndarray) -> MasterBasis:
    """The master's own piecewise-linear trace: N = (1 - eta, eta) on the segment's ends.

    The signature of every master-basis factory: pts (n, 2), m_edges (F, 2) oriented
    master segments, and per slave node nearest the master (`nearest_slave_nodes`) the
    master segment it faces (facing (q,)) and its tributary length (slave_length (q,));
    unused here."""
    return lambda f, eta: (m_edges[f], np.stack([1 - eta, eta]))


def dual_multipliers(s: np.ndarray) -> np.ndarray:
    """Dual shape functions (2, ...) of a linear slave segment at parameters s in [0, 1]:
    phi_1 = 2 - 3s, phi_2 = 3s - 1, biorthogonal to N = (1 - s, s)."""
    return np.stack([2 - 3 * s, 3 * s - 1])


@dataclass(frozen=True)
class Multipliers:
    """The multiplier (test) functions of the mortar rows.

    shape: s (p, g) -> (2, p, g) values on a slave segment at its ends 0 and 1.
    slave_mass: False when shape is biorthogonal to the slave's N (dual: the slave part
    of a row is the node itself, D diagonal); True to integrate the slave part
    int shape_j N_k ds over the covered pieces as well (standard functions, banded D).
    consistent: True for shape functions that must be biorthogonal to N over the covered
    part of a partly covered slave segment (`covered_tests`), so that D stays diagonal.
    """

    name: str
    shape: Callable[[np.ndarray], np.ndarray]
    slave_mass: bool
    consistent: bool = False


DUAL = Multipliers("dual", dual_multipliers, slave_mass=False, consistent=True)


def segment_overlaps(xs1: np.ndarray, xs2: np.ndarray, ns1: np.ndarray, ns2: np.ndarray,
                     xa: np.ndarray, xb: np.ndarray, e: np.ndarray, f: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Gauss points of the overlaps of candidate pairs (slave segment e, master segment f).

    xs1, xs2, ns1, ns2: (S, 2) slave segment ends and their contact normals; xa, xb:
    (F, 2) master segment ends. Returns (k (p,) indices of the pairs that overlap,
    s (p, g) slave parameters, w (p, g) quadrature weights (length), eta (p, g) master
    parameters where the interpolated normal through the slave point meets segment f).
    """
    x1, x2, n1, n2 = xs1[e], xs2[e], ns1[e], ns2[e]
    pa, pb = xa[f], xb[f]
    sa = project_onto_segment(pa, x1, x2, n1, n2)
    sb = project_onto_segment(pb, x1, x2, n1, n2)
    lo = np.clip(np.fmin(sa, sb), 0.0, 1.0)
    hi = np.clip(np.fmax(sa, sb), 0.0, 1.0)
    ok = np.isfinite(sa) & np.isfinite(sb) & (hi - lo > 1e-12)
    k = np.flatnonzero(ok)
    lo, hi = lo[k], hi[k]
    s = 0.5 * (lo + hi)[:, None] + 0.5 * (hi - lo)[:, None] * _GAUSS_S  # (p, g)
    w = (0.5 * (hi - lo) * np.linalg.norm(x2[k] - x1[k], axis=1))[:, None] * _GAUSS_W
    # the Gauss points relative to the master segment's start, from coordinate
    # differences: x1 + s (x2 - x1) - pa carried the round-off of |x|, not of the
    # segments (eta, so the weights, moved by 1e-10 when the scene was moved by 1e6)
    rg = (x1[k] - pa[k])[:, None] + s[..., None] * (x2[k] - x1[k])[:, None]
    ng = n1[k, None] + s[..., None] * (n2[k] - n1[k])[:, None]
    dm = (pb[k] - pa[k])[:, None]
    den = _cross(dm, ng)
    eta = np.clip(_cross(rg, ng) / np.where(den == 0, np.nan, den), 0, 1)
    return k, s, w, np.nan_to_num(eta, nan=0.5)


def segment_integrals(xs1: np.ndarray, xs2: np.ndarray, ns1: np.ndarray, ns2: np.ndarray,
                      xa: np.ndarray, xb: np.ndarray, e: np.ndarray, f: np.ndarray,
                      basis: MasterBasis, multipliers: Multipliers = DUAL,
                      carrier: np.ndarray | None = None) -> tuple:
    """Mortar integrals of candidate pairs (slave segment e, master segment f).

    Arguments as `segment_overlaps`; basis: the master interpolation (`linear_master` or
    a smoothed one); carrier (S, 2) bool: which ends of each slave segment carry a
    multiplier (None: all; `covered_tests`). Returns (pair (r,), j (r,) 0/1 slave end,
    node (r,) master node id (-1: none), value (r,)) with value = int phi_j N_node ds over
    the overlap (length), phi = the test functions of `covered_tests`, and the slave
    integrals (p, 2, 2) int phi_j N_k ds of the overlapping pairs (k: slave end), in pair
    order of `pair`'s unique values.
    """
    k, s, w, eta = segment_overlaps(xs1, xs2, ns1, ns2, xa, xb, e, f)
    ls = np.linalg.norm(xs2 - xs1, axis=1)
    ends = (np.ones((xs1.shape[0], 2), dtype=bool) if carrier is None else carrier)[e[k]]
    phi = covered_tests(multipliers, s, w / ls[e[k], None], e[k], ends)
    return piece_integrals(k, s, w, eta, f, basis, phi)


def piece_integrals(k: np.ndarray, s: np.ndarray, w: np.ndarray, eta: np.ndarray,
                    f: np.ndarray, basis: MasterBasis, phi: np.ndarray) -> tuple:
    """`segment_integrals` from the overlaps (k, s, w, eta of `segment_overlaps`) and the
    test functions phi (2, p, g) at their Gauss points."""
    nodes, big_n = basis(f[k], eta)  # (p, q), (q, p, g)
    val = np.einsum("jpg,lpg,pg->pjl", phi, big_n, w)  # (p, 2, q)
    slave = np.einsum("jpg,lpg,pg->pjl", phi, np.stack([1 - s, s]), w)  # (p, 2, 2)
    q = nodes.shape[1]
    pair = np.repeat(k, 2 * q)
    jj = np.tile(np.repeat([0, 1], q), k.size)
    node = np.repeat(nodes[:, None, :], 2, axis=1).reshape(-1)
    return pair, jj, node, val.reshape(-1), (k, slave)


FULL_COVER_TOL = 1e-12
"""A slave segment whose covered pieces have measure, centroid and second moment within
this of the whole segment's (1, 1/2, 1/12) is whole: it keeps the dual functions of
`dual_multipliers` bit for bit."""


def covered_tests(multipliers: Multipliers, s: np.ndarray, wp: np.ndarray, seg: np.ndarray,
                  carrier: np.ndarray) -> np.ndarray:
    """Test functions (2, p, g) at the Gauss points s (p, g) (weights wp (p, g) in units
    of the slave parameter) of overlap pieces on slave segments seg (p,) whose ends carry
    a multiplier where carrier (p, 2) is True.

    A segment with one carrier end (the other end's node has no row and faces the master
    over less than half its support, or lies beyond a free end of it, `_covered_weights`)
    tests the carrier with 1, the sum of the two shape functions: the other node's
    covered share goes to its neighbour, so the row sums add up to the covered length.
    A segment with no carrier end tests with N = (1 - s, s), each handed to the nearest
    carrier along the slave (`share_owners`). Dual multipliers (`multipliers.consistent`)
    on a segment the master covers only in part are biorthogonal over the covered pieces
    (Cichosz and Bischoff 2011): phi_1 = (1 - c) - g (s - c), phi_2 = c + g (s - c) with c
    the pieces' centroid, g = c (1 - c) m0 / m2 (m0, m2 their measure and second moment
    about c), so int_cov phi_j N_k = delta_jk int_cov N_j: D stays diagonal and D_j is
    the covered part of the node's tributary length (the functions of the whole segment,
    2 - 3s and 3s - 1, are biorthogonal only over all of it, and a master end inside a
    segment gave row sums up to 1.16 D_j and an end node 0.5 - 2o + 1.5 o^2 of its half
    edge for an overhang o)."""
    phi = multipliers.shape(s)
    if multipliers.consistent and seg.size:
        n_seg = int(seg.max()) + 1
        m0 = np.bincount(seg, weights=wp.sum(axis=1), minlength=n_seg)
        c = np.bincount(seg, weights=(wp * s).sum(axis=1), minlength=n_seg)
        c = c / np.where(m0 > 0, m0, 1.0)
        m2 = np.bincount(seg, weights=(wp * (s - c[seg, None]) ** 2).sum(axis=1),
                         minlength=n_seg)
        whole = ((np.abs(m0 - 1) <= FULL_COVER_TOL) & (np.abs(c - 0.5) <= FULL_COVER_TOL)
                 & (np.abs(12 * m2 - 1) <= FULL_COVER_TOL))
        g = c * (1 - c) * m0 / np.where(m2 > 0, m2, 1.0)
        cs, gs = c[seg, None], g[seg, None]
        part = np.stack([(1 - cs) - gs * (s - cs), cs + gs * (s - cs)])
        phi = np.where(whole[seg][None, :, None], phi, part)
    one = carrier.sum(axis=1) == 1
    phi = np.where((carrier.sum(axis=1) == 0)[None, :, None], np.stack([1 - s, s]), phi)
    return np.where(one[None, :, None], carrier.T[:, :, None].astype(float), phi)


def _rows(nodes: np.ndarray, n_nodes: int, s_edges: np.ndarray, pair, jj, node, val,
          e) -> sp.csr_matrix:
    """Covered mortar matrix M (len(nodes), n_nodes): row = slave node (position in
    `nodes`), column = master node (entries with node -1 or zero weight dropped, so a
    row spans only the master nodes it depends on)."""
    where = np.full(n_nodes, -1, dtype=np.int64)
    where[nodes] = np.arange(nodes.size)
    r = where[s_edges[e[pair], jj]]
    ok = (r >= 0) & (node >= 0) & (val != 0)
    return sp.csr_matrix((val[ok], (r[ok], node[ok])), shape=(nodes.size, n_nodes))


@dataclass(frozen=True)
class SlaveGeometry:
    """The geometry the mortar rows of one interface start from, before any integral.

    pts (n, 2) mesh points; s_edges (k, 2), m_edges (F, 2) slave and master edges, each
    oriented with its body on the left; tol the penetration tolerance (length); per slave
    node (q,): nodes its id, d_len its tributary length D_j, found (a master segment
    within search_distance), sg that segment's index (0 if not found), xi its parameter
    in [0, 1], g_node the nodal gap (length, open > 0; beyond a free master end, below
    the master continued, `continued_end_gaps`), near (`nearest_slave_nodes`), beyond
    (found, beyond a free master end by more than XI_EPS);
    normal (n, 2) the contact normals (master -> slave) at the slave nodes, zero elsewhere.
    """

    pts: np.ndarray
    s_edges: np.ndarray
    m_edges: np.ndarray
    tol: float
    nodes: np.ndarray
    d_len: np.ndarray
    found: np.ndarray
    sg: np.ndarray
    xi: np.ndarray
    normal: np.ndarray
    g_node: np.ndarray
    near: np.ndarray
    beyond: np.ndarray

    def master_basis_args(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(pts, m_edges, facing, slave_length): the arguments of a master-basis factory
        (`linear_master`), over the slave nodes nearest the master."""
        return self.pts, self.m_edges, self.sg[self.near], self.d_len[self.near]


def _master_measures(pts: np.ndarray, m_edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(seg_len (k,), m_degree (n,)): the master edges' lengths and each node's number of
    master edges (1 at a free end), as `_beyond_free_end` and `end_overlaps` take them."""
    seg_len = np.linalg.norm(pts[m_edges[:, 1]] - pts[m_edges[:, 0]], axis=1)
    return seg_len, np.bincount(m_edges.ravel(), minlength=pts.shape[0])


def slave_geometry(mesh: Mesh, itf: InterfaceSpec, normal_rule: NormalRule | None = None
                   ) -> SlaveGeometry:
    """The `SlaveGeometry` of one interface (itf and normal_rule as `mortar_constraints`):
    its edges (InputError for an unknown curve or a zero-length master edge), the slave
    nodes' closest master points, contact normals and nodal gaps."""
    sd = float(itf.search_distance)
    pts = np.asarray(mesh.points, dtype=float)
    s_edges, m_edges, tol = _interface_edges(mesh, itf, pts)
    nodes, d_len = tributary_length(pts, s_edges)
    rule = contact_normal if normal_rule is None else normal_rule
    found, sg, xi, normal = _slave_normals(pts, s_edges, m_edges, nodes, sd, rule)
    xa, xb = pts[m_edges[:, 0]], pts[m_edges[:, 1]]
    g_node = _nodal_gap(pts[nodes], xa[sg], xb[sg], xi)
    # beyond a free master end: the depth below the master continued beyond it, as
    # node-to-segment (its line read a touching pin a (a + h) / (2 R) into a hole's end)
    seg_len, m_degree = _master_measures(pts, m_edges)
    ab = (xb - xa)[sg]
    xr = np.einsum("ij,ij->i", pts[nodes] - xa[sg], ab) / seg_len[sg] ** 2
    g_node, beyond = continued_end_gaps(pts[nodes], sg, np.where(found, xr, 0.5), g_node,
                                        pts, m_edges, seg_len, m_degree)
    near = nearest_slave_nodes(found, g_node, sd)
    return SlaveGeometry(pts, s_edges, m_edges, tol, nodes, d_len, found, sg, xi, normal,
                         g_node, near, found & beyond)


def mortar_constraints(mesh: Mesh, itf: InterfaceSpec, index: int,
                       normal_rule: NormalRule | None = None,
                       master_basis: BasisFactory | None = None,
                       multipliers: Multipliers = DUAL) -> ContactConstraints:
    """Mortar rows of one interface (see the module docstring).

    normal_rule: (nu_s, k_s, nu_m, k_m) -> (p, 2) unit contact normals (master -> slave);
    None: `contact_normal` (app/contact/mortar_bisector.py registers another).
    master_basis: (pts, m_edges, facing, slave_length) -> MasterBasis, the master
    interpolation N_l in the mortar integrals and so in the gaps and slips; None:
    `linear_master` (app/contact/mortar_smooth.py registers a smoothed one).
    multipliers: the test functions of the rows (`DUAL`; app/contact/mortar_standard.py
    registers the standard ones).

    itf: an `[[interface]]` (name, slave, master, search_distance, penetration_tol,
    interference). Slave nodes farther than search_distance from the master, with less
    than MIN_COVER of their support facing it, or with g0 > search_distance are dropped.
    Initial penetrations are checked as for node-to-segment on the nodal gap (distance of
    the slave node to its closest master point): the weighted gap g0 of a node touching a
    convex master is slightly negative (dual shape functions are negative in part), an
    O(h^2 / R) property of the discretisation, not an overlap.
    """
    return mortar_rows(slave_geometry(mesh, itf, normal_rule), itf, index, master_basis,
                       multipliers)


def mortar_rows(geo: SlaveGeometry, itf: InterfaceSpec, index: int,
                master_basis: BasisFactory | None = None,
                multipliers: Multipliers = DUAL) -> ContactConstraints:
    """`mortar_constraints` from the interface's geometry (`slave_geometry`)."""
    sd = float(itf.search_distance)
    factory = linear_master if master_basis is None else master_basis
    basis = linear_where_slave_ends(factory(*geo.master_basis_args()), geo)
    w, cover, covered = _covered_weights(geo, itf, sd, basis, multipliers)
    g0 = _initial_gaps(geo, itf, sd, w, basis, multipliers)
    # beyond a free master end the weighted gap extrapolates the covered part's gap to
    # the node, through the end segment's line: on a curve a (a + h) / (2 R) off its
    # depth below the master continued (pushing a touching hole's end node off a pin by
    # 2.6e-4 with interference), so the row takes the node's depth, node-to-segment's g0
    g0 = np.where(geo.beyond, geo.g_node, g0)
    keep = geo.found & covered & (g0 <= sd)
    if not keep.any():
        raise _none_kept_error(itf, sd, geo.found, covered)
    if not itf.interference:
        g_kept = geo.g_node[keep]
        refuse_penetration(itf.name, geo.pts[geo.nodes[keep]], g_kept, g_kept < -geo.tol,
                           geo.tol)
    return _kept_rows(geo, np.flatnonzero(keep), w, g0, cover, index,
                      getattr(basis, "label", "linear"))


def slave_end_segments(geo: SlaveGeometry) -> np.ndarray:
    """(F,) bool: the master segments inside which an end of the slave curve lies (a found
    slave node on one slave edge whose closest master point is inside the segment, more
    than XI_EPS from its ends): segments the slave covers only in part."""
    degree = np.bincount(geo.s_edges.ravel(), minlength=geo.pts.shape[0])[geo.nodes]
    inside = geo.found & (degree == 1) & (geo.xi > XI_EPS) & (geo.xi < 1 - XI_EPS)
    part = np.zeros(geo.m_edges.shape[0], dtype=bool)
    part[geo.sg[inside]] = True
    return part


def linear_where_slave_ends(basis: MasterBasis, geo: SlaveGeometry) -> MasterBasis:
    """basis with the master's linear trace on the master segments the slave ends inside
    (`slave_end_segments`); basis itself when it is the linear trace or there is none.

    A smoothed master (app/contact/mortar_smooth.py) gives each master node its linear
    share int N_l ds only over whole segments (its kernels have zero mean on each side of
    a node); over the part of a segment a slave covers they do not, so a slave ending
    inside a master segment put forces off the consistent ones on that segment's nodes,
    and two slaves meeting there (the lower blocks of "Interfaces meeting at a corner" as
    slaves of one upper block, joints at 1.9 h and 5.1 h of its element h) read p 0.66%
    off a uniform 10 where one of them was smoothed and the other not. The kernels of the
    whole segments next to it keep their zero means, so every master node gets its
    linear share of a uniform traction wherever the slave ends."""
    part = slave_end_segments(geo)
    if getattr(basis, "label", "linear") == "linear" or not part.any():
        return basis
    m_edges = geo.m_edges

    def ends_linear(f: np.ndarray, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        nodes, big_n = basis(f, eta)  # (p, q), (q, p, g)
        is_a = (nodes == m_edges[f, :1]).T[:, :, None]
        is_b = (nodes == m_edges[f, 1:]).T[:, :, None]
        lin = is_a * (1 - eta)[None] + is_b * eta[None]
        return nodes, np.where(part[f][None, :, None], lin, big_n)

    ends_linear.label = basis.label
    return ends_linear


def _initial_gaps(geo: SlaveGeometry, itf, sd: float, w: sp.csr_matrix, basis: MasterBasis,
                  multipliers: Multipliers) -> np.ndarray:
    """Initial weighted gaps g0 (q,) (length) of the rows w (q, n); with a master basis
    other than the linear trace and no `interference`, no overlap that the linear trace
    does not have (`no_made_overlap`)."""
    g0 = weighted_gaps(geo.pts, geo.nodes, geo.normal[geo.nodes], w)
    if getattr(basis, "label", "linear") != "linear" and not itf.interference:
        w_lin, *_ = _covered_weights(geo, itf, sd, linear_master(*geo.master_basis_args()),
                                     multipliers)
        g0 = no_made_overlap(g0, weighted_gaps(geo.pts, geo.nodes, geo.normal[geo.nodes],
                                               w_lin))
    return g0


def weighted_gaps(pts: np.ndarray, nodes: np.ndarray, nrm: np.ndarray,
                  w: sp.csr_matrix) -> np.ndarray:
    """(q,) weighted gaps n_j . (x_j - sum_l w_jl x_l) (length) of the rows w (q, n) whose
    nonzero rows sum to 1, at the slave nodes `nodes` (q,) with normals nrm (q, 2).

    Formed as n_j . sum_l w_jl (x_j - x_l), from coordinate differences: x_j - w x carried
    the round-off of the coordinates (eps |x|, 2.3e-10 with the scene moved by 1e6)
    instead of that of the gaps. A zero row (an uncovered node) reads 0 (it is dropped)."""
    w = w.tocsr()
    row = np.repeat(np.arange(w.shape[0]), np.diff(w.indptr))
    rel = pts[nodes[row]] - pts[w.indices]  # (nnz, 2)
    terms = w.data * np.einsum("ij,ij->i", nrm[row], rel)
    return np.bincount(row, weights=terms, minlength=w.shape[0])


def _kept_rows(geo: SlaveGeometry, k: np.ndarray, w: sp.csr_matrix, g0: np.ndarray,
               cover: np.ndarray, index: int, label: str) -> ContactConstraints:
    """The pairs and padded rows of the kept slave nodes k (positions in geo.nodes);
    cover (q,): each slave node's covered weight (length)."""
    nrm = geo.normal[geo.nodes]
    tan = np.column_stack([-nrm[:, 1], nrm[:, 0]])
    # length: the covered part of D_j where it is below D_j (`covered_length`), so that a
    # slave node facing a master's end over half its support gets p = force / that half
    # and c, a over that half (its whole D_j doubled the bond strength at a bond's edge)
    pairs = ContactPairs(
        interface=np.full(k.size, int(index), dtype=np.int64),
        slave=geo.nodes[k].astype(np.int64), master=geo.m_edges[geo.sg[k]].copy(),
        xi=geo.xi[k], normal=nrm[k], tangent=tan[k], g0=g0[k],
        position=geo.pts[geo.nodes[k]].copy(), length=covered_length(geo.d_len, cover)[k])
    return ContactConstraints(pairs, *_padded_rows(w[k].tocsr(), pairs),
                              master_interpolation=label)


def covered_length(d_len: np.ndarray, cover: np.ndarray) -> np.ndarray:
    """(q,) pair lengths: the covered weight (the row sum int_cov phi_j ds) where it
    differs from the tributary length D_j (below it: a slave node facing the master over
    part of its support; above it: a node that took over the covered share of a
    neighbour without a multiplier, `covered_tests`), else D_j itself (a fully covered
    node keeps D_j bit for bit, not its round-off)."""
    return np.where(np.abs(cover - d_len) > d_len * COVER_RTOL, cover, d_len)


def no_made_overlap(g0: np.ndarray, g0_linear: np.ndarray) -> np.ndarray:
    """Initial weighted gaps (q,) of a smoothed master interpolation g0 with no overlap
    that the master's own piecewise-linear surface (weighted gaps g0_linear (q,)) does not
    have: max(g0, min(g0_linear, 0)). A smoothed master lies off its segments by
    O(h^2 x curvature), into the slave at a concave kink; without `interference` that is
    not an intended fit, and as a negative g0 it pressed two touching bodies apart with no
    load at all (lengths)."""
    return np.maximum(g0, np.minimum(g0_linear, 0.0))


def _none_kept_error(itf, sd: float, found: np.ndarray, covered: np.ndarray):
    """The InputError of an interface that keeps no slave node: none within sd of the
    master (`no_slave_error`), or those within sd face it over less than MIN_COVER of
    their support (curves that meet end to end, or overlap by less than half a slave
    segment), which a larger search_distance does not change."""
    if not found.any() or (found & covered).any():
        return no_slave_error(itf.name, itf.slave, itf.master, sd)
    return InputError(
        f"interface '{itf.name}': the slave nodes of '{itf.slave}' within "
        f"search_distance={sd:g} of '{itf.master}' face it over less than half of their "
        f"support (the curves meet end to end or overlap by less than half a slave "
        f"element), so the mortar rows keep none; extend the overlap, refine the slave, "
        f'or use discretisation = "node-to-segment"')


def nearest_slave_nodes(found: np.ndarray, gap: np.ndarray, sd: float) -> np.ndarray:
    """(q,) bool: the found slave nodes whose nodal gap (q,) is within NEAR_BAND x sd of
    the smallest found gap (where contact starts; all of a flat, touching interface)."""
    if not found.any():
        return found
    return found & (gap <= gap[found].min() + NEAR_BAND * sd)


def _interface_edges(mesh: Mesh, itf, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Slave and master edges (k, 2) of the interface, each oriented with its body on the
    left, and the penetration tolerance (length), as for node-to-segment
    (`app.contact.pairs.master_segments`: InputError for a zero-length master edge)."""
    label = itf.name
    s_edges = orient_boundary_edges(mesh, _curve_edges(mesh, itf.slave, "slave", label),
                                    f"interface '{label}': slave curve '{itf.slave}'")
    m_edges, _, tol = master_segments(mesh, pts,
                                      _curve_edges(mesh, itf.master, "master", label),
                                      label, itf.master, itf.penetration_tol)
    return s_edges, m_edges, tol


def _slave_normals(pts: np.ndarray, s_edges: np.ndarray, m_edges: np.ndarray,
                   nodes: np.ndarray, sd: float, rule: Callable[..., np.ndarray]
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Closest master point and contact normal of the slave nodes `nodes` (q,).

    Returns found (q,) bool (a master segment within sd and the node not on the master
    curve), sg (q,) that segment (0 if not found), xi (q,) its parameter in [0, 1], and
    normal (n_nodes, 2): rule(nu_s, k_s, nu_m, k_m) (master -> slave) at the found nodes,
    -nu_s at the other slave nodes, zero elsewhere.
    """
    n = pts.shape[0]
    nu_s, k_s = nodal_normals(pts, s_edges, n)
    nu_m, k_m = nodal_normals(pts, m_edges, n)
    m_degree = np.bincount(m_edges.ravel(), minlength=n)
    seg, xr, dist = closest_segments(pts[nodes], pts[m_edges[:, 0]], pts[m_edges[:, 1]], sd)
    found = (seg >= 0) & (m_degree[nodes] == 0)
    sg = np.where(found, seg, 0)
    xi = np.clip(np.nan_to_num(xr), 0.0, 1.0)
    ma, mb = m_edges[sg, 0], m_edges[sg, 1]
    nu_mp = _unit((1 - xi)[:, None] * nu_m[ma] + xi[:, None] * nu_m[mb])
    k_mp = (1 - xi) * k_m[ma] + xi * k_m[mb]
    normal = np.zeros((n, 2))
    normal[nodes] = np.where(found[:, None], rule(nu_s[nodes], k_s[nodes], nu_mp, k_mp),
                             -nu_s[nodes])
    return found, sg, xi, normal


def _covered_weights(geo: SlaveGeometry, itf, sd: float, basis: MasterBasis,
                     multipliers: Multipliers = DUAL
                     ) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """Mortar weights of the slave nodes geo.nodes (q,) on the master nodes.

    Integrates the slave edges with a found node against the master segments within sd
    (along geo.normal). Returns w (q, n_nodes), the covered mortar matrix M with its rows
    divided by their sums (rows of uncovered nodes stay zero), cover (q,) those row sums
    (length), and carrier (q,) bool: the found nodes whose support faces the master over
    at least MIN_COVER of it (int_cov N_j ds >= MIN_COVER D_j, the standard shape function
    over the covered pieces: geometry, whatever the multipliers). A found node that is no
    carrier (inside or at a free master end), or a node beyond a free master end, gives
    its covered share to the nearest carrier along the slave (`covered_tests`,
    `share_owners`); a node out of reach over the master keeps its own test function
    without a row (its neighbour's row stays as it was, whatever the lengths of the
    edges beyond the search zone).
    InputError if no slave edge has a found node.
    A row reads u_j - sum_l w_jl u_l = (sum_k S_jk u_k - sum_l M_jl u_l) / cover_j, S the
    slave integrals int phi_j N_k ds over the same covered pieces (so the row sums stay
    1): all of them with multipliers.slave_mass, else (dual: S_jk = 0 between carriers)
    those on the nodes without a multiplier next to a carrier.
    """
    pts, nodes, found = geo.pts, geo.nodes, geo.found
    xa, xb = pts[geo.m_edges[:, 0]], pts[geo.m_edges[:, 1]]
    active = found[np.searchsorted(nodes, geo.s_edges)].any(axis=1)
    se = geo.s_edges[active]
    if se.shape[0] == 0:
        raise no_slave_error(itf.name, itf.slave, itf.master, sd)
    xs1, xs2 = pts[se[:, 0]], pts[se[:, 1]]
    ns1, ns2 = geo.normal[se[:, 0]], geo.normal[se[:, 1]]
    e, f = _candidates(xs1, xs2, xa, xb, sd)
    k, s, wq, eta = segment_overlaps(xs1, xs2, ns1, ns2, xa, xb, e, f)
    ends = se[e[k]]  # (p, 2) slave nodes of the overlapping pieces
    at = np.searchsorted(nodes, ends)
    geometric = _covered_shares(nodes, ends, s, wq)  # complete for the found nodes
    carrier = found & (geometric >= MIN_COVER * (1 - COVER_RTOL) * geo.d_len)
    carrier &= ~_end_overlap_refused(geo, sd)
    # a node without a row that faces the master (or lies beyond a free end of it) gives
    # its covered share to the nearest carrier along the slave curve
    beyond = _beyond_master_end(geo, float(sd + ls_max(xs1, xs2)))
    tests = carrier | ~(found | beyond)
    owner = share_owners(se, nodes, tests)
    ls = np.linalg.norm(xs2 - xs1, axis=1)
    phi = covered_tests(multipliers, s, wq / ls[e[k], None], e[k], tests[at])
    pair, jj, node, val, (k, slave) = piece_integrals(k, s, wq, eta, f, basis, phi)
    n = pts.shape[0]
    mm = _rows(nodes, n, owner, pair, jj, node, val, e)
    cover = np.asarray(mm.sum(axis=1)).ravel()
    if not multipliers.slave_mass:
        slave = slave * ~tests[at][:, None, :]  # only the nodes without a multiplier
    ss = _rows(nodes, n, owner, np.repeat(k, 4), np.tile([0, 0, 1, 1], k.size),
               np.repeat(ends, 2, axis=0).reshape(-1), slave.reshape(-1), e)
    if ss.nnz:
        own = sp.csr_matrix((np.ones(nodes.size), (np.arange(nodes.size), nodes)),
                            shape=(nodes.size, n))
        total = cover if multipliers.slave_mass else np.asarray(ss.sum(axis=1)).ravel()
        mm = mm - ss + sp.diags(total) @ own
    w = sp.diags(1.0 / np.where(cover > 0, cover, 1.0)) @ mm  # rows sum to 1
    return w, cover, carrier


def share_owners(se: np.ndarray, nodes: np.ndarray, tests: np.ndarray) -> np.ndarray:
    """(S, 2) the slave node whose row takes the test function of each end of the slave
    edges se (S, 2), given tests (q,) over the slave nodes `nodes` (sorted): which keep
    their own test function (a multiplier, or a node out of reach over the master).

    An edge with a test end gives both ends' functions to their own nodes (a one-test
    edge tests that node with 1, `covered_tests`). An edge with none (both nodes without
    a row facing the master or beyond its free end: a node inside a master end whose
    outer edge is longer than its inner one) gives end i's function (N_i there) to the
    first test node met walking the slave curve out through end i, or through the other
    end when that side has none: its covered pieces count for the nearest rows, so the
    lengths add up to the covered length (before, the piece and the node's share were
    lost: 0.105 of 1.0 for a slave whose node 0.055 inside a master end had edges of 0.3
    beyond and 0.1 over it). A chain with no test node at all keeps the edges' own ends
    (no row takes them)."""
    t_end = tests[np.searchsorted(nodes, se)]  # (S, 2)
    owner = se.copy()
    none = np.flatnonzero(~t_end.any(axis=1))
    if none.size == 0:
        return owner
    order = np.argsort(se.ravel(), kind="stable")  # slave node -> its (one or two) edges
    by_node = se.ravel()[order]

    def other_edge(edge: np.ndarray, node: np.ndarray) -> np.ndarray:
        """The edge at node other than edge (-1 at a curve end), both (m,)."""
        lo = np.searchsorted(by_node, node)
        hi = np.searchsorted(by_node, node, side="right")
        a, b = order[lo] // 2, order[hi - 1] // 2
        return np.where(hi - lo < 2, -1, np.where(a == edge, b, a))

    found = np.full((none.size, 2), -1, dtype=np.int64)
    for i in (0, 1):
        edge, node = none.copy(), se[none, i]
        live = np.ones(none.size, dtype=bool)
        for _ in range(se.shape[0]):
            nxt = np.where(live, other_edge(edge, node), -1)
            live &= nxt >= 0
            if not live.any():
                break
            far = np.where(se[np.maximum(nxt, 0), 0] == node, se[np.maximum(nxt, 0), 1],
                           se[np.maximum(nxt, 0), 0])
            hit = live & t_end[np.maximum(nxt, 0)].any(axis=1)
            found[hit, i] = np.where(t_end[nxt[hit], 0], se[nxt[hit], 0], se[nxt[hit], 1])
            live &= ~hit
            edge, node = np.where(live, nxt, edge), np.where(live, far, node)
    found = np.where(found >= 0, found, found[:, ::-1])
    owner[none] = np.where(found >= 0, found, se[none])
    return owner


def _covered_shares(nodes: np.ndarray, ends: np.ndarray, s: np.ndarray,
                    wq: np.ndarray) -> np.ndarray:
    """(q,) int_cov N_j ds (length) of the slave nodes `nodes` (sorted) over the overlap
    pieces with slave-segment ends `ends` (p, 2), Gauss points s (p, g), weights wq."""
    share = np.einsum("jpg,pg->pj", np.stack([1 - s, s]), wq)
    return np.bincount(np.searchsorted(nodes, ends).ravel(), weights=share.ravel(),
                       minlength=nodes.size)


def ls_max(xs1: np.ndarray, xs2: np.ndarray) -> float:
    """The longest of the segments xs1 -> xs2 ((k, 2) each; length)."""
    return float(np.linalg.norm(xs2 - xs1, axis=1).max(initial=0.0))


def _end_overlap_refused(geo: SlaveGeometry, sd: float) -> np.ndarray:
    """(q,) bool: the found slave nodes beyond a free master end (`SlaveGeometry.beyond`)
    below the master continued by more than geo.tol (nodal gap) whose slave edges do not
    overlap the master at the line through its end, or face it there over less than
    MIN_COVER of their support: node-to-segment's rule (`end_overlaps`), so such a node
    has no row in either discretisation (its share goes to its neighbour). A slave corner
    0.02 beside a block corner and 0.002 below its top's line, its edge touching the
    corner or clearing it, was refused as a penetration of 0.002 (with `interference`:
    its row pushed it out by 0.002) where node-to-segment had no pair."""
    m_edges, pts = geo.m_edges, geo.pts
    seg_len, m_degree = _master_measures(pts, m_edges)
    over = geo.beyond & (geo.g_node < -geo.tol)
    ok = end_overlaps(pts, geo.s_edges, geo.nodes, m_edges, seg_len, m_degree, sd,
                      geo.g_node, geo.tol, geo.beyond)
    return over & ~ok


def _beyond_master_end(geo: SlaveGeometry, reach: float) -> np.ndarray:
    """(q,) bool: the slave nodes whose closest master segment (within reach) they project
    at or beyond a free end of the master curve (within XI_EPS of the end segment, or past
    it). At the end too: a node there (or past it by less than XI_EPS) with less than half
    its support over the master has no row, and kept its own test function: its covered
    share counted for no node (0.05 of 1.0 for a node at the end between slave edges of
    0.3 beyond and 0.1 over the master; 37% off p for a slave straddling two masters whose
    joint lay 1e-6 of an edge before a slave node)."""
    m_edges = geo.m_edges
    seg_len, m_degree = _master_measures(geo.pts, m_edges)
    out, _, _ = _beyond_free_end(geo.pts[geo.nodes], (), geo.pts, m_edges, seg_len,
                                 m_degree, reach, eps=-XI_EPS)
    beyond = np.zeros(geo.nodes.size, dtype=bool)
    beyond[out] = True
    return beyond


def _nodal_gap(x: np.ndarray, xa: np.ndarray, xb: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """Signed distance (q,) of the points x (q, 2) to the lines xa -> xb (q, 2) at their
    closest points xa + xi (xb - xa): open > 0 (master body on the left of xa -> xb)."""
    d = xb - xa
    return _cross((x - xa) - xi[:, None] * d, d) / np.linalg.norm(d, axis=1)


def _padded_rows(w: sp.csr_matrix, pairs: ContactPairs):
    """(cols, g_normal, g_tangent), (m, 2 + 2 k): slave DOFs, then -w_jl at master DOFs."""
    m = pairs.n_pairs
    counts = np.diff(w.indptr)
    k = int(counts.max(initial=0))
    row = np.repeat(np.arange(m), counts)
    pos = np.arange(w.indices.size) - w.indptr[row]
    node = np.zeros((m, 1 + k), dtype=np.int64)
    wt = np.zeros((m, 1 + k))
    node[:, 0], wt[:, 0] = pairs.slave, 1.0
    node[row, 1 + pos], wt[row, 1 + pos] = w.indices, -w.data
    cols = (2 * node[:, :, None] + np.arange(2)).reshape(m, -1)
    g_n = (wt[:, :, None] * pairs.normal[:, None, :]).reshape(m, -1)
    g_t = (wt[:, :, None] * pairs.tangent[:, None, :]).reshape(m, -1)
    return cols, g_n, g_t
