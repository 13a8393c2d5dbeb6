"""Contact kinematics: node-to-segment point-pairs between a slave and a master curve.

Every node of the slave curve is paired with the closest segment (edge) of the master
curve (METHOD.md section 2). The search is vectorised: a `cKDTree` over the master segment
midpoints gives the candidate segments of all slave nodes at once, and the projection onto
the candidates is done with numpy array operations (no Python loop over nodes or segments).

Sign conventions (used by every later stage):

- normal n: unit outward normal of the master body at the segment, i.e. pointing away from
  the interior of the master element that owns the edge, towards the slave side.
- tangent t: unit vector along A -> B. The master segment is ordered (A, B) as in the
  counter-clockwise connectivity of its owning element, so the master body lies on the
  left when walking A -> B and n = (t_y, -t_x) (t turned by -90 degrees); equivalently
  t = (-n_y, n_x) (n turned by +90 degrees) and (n, t) is a right-handed frame. Example: a
  master block below the interface has n = (0, +1) and t = (-1, 0).
- gap: g0 = n . (x_s - x_p) >= 0 when open; negative = penetration.
- relative displacement d = u_s - (1 - xi) u_A - xi u_B (slave minus master point).
  Normal opening g_n = n . d (positive = separation). Tangential slip g_t = t . d
  (positive = the slave moves relative to the master in the A -> B direction).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from app.errors import InputError
from app.mesh.model import Mesh, orient_boundary_edges

XI_EPS = 1e-6
"""Tolerance on the unclipped xi beyond a free end of the master curve (dimensionless)."""

END_MIN_COVER = 0.5
"""A slave node beyond a free master end that overlaps the end segment's line keeps a pair
with that segment (xi clamped to the end) when it faces the master over at least this
share of its support (int_cov N_j ds >= END_MIN_COVER x D_j, N_j its linear shape
function, D_j its tributary length): the rule by which mortar's rows keep such a node
(`MIN_COVER` in app/contact/mortar.py)."""

PENETRATION_REL_TOL = 1e-6
"""Default penetration_tol = this x the mean master segment length (plus round-off floor)."""

_K0 = 8  # first number of nearest midpoints queried per slave node


@dataclass
class ContactPairs:
    """Node-to-segment contact pairs (m pairs), in the mesh's length unit.

    interface: (m,) int, index of the interface each pair belongs to.
    slave: (m,) int slave node.
    master: (m, 2) int master segment nodes (A, B), master body on the left of A -> B.
    xi: (m,) float in [0, 1]; projection x_p = (1 - xi) x_A + xi x_B.
    normal: (m, 2) unit outward normal of the master body, pointing towards the slave.
    tangent: (m, 2) unit tangent along A -> B; n = (t_y, -t_x).
    g0: (m,) initial gap n . (x_s - x_p), positive = open (length).
    position: (m, 2) slave node coordinates (length).
    length: (m,) slave node tributary length: half the summed length of the slave-curve
        edges at that node (length); traction x length = force per pair.
    """

    interface: np.ndarray
    slave: np.ndarray
    master: np.ndarray
    xi: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray
    g0: np.ndarray
    position: np.ndarray
    length: np.ndarray

    @property
    def n_pairs(self) -> int:
        """Number of pairs m."""
        return int(self.slave.shape[0])

    def __len__(self) -> int:
        return self.n_pairs

    @classmethod
    def empty(cls) -> ContactPairs:
        """A set of zero pairs with the right shapes and dtypes."""
        i1 = np.zeros(0, dtype=np.int64)
        f1 = np.zeros(0)
        f2 = np.zeros((0, 2))
        return cls(i1, i1.copy(), np.zeros((0, 2), dtype=np.int64), f1, f2, f2.copy(),
                   f1.copy(), f2.copy(), f1.copy())

    @classmethod
    def concatenate(cls, pairs: Sequence[ContactPairs]) -> ContactPairs:
        """Stack several pair sets (e.g. one per interface) in the given order."""
        pairs = list(pairs)
        if not pairs:
            return cls.empty()
        return cls(**{f.name: np.concatenate([getattr(p, f.name) for p in pairs], axis=0)
                      for f in fields(cls)})

    def select(self, mask: np.ndarray) -> ContactPairs:
        """Subset of the pairs: `mask` is an (m,) bool mask or an array of pair indices."""
        mask = np.asarray(mask)
        if mask.dtype == bool and mask.shape != (self.n_pairs,):
            raise ValueError(f"select: bool mask of shape {mask.shape}, expected "
                             f"({self.n_pairs},)")
        return ContactPairs(**{f.name: getattr(self, f.name)[mask] for f in fields(self)})


def _curve_edges(mesh: Mesh, name: str, role: str, label: str) -> np.ndarray:
    """Validated (k, 2) int64 edges of a named curve, duplicates removed."""
    if name not in mesh.curves:
        avail = ", ".join(repr(c) for c in sorted(mesh.curves)) or "none"
        raise InputError(f"interface '{label}': {role} curve '{name}' is not in the mesh "
                         f"(available curves: {avail})")
    e = np.asarray(mesh.curves[name])
    if e.ndim != 2 or e.shape[1] != 2 or e.shape[0] == 0:
        raise InputError(f"interface '{label}': {role} curve '{name}' must be a non-empty "
                         f"(n_edges, 2) array of node pairs, got shape {e.shape}")
    e = e.astype(np.int64)
    if e.min() < 0 or e.max() >= mesh.n_nodes:
        raise InputError(f"interface '{label}': {role} curve '{name}' refers to nodes outside "
                         f"0..{mesh.n_nodes - 1}")
    if np.any(e[:, 0] == e[:, 1]):
        raise InputError(f"interface '{label}': {role} curve '{name}' has an edge with the "
                         f"same node at both ends")
    _, first = np.unique(np.sort(e, axis=1), axis=0, return_index=True)
    return e[np.sort(first)]


def tributary_length(points: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nodes of a curve and their tributary lengths.

    points: (n, 2) coordinates; edges: (k, 2) node pairs.
    Returns (nodes (q,) sorted unique, length (q,)): half the summed length of the edges at
    each node, so that length.sum() is the curve length.
    """
    edges = np.asarray(edges, dtype=np.int64)
    le = np.linalg.norm(points[edges[:, 1]] - points[edges[:, 0]], axis=1)
    nodes, inv = np.unique(edges.ravel(), return_inverse=True)
    length = np.bincount(inv.ravel(), weights=np.repeat(0.5 * le, 2), minlength=nodes.size)
    return nodes, length


