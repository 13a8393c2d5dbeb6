"""Dual mortar with the multipliers on the coarser side (`discretisation = "mortar-coarse-slave"`).

The rows of `mortar` (app/contact/mortar.py), with one choice made per interface: when
the configured master's segments facing the slave are more than SWAP_RATIO x the slave's
(medians over the slave nodes nearest the master, the stripe check's ratio), the two
curves swap roles, so the multipliers (the pairs, with their p, q, states and output)
sit on the nodes of the coarser side; otherwise the rows are `mortar`'s, bit for bit.

Why: with one multiplier per node of a slave much finer than its master, the constraint
set is richer than the master's piecewise-linear trace can carry (an inf-sup defect):
the slave's tractions oscillate with the master's element period (multibody `indent`,
master 4.4x: 30% of max p off a local quadratic fit), and a bond between a fine slave and
a coarse master debonds where the smooth answer does not (45% of the pairs at 6x). A
multiplier space at the master's resolution removes both; measured on the frictionless
indent LCP (scripts/bench_indent_ratio.py, `spaces`), coarse multipliers interpolated to
the fine slave nodes and dual multipliers on the coarse side behave alike, and the
latter is a plain `mortar` interface the other way round. README "Multiplier spaces on
a coarse master" has the figures.

What it changes for the user: the pairs of a swapped interface are the configured
master's nodes (output `slave` names them; normals point towards the configured master),
and a node may still be the slave of one interface only, so the swap can meet a curve
that is the slave of another interface at a shared corner (the run then stops with the
usual error naming the interfaces).
"""

from __future__ import annotations

from collections.abc import Callable
from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np

from app.contact.constraints import ContactConstraints
from app.contact.mortar import (
    MasterBasis,
    SlaveGeometry,
    linear_master,
    mortar_constraints,
    mortar_rows,
    slave_geometry,
)
from app.contact.mortar_smooth import master_slave_ratio
from app.contact.resolution import SIZE_RATIO_WARN
from app.mesh.model import Mesh

if TYPE_CHECKING:  # app.contact.discretisation imports this module
    from app.contact.discretisation import InterfaceSpec

SWAP_RATIO = SIZE_RATIO_WARN
"""The roles swap when the master / slave element-size ratio (medians, as the stripe
check's, app/contact/resolution.py) exceeds this."""


def swapped(itf: InterfaceSpec) -> SimpleNamespace:
    """The interface spec (what a builder reads, app.contact.discretisation.InterfaceSpec)
    with slave and master exchanged."""
    return SimpleNamespace(name=itf.name, slave=itf.master, master=itf.slave,
                           search_distance=itf.search_distance,
                           penetration_tol=itf.penetration_tol,
                           interference=itf.interference)


def size_ratio_probe(seen: list[float]) -> Callable[..., MasterBasis]:
    """A master-basis factory for app.contact.mortar.mortar_constraints that appends the
    interface's master / slave size ratio (`master_slave_ratio`) to `seen` and returns
    the linear trace (so the rows are `mortar`'s)."""

    def factory(pts: np.ndarray, m_edges: np.ndarray, facing: np.ndarray,
                slave_length: np.ndarray) -> MasterBasis:
        seen.append(master_slave_ratio(pts, m_edges, facing, slave_length))
        return linear_master(pts, m_edges, facing, slave_length)

    return factory


def size_ratio(geo: SlaveGeometry) -> float:
    """The interface's master / slave element-size ratio (`master_slave_ratio` over the
    slave nodes nearest the master), from its geometry alone: what `size_ratio_probe`
    records while the rows are built."""
    return master_slave_ratio(*geo.master_basis_args())


def mortar_coarse_slave_constraints(mesh: Mesh, itf: InterfaceSpec,
                                    index: int) -> ContactConstraints:
    """`mortar` rows of one interface, with slave and master swapped when the master is
    more than SWAP_RATIO x coarser than the slave (see the module docstring). The ratio
    comes from the interface's geometry (`size_ratio`): an interface that keeps its roles
    builds its rows once; one that swaps also builds the configured rows first, for their
    checks (a fine slave node penetrating the coarse master between two of its nodes is
    no penetration of the coarse nodes into the fine curve; no pair kept)."""
    geo = slave_geometry(mesh, itf)
    rows = mortar_rows(geo, itf, index)  # InputError: penetration, or no pair kept
    if size_ratio(geo) > SWAP_RATIO:
        return mortar_constraints(mesh, swapped(itf), index)
    return rows
