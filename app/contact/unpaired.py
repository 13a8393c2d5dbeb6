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
                radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance (q,) of points x (q, 2) to the closest of the oriented segments
    xa -> xb (s, 2) within radius (positive on the right, outside the master body), and
    whether it is judged (q,) bool: a segment within radius, the point not beyond a free
    end (free (s, 2) bool: the segment's ends that end the master curve)."""
    seg, xr, _ = closest_segments(x, xa, xb, radius)
    found = seg >= 0
    s = np.where(found, seg, 0)
    beyond = (((xr < -XI_EPS) & free[s, 0]) | ((xr > 1 + XI_EPS) & free[s, 1]))
    d = xb[s] - xa[s]
    xi = np.clip(np.nan_to_num(xr), 0.0, 1.0)[:, None]
    r = x - (xa[s] + xi * d)
    gap = (r[:, 0] * d[:, 1] - r[:, 1] * d[:, 0]) / np.linalg.norm(d, axis=1)
    return gap, found & ~beyond


def nodes_behind(pts: np.ndarray, nodes: np.ndarray, edges: np.ndarray, u: np.ndarray,
                 reach: float, start_min: float, depth_tol: float
                 ) -> tuple[int, float, int] | None:
    """Of `nodes` (k,), those whose undeformed signed gap to the oriented curve `edges`
    (s, 2) exceeds start_min and that lie behind the deformed curve (pts + u) by more than
    depth_tol, both judged by the closest segment (searched within reach, then 2 reach;
    a node beyond a free end of the curve is not judged): (count, the deepest one's
    depth, its node id), or None when there is none."""
    free = np.bincount(edges.ravel(), minlength=pts.shape[0])[edges] == 1
    a, b = edges[:, 0], edges[:, 1]
    g_start, ok_start = _signed_gap(pts[nodes], pts[a], pts[b], free, reach)
    near = ok_start & (g_start > start_min)
    if not near.any():
        return None
    nodes = nodes[near]
    x1 = pts + u
    g_now, ok_now = _signed_gap(x1[nodes], x1[a], x1[b], free, 2.0 * reach)
    behind = ok_now & (g_now < -depth_tol)
    if not behind.any():
        return None
    deepest = int(np.argmin(np.where(behind, g_now, np.inf)))
    return int(behind.sum()), float(-g_now[deepest]), int(nodes[deepest])


def crossed_unpaired(mesh: Mesh, slave: str, master: str, paired: np.ndarray,
                     u: np.ndarray, label: str) -> Crossing | None:
    """The unpaired nodes of curve `slave` (paired (k,): the slave nodes with a pair)
    that were outside the master curve `master` and lie behind it in the displaced
    configuration u (n_nodes, 2); None when there are none."""
    pts = np.asarray(mesh.points, dtype=float)
    s_nodes = np.unique(_curve_edges(mesh, slave, "slave", label))
    m_edges = orient_boundary_edges(mesh, _curve_edges(mesh, master, "master", label),
                                    f"interface '{label}': master curve '{master}'")
    m_nodes = np.unique(m_edges)
    nodes = np.setdiff1d(np.setdiff1d(s_nodes, paired), m_nodes)
    if nodes.size == 0:
        return None
    reach = float(np.abs(u[s_nodes]).max() + np.abs(u[m_nodes]).max()) * np.sqrt(2.0)
    if not reach > 0:
        return None
    found = nodes_behind(pts, nodes, m_edges, u, reach, 0.0, CROSS_REL_TOL * reach)
    if found is None:
        return None
    count, depth, node = found
    return Crossing(count, depth, pts[node].copy())


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