def _pick(dd: np.ndarray, exc: np.ndarray, idx: np.ndarray, tie_abs: float) -> np.ndarray:
    """(q,) column of the best candidate per row of (q, k) distances dd, excursions exc and
    segment indices idx: the smallest distance; ties: smallest excursion, lowest index."""
    tie = dd <= dd.min(axis=1)[:, None] * (1 + 1e-9) + tie_abs
    ex = np.where(tie, exc, np.inf)
    tie &= ex <= ex.min(axis=1)[:, None] + 1e-12
    return np.argmin(np.where(tie, idx, np.iinfo(np.int64).max), axis=1)


def closest_segments(x: np.ndarray, xa: np.ndarray, xb: np.ndarray,
                     search_distance: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closest segment to each point, among segments closer than `search_distance`.

    x: (p, 2) points; xa, xb: (s, 2) segment ends (non-degenerate).
    Returns seg (p,) int (-1 if no segment lies within search_distance), xi_raw (p,)
    unclipped projection parameter on that segment, dist (p,) distance from the point to
    the clipped projection (inf if none). Ties in distance: the smallest excursion of the
    unclipped xi outside [0, 1], then the lowest segment index.

    Segments are grouped in length classes (lengths within a factor 2) with one cKDTree of
    midpoints per class; a segment of half length <= H can only be closer than D if its
    midpoint is within D + H, so each class is queried (k nearest, k doubled while needed)
    with that radius. Vectorised over points; the loops run over classes and k-doublings.
    """
    x = np.asarray(x, dtype=float)
    sd = float(search_distance)
    p = x.shape[0]
    ab = xb - xa
    len2 = np.einsum("ij,ij->i", ab, ab)
    lens = np.sqrt(len2)
    mid = 0.5 * (xa + xb)
    tie_abs = 1e-12 * float(lens.mean())
    cls = np.floor(np.log2(lens / lens.min())).astype(np.int64)

    seg = np.full(p, -1, dtype=np.int64)
    xi_raw = np.full(p, np.nan)
    dist = np.full(p, np.inf)
    exc_best = np.full(p, np.inf)
    for c in np.unique(cls):
        ids = np.flatnonzero(cls == c)
        half = 0.5 * float(lens[ids].max())
        _search_class(x, xa, ab, len2, mid, ids, half, sd, tie_abs,
                      (seg, xi_raw, dist, exc_best))
    far = ~(dist <= sd)
    seg[far], xi_raw[far], dist[far] = -1, np.nan, np.inf
    return seg, xi_raw, dist


def _search_class(x: np.ndarray, xa: np.ndarray, ab: np.ndarray, len2: np.ndarray,
                  mid: np.ndarray, ids: np.ndarray, half: float, sd: float, tie_abs: float,
                  best: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]) -> None:
    """Improve the best segment of every point with the segments `ids` of one length class.

    x: (p, 2) points; xa, ab, len2, mid: (s, 2), (s, 2), (s,), (s, 2) segment starts,
    A -> B vectors, squared lengths and midpoints; half: the class's largest half length.
    best: (seg, xi_raw, dist, exc) (p,) arrays, updated in place (see `_pick`). The k
    nearest midpoints within (sd + half) are queried, k doubled for the points whose
    k-th midpoint still lies inside the radius that could hold a closer segment.
    """
    seg, xi_raw, dist, exc_best = best
    ns, nc = xa.shape[0], ids.size
    tree = cKDTree(mid[ids])
    ub = (sd + half) * (1 + 1e-9) + tie_abs
    todo = np.arange(x.shape[0])
    k = min(_K0, nc)
    while todo.size:
        dm, im = tree.query(x[todo], k=k, distance_upper_bound=ub)
        dm, im = dm.reshape(todo.size, k), im.reshape(todo.size, k)
        valid = im < nc
        ic = ids[np.where(valid, im, 0)]  # (q, k) candidate segments
        xr, dd, exc = _candidate_distances(x[todo], xa, ab, len2, ic, valid)
        # column 0: the best so far (from earlier classes or rounds)
        dd = np.column_stack([dist[todo], dd])
        xr = np.column_stack([xi_raw[todo], xr])
        exc = np.column_stack([exc_best[todo], exc])
        ic = np.column_stack([seg[todo], ic])
        j = _pick(dd, exc, np.where(ic < 0, ns, ic), tie_abs)
        rows = np.arange(todo.size)
        dist[todo], xi_raw[todo] = dd[rows, j], xr[rows, j]
        exc_best[todo], seg[todo] = exc[rows, j], ic[rows, j]
        # all k midpoints inside the radius: there may be more candidates, query again
        radius = np.minimum(dist[todo], sd) * (1 + 1e-9) + half + tie_abs
        more = valid[:, -1] & (dm[:, -1] <= radius) & (k < nc)
        todo = todo[more]
        k = min(2 * k, nc)


def _candidate_distances(x: np.ndarray, xa: np.ndarray, ab: np.ndarray, len2: np.ndarray,
                         ic: np.ndarray,
                         valid: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Projections of the points x (q, 2) onto their candidate segments ic (q, k).

    Returns xr (q, k) the unclipped parameter, dd (q, k) the distance to the clipped
    projection (inf where not `valid`), exc (q, k) the excursion of xr outside [0, 1].
    """
    rel = x[:, None, :] - xa[ic]
    xr = np.einsum("qkj,qkj->qk", rel, ab[ic]) / len2[ic]
    diff = rel - np.clip(xr, 0.0, 1.0)[..., None] * ab[ic]
    dd = np.where(valid, np.hypot(diff[..., 0], diff[..., 1]), np.inf)
    exc = np.maximum(np.maximum(-xr, xr - 1.0), 0.0)
    return xr, dd, exc


def _checked_search_distance(label: str, slave: str, master: str, search_distance) -> float:
    """search_distance as a positive float; InputError if not, or if slave == master."""
    if slave == master:
        raise InputError(f"interface '{label}': slave and master are the same curve "
                         f"'{slave}'; use two different curves")
    sd = float(search_distance)
    if not np.isfinite(sd) or sd <= 0:
        raise InputError(f"interface '{label}': search_distance must be a positive length, "
                         f"got {search_distance}")
    return sd


def penetration_tolerance(label: str, pts: np.ndarray, seg_len: np.ndarray,
                           penetration_tol: float | None) -> float:
    """The given tolerance (checked >= 0) or PENETRATION_REL_TOL x mean master segment."""
    if penetration_tol is None:
        scale = float(np.ptp(pts, axis=0).max()) if pts.size else 0.0
        return max(PENETRATION_REL_TOL * float(seg_len.mean()), 1e-12 * scale)
    tol = float(penetration_tol)
    if not np.isfinite(tol) or tol < 0:
        raise InputError(f"interface '{label}': penetration_tol must be a non-negative "
                         f"length, got {penetration_tol}")
    return tol


def refuse_penetration(label: str, xs: np.ndarray, g0: np.ndarray, pen: np.ndarray,
                        tol: float) -> None:
    """InputError naming the first penetrating slave nodes (pen: (m,) bool), if any."""
    if not pen.any():
        return
    ip = np.flatnonzero(pen)
    locs = "; ".join(f"x={xs[i, 0]:.6g}, y={xs[i, 1]:.6g}" for i in ip[:3])
    raise InputError(f"interface '{label}': {ip.size} slave nodes penetrate the master by "
                     f"more than {tol:.3g} (first at {locs}; deepest g0={g0[ip].min():.3g})"
                     f": fix the geometry, raise penetration_tol, or set interference = true "
                     f"if the overlap is an intended interference fit")


def contact_pairs(mesh: Mesh, slave: str, master: str, search_distance: float, *,
                  interface: int = 0, penetration_tol: float | None = None,
                  name: str | None = None, interference: bool = False) -> ContactPairs:
    """Node-to-segment pairs of one interface: every slave-curve node with its closest
    master-curve segment.

    mesh: the scene; slave, master: names of boundary curves in mesh.curves (may be on
    the same body if they are different curves; slave nodes that are also master-curve
    nodes are skipped). search_distance (length, > 0): pairs whose slave node is farther
    than this from its projection, or whose gap g0 exceeds it, are dropped. A slave node
    that projects beyond a free end of the master curve (a node used by one master edge)
    by more than XI_EPS in xi is dropped too, unless it overlaps the end segment's line
    by more than penetration_tol and faces the master over at least END_MIN_COVER of its
    support (`end_overlaps`, mortar's rule): then it is paired with the end segment, xi
    clamped to the end, g0 its depth below the master continued beyond that end (the
    end segment's line, or on a curved master its circle, `continued_end_gaps`; a tilted
    interference fit's slave
    corner 4e-5 past the master's end had no pair and its overlap of 0.002 was ignored).
    interface: index stored in the pairs.
    penetration_tol (length): a kept pair with g0 < -penetration_tol is an initial
    penetration and raises InputError; default PENETRATION_REL_TOL x the mean master
    segment length (at least 1e-12 x the scene size, for round-off). Gaps in
    [-penetration_tol, 0) are kept as computed. interference: initial penetrations are an
    intended interference fit, kept with their negative g0 (the contact law pushes the
    bodies apart by -g0) instead of raising. name: interface name for messages
    (default 'slave/master').

    Note: a slave node behind a thin master body (closer than search_distance to its far
    side) would show as a penetration; keep search_distance below the body thicknesses.
    See the module docstring for the sign conventions.
    """
    label = name if name is not None else f"{slave}/{master}"
    sd = _checked_search_distance(label, slave, master, search_distance)
    s_edges = _curve_edges(mesh, slave, "slave", label)
    m_edges = _curve_edges(mesh, master, "master", label)
    pts = np.asarray(mesh.points, dtype=float)
    m_edges, seg_len, tol = master_segments(mesh, pts, m_edges, label, master,
                                             penetration_tol)

    nodes, _ = tributary_length(pts, s_edges)
    m_degree = np.bincount(m_edges.ravel(), minlength=mesh.n_nodes)
    keep_s = m_degree[nodes] == 0
    xs = pts[nodes[keep_s]]

    keep, sg, xi, t, nrm, g0, beyond = _project_slaves(xs, pts, m_edges, seg_len,
                                                       m_degree, sd)
    at_end = end_overlaps(pts, s_edges, nodes[keep_s], m_edges, seg_len, m_degree, sd,
                          g0, tol, beyond)
    keep |= at_end
    trib = covered_tributary(pts, s_edges, m_edges, seg_len, m_degree, sd,
                             kept=nodes[keep_s][at_end])[keep_s]
    nodes = nodes[keep_s]
    if not keep.any():
        raise no_slave_error(label, slave, master, sd)
    if not interference:
        refuse_penetration(label, xs, g0, keep & (g0 < -tol), tol)
    k = np.flatnonzero(keep)
    return ContactPairs(interface=np.full(k.size, int(interface), dtype=np.int64),
                        slave=nodes[k].astype(np.int64), master=m_edges[sg[k]].copy(),
                        xi=xi[k], normal=nrm[k], tangent=t[k], g0=g0[k],
                        position=xs[k].copy(), length=trib[k])


def covered_tributary(pts: np.ndarray, s_edges: np.ndarray, m_edges: np.ndarray,
                      seg_len: np.ndarray, m_degree: np.ndarray, sd: float,
                      kept: np.ndarray | None = None) -> np.ndarray:
    """Tributary lengths of the slave-curve nodes (in `tributary_length`'s order, length)
    counting only what faces the master: a half edge (node to edge midpoint) whose midpoint
    projects beyond a free master end (a node of one master edge) by more than XI_EPS
    counts up to the line through that end normal to the end segment (none of it if the
    node is beyond too); an edge whose other node projects beyond a free end (that node is
    dropped) counts from the node up to that line, past the midpoint if the line is (else
    the part between them faced the master and counted for no node: a slave overhanging
    by less than half an edge, or one slave on two masters that meet inside an edge, read
    lengths 10% short). Elsewhere the whole half edge counts, bit for bit as
    `tributary_length`, so the lengths add up to the covered length of a slave that
    overhangs its master.

    pts (n, 2); s_edges (k, 2) slave edges; m_edges (j, 2) oriented master edges and
    seg_len (j,) their lengths; m_degree (n_nodes,) master edges per node; sd the
    search distance (length). kept (r,): nodes beyond a free end that keep a pair
    (`end_overlaps`): each counts its half edges from that end's line, and its edge
    partner only its own half edge.
    """
    s_edges = np.asarray(s_edges, dtype=np.int64)
    kept = np.zeros(0, dtype=np.int64) if kept is None else np.asarray(kept)
    xs = (pts[s_edges[:, 0]], pts[s_edges[:, 1]])
    mid = 0.5 * (xs[0] + xs[1])
    half = 0.5 * np.linalg.norm(xs[1] - xs[0], axis=1)
    frac = np.ones((s_edges.shape[0], 2))
    ends = (pts, m_edges, seg_len, m_degree, sd + 2.0 * float(half.max()))
    out, s_mid, s_node = _beyond_free_end(mid, xs, *ends)
    for k in (0, 1):
        frac[out, k] = np.minimum(np.maximum(-s_node[k], 0.0) / (s_mid - s_node[k]), 1.0)
    for j in (0, 1):  # node j beyond: node 1 - j's share reaches the end line
        out, s_j, (s_k,) = _beyond_free_end(xs[j], (xs[1 - j],), *ends)
        own = np.isin(s_edges[out, j], kept)
        s_m = 0.5 * (s_j + s_k)
        frac[out[own], j] = np.clip(-s_m[own] / (s_j[own] - s_m[own]), 0.0, 1.0)
        out, s_j, s_k = out[~own], s_j[~own], s_k[~own]
        frac[out, 1 - j] = 2.0 * np.clip(-s_k / (s_j - s_k), 0.0, 1.0)
    nodes, inv = np.unique(s_edges.ravel(), return_inverse=True)
    return np.bincount(inv.ravel(), weights=(half[:, None] * frac).ravel(),
                       minlength=nodes.size)


def end_overlaps(pts: np.ndarray, s_edges: np.ndarray, nodes: np.ndarray,
                 m_edges: np.ndarray, seg_len: np.ndarray, m_degree: np.ndarray, sd: float,
                 g0: np.ndarray, tol: float, candidates: np.ndarray) -> np.ndarray:
    """(q,) bool: the slave nodes `nodes` (q,) among `candidates` (q,) bool (beyond a
    free master end by more than XI_EPS, within sd: `_project_slaves`) that overlap the
    end segment's line (g0 (q,) < -tol, lengths) and face the master over at least
    END_MIN_COVER of their support: int_cov N_j ds over their slave edges s_edges (k, 2),
    the covered part being on the master's side of the line through the end normal to
    the end segment, against D_j (only the candidates' edges are searched; an edge counts
    only if its gap at that line, interpolated along it, is below -tol: a corner beside a
    block whose edge clears the block's corner has nothing to push out). Such a node
    is paired with the end segment (`contact_pairs`); with less cover, mortar hands its
    share to a neighbour and node-to-segment extends the neighbour's tributary length to
    the end line."""
    ok = np.zeros(nodes.size, dtype=bool)
    s_edges = np.asarray(s_edges, dtype=np.int64)
    s_edges = s_edges[np.isin(s_edges, nodes[candidates & (g0 < -tol)]).any(axis=1)]
    if s_edges.shape[0] == 0:
        return ok
    xs = (pts[s_edges[:, 0]], pts[s_edges[:, 1]])
    h = np.linalg.norm(xs[1] - xs[0], axis=1)
    reach = sd + float(h.max(initial=0.0))
    cover = np.zeros(pts.shape[0])
    beyond = np.zeros(pts.shape[0], dtype=bool)
    for j in (0, 1):
        out, s_j, (s_k,) = _beyond_free_end(xs[j], (xs[1 - j],), pts, m_edges, seg_len,
                                            m_degree, reach)
        t0 = np.where(s_k < 0, s_j / np.where(s_k < 0, s_j - s_k, 1.0), 1.0)
        g_j, g_k = _end_line_gaps(xs[j], xs[1 - j], out, pts, m_edges, seg_len, reach)
        out = out[g_j + t0 * (g_k - g_j) < -tol]  # the edge overlaps at the end's line
        t0 = t0[g_j + t0 * (g_k - g_j) < -tol]
        np.add.at(cover, s_edges[out, j], 0.5 * h[out] * (1.0 - t0) ** 2)
        beyond[s_edges[out, j]] = True
    d_len = np.bincount(s_edges.ravel(), weights=np.repeat(0.5 * h, 2),
                        minlength=pts.shape[0])
    ok = beyond & (cover >= END_MIN_COVER * (1.0 - 1e-12) * d_len)
    return ok[nodes] & candidates & (g0 < -tol)


def _end_line_gaps(probe: np.ndarray, other: np.ndarray, out: np.ndarray, pts: np.ndarray,
                   m_edges: np.ndarray, seg_len: np.ndarray, reach: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Signed distances (o,) of probe[out] and other[out] (points (k, 2)) to the line of
    the closest master segment of probe[out] (within reach; oriented master edges, body on
    the left: positive outside, length), for the probes `_beyond_free_end` found."""
    seg, _, _ = closest_segments(probe[out], pts[m_edges[:, 0]], pts[m_edges[:, 1]], reach)
    xa, xb = pts[m_edges[seg, 0]], pts[m_edges[seg, 1]]
    t = (xb - xa) / seg_len[seg, None]
    nrm = np.column_stack([t[:, 1], -t[:, 0]])
    return (np.einsum("ij,ij->i", nrm, probe[out] - xa),
            np.einsum("ij,ij->i", nrm, other[out] - xa))


def _beyond_free_end(probe: np.ndarray, others: tuple[np.ndarray, ...], pts: np.ndarray,
                     m_edges: np.ndarray, seg_len: np.ndarray, m_degree: np.ndarray,
                     reach: float, eps: float = XI_EPS
                     ) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """The points of probe (k, 2) whose closest master segment (within reach) they project
    beyond a free end of by more than eps (segment parameter; -XI_EPS: at the end or
    beyond it): their indices out (o,), their distances s (o,) past that end along the end
    segment's outward tangent, and those of the matching points of each array in others
    ((k, 2) each) as a list of (o,) (length)."""
    seg, xr, _ = closest_segments(probe, pts[m_edges[:, 0]], pts[m_edges[:, 1]], reach)
    sg = np.where(seg >= 0, seg, 0)
    a_end = (seg >= 0) & (xr < -eps) & (m_degree[m_edges[sg, 0]] == 1)
    b_end = (seg >= 0) & (xr > 1 + eps) & (m_degree[m_edges[sg, 1]] == 1)
    out = np.flatnonzero(a_end | b_end)
    end = np.where(a_end[out], m_edges[sg[out], 0], m_edges[sg[out], 1])
    other = np.where(a_end[out], m_edges[sg[out], 1], m_edges[sg[out], 0])
    t_out = (pts[end] - pts[other]) / seg_len[sg[out], None]  # (o, 2) outwards
    def past(x: np.ndarray) -> np.ndarray:
        return np.einsum("ij,ij->i", x[out] - pts[end], t_out)

    return out, past(probe), [past(x) for x in others]


def no_slave_error(label: str, slave: str, master: str, sd: float) -> InputError:
    """The InputError of an interface with no slave node within sd of its master."""
    return InputError(f"interface '{label}': no slave node of '{slave}' lies within "
                      f"search_distance={sd:g} of '{master}' (raise search_distance or "
                      "check the curves)")


def master_segments(mesh: Mesh, pts: np.ndarray, m_edges: np.ndarray, label: str,
                     master: str,
                     penetration_tol: float | None) -> tuple[np.ndarray, np.ndarray, float]:
    """Master edges oriented with the master body on the left (k, 2), their lengths (k,)
    and the penetration tolerance (length); InputError for a zero-length edge."""
    m_edges = orient_boundary_edges(mesh, m_edges,
                                    f"interface '{label}': master curve '{master}'")
    xa, xb = pts[m_edges[:, 0]], pts[m_edges[:, 1]]
    seg_len = np.linalg.norm(xb - xa, axis=1)
    tol = penetration_tolerance(label, pts, seg_len, penetration_tol)
    if np.any(seg_len == 0):
        raise InputError(f"interface '{label}': master curve '{master}' has an edge of zero "
                         f"length (coincident nodes)")
    return m_edges, seg_len, tol


def _project_slaves(xs: np.ndarray, pts: np.ndarray, m_edges: np.ndarray,
                    seg_len: np.ndarray, m_degree: np.ndarray,
                    sd: float) -> tuple[np.ndarray, ...]:
    """Closest master segment of every slave point xs (q, 2) and the pair geometry there.

    m_edges (k, 2) oriented master edges, seg_len (k,) their lengths, m_degree (n_nodes,)
    master edges per node. Returns keep (q,) bool (a segment within sd, not beyond a free
    master end by more than XI_EPS, g0 <= sd), sg (q,) segment (0 if none), xi (q,) in
    [0, 1], tangent t (q, 2), normal (q, 2), gap g0 (q,) (module sign conventions; beyond
    a free end: below the master continued, `continued_end_gaps`) and beyond (q,) bool (within sd
    as keep, but beyond a free end).
    """
    xa, xb = pts[m_edges[:, 0]], pts[m_edges[:, 1]]
    seg, xr, dist = closest_segments(xs, xa, xb, sd)
    found = seg >= 0
    sg = np.where(found, seg, 0)
    a_free = m_degree[m_edges[sg, 0]] == 1
    b_free = m_degree[m_edges[sg, 1]] == 1
    beyond = ((xr < -XI_EPS) & a_free) | ((xr > 1 + XI_EPS) & b_free)
    xi = np.clip(np.nan_to_num(xr), 0.0, 1.0)

    t = (xb - xa) / seg_len[:, None]
    t = t[sg]
    nrm = np.column_stack([t[:, 1], -t[:, 0]])
    # from coordinate differences (xs - xp with xp = (1 - xi) xa + xi xb carried the
    # round-off of |x|, not of the gap)
    g0 = np.einsum("ij,ij->i", nrm, (xs - xa[sg]) - xi[:, None] * (xb - xa)[sg])
    g0, _ = continued_end_gaps(xs, sg, np.where(found, xr, 0.5), g0, pts, m_edges,
                               seg_len, m_degree)
    near = found & (dist <= sd) & (g0 <= sd)
    return near & ~beyond, sg, xi, t, nrm, g0, near & beyond


END_CURVE_TURN = np.pi / 6
"""Largest turn (rad) between a free master end segment and its neighbour for which the
master counts as a curve continued beyond its end along the circle through their three
nodes (`continued_end_gaps`); a sharper turn is a corner, continued along the end
segment's line."""


def continued_end_gaps(x: np.ndarray, sg: np.ndarray, xr: np.ndarray, g_line: np.ndarray,
                       pts: np.ndarray, m_edges: np.ndarray, seg_len: np.ndarray,
                       m_degree: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(q,) gaps of the points x (q, 2) to their master segments sg (q,) (unclipped
    parameters xr (q,)), g_line (q,) their distances to those segments' lines at the
    clipped point (length, open > 0), with the points beyond a free master end by more
    than XI_EPS measured against the master's boundary continued beyond that end: the
    circle through the end segment's nodes and the node before them (signed distance to
    it, open > 0), the end segment's line where the master is straight there, has one
    segment, or turns there by more than END_CURVE_TURN. On a curved master the line
    reads a node on the continued curve a (a + h) / (2 R) inside (outside on a concave
    master): a hole's arc longer than its pin's by 0.05 of an edge of 0.1 was refused as
    a penetration of 2.6e-4 where it touched. Also returns those points' mask (q,)."""
    g = np.array(g_line, dtype=float)
    a_end = (xr < -XI_EPS) & (m_degree[m_edges[sg, 0]] == 1)
    b_end = (xr > 1 + XI_EPS) & (m_degree[m_edges[sg, 1]] == 1)
    out = np.flatnonzero(a_end | b_end)
    if out.size == 0:
        return g, a_end | b_end
    s_out = sg[out]
    end = np.where(a_end[out], m_edges[s_out, 0], m_edges[s_out, 1])
    oth = np.where(a_end[out], m_edges[s_out, 1], m_edges[s_out, 0])
    h = seg_len[s_out]
    t = (pts[end] - pts[oth]) / h[:, None]  # outwards along the end segment
    tab = (pts[m_edges[s_out, 1]] - pts[m_edges[s_out, 0]]) / h[:, None]
    n = np.column_stack([tab[:, 1], -tab[:, 0]])  # outward normal of the master body
    prev = _far_node(m_edges, s_out, oth)
    pp = pts[np.maximum(prev, 0)] - pts[oth]  # (o, 2) towards the node before
    lp = np.linalg.norm(pp, axis=1)
    lpe = np.linalg.norm(pts[np.maximum(prev, 0)] - pts[end], axis=1)
    turn = np.arctan2(-np.einsum("ij,ij->i", n, pp), -np.einsum("ij,ij->i", t, pp))
    smooth = (prev >= 0) & (np.abs(turn) <= END_CURVE_TURN)
    kappa = np.where(smooth, -2.0 * np.einsum("ij,ij->i", n, pp)
                     / np.where(smooth, lp * lpe, 1.0), 0.0)  # > 0: convex
    sb = np.clip(0.5 * kappa * h, -1.0, 1.0)
    cb = np.sqrt(1.0 - sb * sb)
    t_e = cb[:, None] * t - sb[:, None] * n  # the circle's tangent and normal at the end
    n_e = cb[:, None] * n + sb[:, None] * t
    rel = x[out] - pts[end]
    s = np.einsum("ij,ij->i", t_e, rel)
    d = np.einsum("ij,ij->i", n_e, rel)
    g[out] = (kappa * (s * s + d * d) + 2.0 * d) / (
        np.sqrt((kappa * s) ** 2 + (kappa * d + 1.0) ** 2) + 1.0)
    return g, a_end | b_end


def _far_node(m_edges: np.ndarray, seg: np.ndarray, node: np.ndarray) -> np.ndarray:
    """(o,) the far node of the master edge other than seg (o,) at node (o,), -1 where
    node has no other edge or more than one (a branch)."""
    e = np.flatnonzero(np.isin(m_edges, node).any(axis=1))
    hit = (m_edges[e][None, :, :] == node[:, None, None]).any(axis=2)  # (o, |e|)
    hit &= e[None, :] != seg[:, None]
    one = hit.sum(axis=1) == 1
    k = e[np.argmax(hit, axis=1)] if e.size else np.zeros(node.size, dtype=np.int64)
    far = np.where(m_edges[k, 0] == node, m_edges[k, 1], m_edges[k, 0])
    return np.where(one, far, -1)


def constraint_matrix(pairs: ContactPairs, n_nodes: int) -> sp.csr_matrix:
    """Contact constraint matrix G, shape (2m, 2 n_nodes), DOF numbering 2 node + component.

    Rows 0..m-1: normal rows, G_n . u = n . d; rows m..2m-1: tangential rows,
    G_t . u = t . d, with d = u_s - (1 - xi) u_A - xi u_B (slave minus master point), so
    G_n u > 0 is opening and G_t u > 0 is slip of the slave along A -> B.
    """
    m = pairs.n_pairs
    if m and (pairs.slave.max() >= n_nodes or pairs.master.max() >= n_nodes):
        raise InputError(f"constraint_matrix: pairs refer to nodes beyond n_nodes={n_nodes}")
    nodes = np.column_stack([pairs.slave, pairs.master[:, 0], pairs.master[:, 1]])  # (m, 3)
    w = np.column_stack([np.ones(m), -(1 - pairs.xi), -pairs.xi])  # (m, 3)
    cols = (2 * nodes[:, :, None] + np.arange(2)).reshape(m, 6)  # (m, 6): node x, y
    vals_n = (w[:, :, None] * pairs.normal[:, None, :]).reshape(m, 6)
    vals_t = (w[:, :, None] * pairs.tangent[:, None, :]).reshape(m, 6)
    rows = np.repeat(np.arange(2 * m), 6)
    g = sp.csr_matrix((np.concatenate([vals_n, vals_t]).ravel(),
                       (rows, np.concatenate([cols, cols]).ravel())),
                      shape=(2 * m, 2 * n_nodes))
    g.eliminate_zeros()
    return g
