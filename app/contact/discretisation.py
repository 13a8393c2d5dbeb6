"""Registry of contact discretisations: name -> builder of `ContactConstraints`.

A builder takes (mesh, interface config, interface index) and returns the constraint
rows of that interface. Adding a discretisation = one new file with its builder plus one
entry in `DISCRETISATIONS`; the config key `discretisation` of `[[interface]]` picks it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

from app.contact.constraints import ContactConstraints
from app.contact.mortar import mortar_constraints
from app.contact.mortar_bisector import mortar_bisector_constraints
from app.contact.mortar_coarse_slave import mortar_coarse_slave_constraints
from app.contact.mortar_smooth import mortar_smooth_constraints
from app.contact.mortar_standard import mortar_standard_constraints
from app.contact.pairs import ContactPairs, contact_pairs
from app.errors import InputError
from app.mesh.model import Mesh


class InterfaceSpec(Protocol):
    """What a builder reads of an `[[interface]]` (app.config.Interface)."""

    name: str
    slave: str
    master: str
    search_distance: float
    penetration_tol: float | None
    interference: bool


def pair_rows(pairs: ContactPairs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node-to-segment rows: (cols, g_normal, g_tangent), each (m, 6), for
    d = u_s - (1 - xi) u_A - xi u_B: opening n . d and slip t . d."""
    m = pairs.n_pairs
    nodes = np.column_stack([pairs.slave, pairs.master[:, 0], pairs.master[:, 1]])  # (m, 3)
    w = np.column_stack([np.ones(m), -(1 - pairs.xi), -pairs.xi])  # (m, 3)
    cols = (2 * nodes[:, :, None] + np.arange(2)).reshape(m, 6)
    vals_n = (w[:, :, None] * pairs.normal[:, None, :]).reshape(m, 6)
    vals_t = (w[:, :, None] * pairs.tangent[:, None, :]).reshape(m, 6)
    return cols.astype(np.int64), vals_n, vals_t


def node_to_segment(mesh: Mesh, itf: InterfaceSpec, index: int) -> ContactConstraints:
    """Every slave node paired with its closest master segment (the seed paper)."""
    pairs = contact_pairs(mesh, itf.slave, itf.master, itf.search_distance, interface=index,
                          penetration_tol=itf.penetration_tol, name=itf.name,
                          interference=itf.interference)
    return ContactConstraints(pairs, *pair_rows(pairs))


Builder = Callable[[Mesh, InterfaceSpec, int], ContactConstraints]

DISCRETISATIONS: dict[str, Builder] = {
    "node-to-segment": node_to_segment,
    "mortar": mortar_constraints,
    "mortar-bisector": mortar_bisector_constraints,
    "mortar-smooth": mortar_smooth_constraints,
    "mortar-standard": mortar_standard_constraints,
    "mortar-coarse-slave": mortar_coarse_slave_constraints,
}
"""Contact discretisations by config name."""

DEFAULT = "mortar"


def contact_discretisation(name: str | None, where: str) -> Builder:
    """The registered builder `name` (None: DEFAULT), or a one-line InputError naming
    `where` and the registered names."""
    try:
        return DISCRETISATIONS[DEFAULT if name is None else name]
    except (KeyError, TypeError):
        names = ", ".join(repr(k) for k in DISCRETISATIONS)
        raise InputError(f"{where}: discretisation must be one of {names}, got {name!r}") \
            from None
