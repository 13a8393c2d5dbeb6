"""Slave nodes outside the pairs that have moved through the master.

The pairs of an interface are chosen once, on the undeformed mesh: a slave node whose
initial gap exceeds search_distance (or that a discretisation drops for another reason)
is not constrained at all. When the bodies then move by more than search_distance
relative to each other, such a node can pass through the master, and the run would go on
with interpenetrating bodies and tractions that look plausible. This check finds those
nodes after a step: on the open side of the master at the start, behind it now (both
judged by the closest master segment, undeformed and deformed; a node beyond a free end
of the master curve is not judged). Only nodes within the largest displacement of the
two curves can have crossed, so the searches use that radius (cheap for the small
displacements the method is made for).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.contact.pairs import XI_EPS, _curve_edges, closest_segments
from app.mesh.model import Mesh, orient_boundary_edges

CROSS_REL_TOL = 1e-3
"""A node counts as crossed when it lies behind the deformed master by more than this
times the largest displacement of the two curves (deeper than round-off and the
linearised kinematics)."""


@dataclass
class Crossing:
    """Unpaired slave nodes of one interface that lie behind the deformed master: count,
    the deepest one's depth (length) and undeformed position (2,)."""

    count: int
    depth: float
    position: np.ndarray


def _signed_gap(x: np.ndarray, xa: np.ndarray, xb: np.ndarray, free: np.ndarray,
                radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed distance (q,) of points x (q, 2) to the closest of the oriented segments
    xa -> xb (s, 2) within radius (positive on the right, outside the master body), whether
    it is judged (q,) bool: a segment within radius, the point not beyond a free end
    (free (s, 2) bool: the segment's ends that end the master curve), and the distance
    (q,) to that segment (inf where none lies within radius)."""
    seg, xr, dist = closest_segments(x, xa, xb, radius)
    found = seg >= 0
    s = np.where(found, seg, 0)
    beyond = (((xr < -XI_EPS) & free[s, 0]) | ((xr > 1 + XI_EPS) & free[s, 1]))
    d = xb[s] - xa[s]
    xi = np.clip(np.nan_to_num(xr), 0.0, 1.0)[:, None]
    r = x - (xa[s] + xi * d)
    gap = (r[:, 0] * d[:, 1] - r[:, 1] * d[:, 0]) / np.linalg.norm(d, axis=1)
    return gap, found & ~beyond, dist


@dataclass(frozen=True)
class Watch:
    """The step-independent half of `nodes_behind`, built once per run: the undeformed
    points pts (n, 2), the watched nodes (k,), the oriented curve edges (s, 2) and their
    ends that end the curve (free (s, 2) bool), the nodes of the two curves (`sides`, the
    displacement scale), and each watched node's closest
    segment at any distance, undeformed: signed gap (k,), distance (k,) and whether it is
    judged (k,) bool. The closest segment within a radius is that one when its distance
    is within the radius (`closest_segments`), so a step needs no undeformed search."""

    pts: np.ndarray
    nodes: np.ndarray
    edges: np.ndarray
    free: np.ndarray
    sides: tuple[np.ndarray, np.ndarray]
    gap: np.ndarray
    dist: np.ndarray
    judged: np.ndarray


def watch(pts: np.ndarray, nodes: np.ndarray, edges: np.ndarray,
          sides: tuple[np.ndarray, np.ndarray]) -> Watch:
    """The Watch of `nodes` (k,) against the oriented curve `edges` (s, 2) on the
    undeformed points pts (n, 2); sides: the nodes of the two curves."""
    free = np.bincount(edges.ravel(), minlength=pts.shape[0])[edges] == 1
    a, b = edges[:, 0], edges[:, 1]
    gap, judged, dist = _signed_gap(pts[nodes], pts[a], pts[b], free, np.inf)
    return Watch(pts, nodes, edges, free, sides, gap, dist, judged)


def displacement_scale(w: Watch, u: np.ndarray, norm: bool) -> float:
    """The largest nodal displacement of the two curves, summed over them (norm False:
    the largest component of each) or the larger of the two (norm True: the lengths)."""
    if norm:
        return float(max(np.linalg.norm(u[side], axis=1).max() for side in w.sides))
    return float(sum(np.abs(u[side]).max() for side in w.sides))


def nodes_behind(w: Watch, u: np.ndarray, reach: float, start_min: float, depth_tol: float
                 ) -> tuple[int, float, int] | None:
    """Of the watched nodes, those whose undeformed signed gap to the curve exceeds
    start_min and that lie behind the deformed curve (pts + u, u (n, 2)) by more than
    depth_tol, both judged by the closest segment (within reach undeformed, 2 reach
    deformed; a node beyond a free end of the curve is not judged): (count, the deepest
    one's depth, its node id), or None when there is none."""
    near = w.judged & (w.dist <= reach) & (w.gap > start_min)
    if not near.any():
        return None
    nodes = w.nodes[near]
    x1 = w.pts + u
    a, b = w.edges[:, 0], w.edges[:, 1]
    g_now, ok_now, _ = _signed_gap(x1[nodes], x1[a], x1[b], w.free, 2.0 * reach)
    behind = ok_now & (g_now < -depth_tol)
    if not behind.any():
        return None
    deepest = int(np.argmin(np.where(behind, g_now, np.inf)))
    return int(behind.sum()), float(-g_now[deepest]), int(nodes[deepest])


def unpaired_watch(mesh: Mesh, slave: str, master: str, paired: np.ndarray,
                   label: str) -> Watch | None:
    """The Watch of the unpaired nodes of curve `slave` (paired (k,): the slave nodes with
    a pair; not the master's own nodes) against the master curve; None when there are
    none. InputError (naming `label`) for a curve that is not one."""
    pts = np.asarray(mesh.points, dtype=float)
    s_nodes = np.unique(_curve_edges(mesh, slave, "slave", label))
    m_edges = orient_boundary_edges(mesh, _curve_edges(mesh, master, "master", label),
                                    f"interface '{label}': master curve '{master}'")
    m_nodes = np.unique(m_edges)
    nodes = np.setdiff1d(np.setdiff1d(s_nodes, paired), m_nodes)
    if nodes.size == 0:
        return None
    return watch(pts, nodes, m_edges, (s_nodes, m_nodes))


def crossing(w: Watch | None, u: np.ndarray) -> Crossing | None:
    """The watched unpaired nodes (`unpaired_watch`) that were outside the master curve
    and lie behind it in the displaced configuration u (n_nodes, 2); None when none."""
    if w is None:
        return None
    reach = displacement_scale(w, u, norm=False) * np.sqrt(2.0)
    if not reach > 0:
        return None
    found = nodes_behind(w, u, reach, 0.0, CROSS_REL_TOL * reach)
    if found is None:
        return None
    count, depth, node = found
    return Crossing(count, depth, w.pts[node].copy())


def crossed_unpaired(mesh: Mesh, slave: str, master: str, paired: np.ndarray,
                     u: np.ndarray, label: str) -> Crossing | None:
    """The unpaired nodes of curve `slave` (paired (k,): the slave nodes with a pair)
    that were outside the master curve `master` and lie behind it in the displaced
    configuration u (n_nodes, 2); None when there are none. (A run builds the Watch once,
    `unpaired_watch`, and calls `crossing` each step.)"""
    return crossing(unpaired_watch(mesh, slave, master, paired, label), u)


def paired_sides(mesh: Mesh, slave: str, master: str, paired: np.ndarray) -> tuple[str, str]:
    """(slave, master) curve names of an interface as its pairs have them: swapped when
    every paired node (paired (k,)) lies on the configured master curve (a discretisation
    that puts the multipliers on the coarser side, app/contact/mortar_coarse_slave.py)."""
    m_nodes = np.unique(np.asarray(mesh.curves[master]))
    if paired.size and np.isin(paired, m_nodes).all():
        return master, slave
    return slave, master


def crossing_warning(name: str, step: int, crossing: Crossing, search_distance: float) -> str:
    """The one-line warning for an interface with crossed unpaired nodes (1-based step)."""
    x, y = crossing.position
    return (f"interface '{name}', step {step}: {crossing.count} slave node(s) without a "
            f"contact pair have moved through the master (deepest {crossing.depth:.3g}, the "
            f"node at x={x:.4g}, y={y:.4g}): pairs are chosen once, on the undeformed mesh, "
            f"and a node whose initial gap was above search_distance={search_distance:g} "
            f"is not constrained; raise search_distance above the relative motion of the "
            f"bodies")
