"""Master nodes that have moved through the slave surface.

The contact rows constrain the slave side only (a slave node's gap, or a weighted gap
over the slave's shape functions): a master node is never kept out of the slave body.
Where the master has a corner (a flat punch's edge) or is finer than the slave, a
master node can sink between two slave nodes and the run goes on without a word.
Measured on a stiff flat punch (2 x 1, E 1e5, its corners refined to 0.01) pressed into
a block (E 1e3) with the block's top as slave: the punch corners lie behind the block's
deformed surface by 6.6e-4, 6.2% of the largest displacement, with every discretisation
(mortar, node-to-segment, mortar-standard, ...); with the punch as slave nothing of the
block is behind it by 1e-4 of it. README "Hard cases", flat punch.

This check, after a step: a master node that started on or outside the slave curve (not
behind it by more than MASTER_DEPTH_WARN of the scale: an intended interference is left
alone) and now lies behind the deformed slave curve by more than MASTER_DEPTH_WARN x the
largest nodal displacement of the two curves (judged by the closest slave segment; a
node beyond a free end of the slave curve is not judged).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.contact.pairs import _curve_edges
from app.contact.unpaired import Watch, displacement_scale, nodes_behind, watch
from app.mesh.model import Mesh, orient_boundary_edges

MASTER_DEPTH_WARN = 0.03
"""Depth behind the deformed slave, relative to the largest nodal displacement of the
two curves, above which a master node is reported. On a flat-on-flat interface with
non-matching meshes a master node can lie behind the slave's chords by a little
(multibody's `stack`, sheared: 1.0-1.5%; every other shipped config below 1%): the
threshold has a factor 2 to that and to the punch's corners (6.2%)."""


@dataclass
class MasterPenetration:
    """Master nodes of one interface behind the deformed slave: count, the deepest one's
    depth (length), that depth over the displacement scale, its undeformed position (2,)."""

    count: int
    depth: float
    ratio: float
    position: np.ndarray


def penetration_watch(mesh: Mesh, slave: str, master: str, label: str) -> Watch | None:
    """The Watch of the master nodes of curves (slave, master) (not the slave's own)
    against the oriented slave curve; None when there are none."""
    pts = np.asarray(mesh.points, dtype=float)
    s_edges = orient_boundary_edges(mesh, _curve_edges(mesh, slave, "slave", label),
                                    f"interface '{label}': slave curve '{slave}'")
    s_nodes = np.unique(s_edges)
    m_nodes = np.setdiff1d(np.unique(_curve_edges(mesh, master, "master", label)), s_nodes)
    if m_nodes.size == 0:
        return None
    return watch(pts, m_nodes, s_edges, (s_nodes, m_nodes))


def penetration(w: Watch | None, u: np.ndarray) -> MasterPenetration | None:
    """The watched master nodes (`penetration_watch`) that lie behind the slave curve in
    the displaced configuration u (n_nodes, 2); None when none does by more than
    MASTER_DEPTH_WARN of the scale."""
    if w is None:
        return None
    scale = displacement_scale(w, u, norm=True)
    if not 0 < scale < np.inf:  # (a non-finite u: the step fails its own check)
        return None
    tol = MASTER_DEPTH_WARN * scale
    found = nodes_behind(w, u, 2.0 * scale + tol, -tol, tol)
    if found is None:
        return None
    count, depth, node = found
    return MasterPenetration(count, depth, depth / scale, w.pts[node].copy())


def master_penetration(mesh: Mesh, slave: str, master: str, u: np.ndarray,
                       label: str) -> MasterPenetration | None:
    """The master nodes of curves (slave, master) that lie behind the slave curve in the
    displaced configuration u (n_nodes, 2); None when none does by more than
    MASTER_DEPTH_WARN of the scale. (A run builds the Watch once, `penetration_watch`,
    and calls `penetration` each step.)"""
    return penetration(penetration_watch(mesh, slave, master, label), u)


def master_penetration_warning(name: str, step: int, slave: str, master: str,
                               found: MasterPenetration) -> str:
    """The one-line warning for an interface with master nodes behind its slave."""
    x, y = found.position
    return (f"interface '{name}', step {step}: {found.count} node(s) of the master "
            f"'{master}' lie behind the deformed slave '{slave}' (deepest {found.depth:.3g}, "
            f"{100 * found.ratio:.2g}% of the largest displacement, the node at x={x:.4g}, "
            f"y={y:.4g}): the contact keeps slave nodes out of the master, not master nodes "
            "out of the slave; make the side with the corner (or the finer side) the slave, "
            "or refine the slave there")
