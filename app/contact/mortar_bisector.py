"""Dual mortar with the bisector contact normal (`discretisation = "mortar-bisector"`).

The same rows as `mortar` (app/contact/mortar.py) except the contact normal: the plain
mean of the two sides' averaged nodal normals, n = unit(nu_m - nu_s), whatever their
curvatures. For a cylinder of radius R on a flat block of the same material it is tilted
by x / (2R) at the slave node x, the slope of the deformed contact surface (equal
materials deform equally, so the contact line has half the cylinder's curvature), and
each body sees the same tangential component p x / (2R) of the contact pressure relative
to its own surface: normal and tangential problems uncouple as in Cattaneo-Mindlin's
theory. With `mortar`'s flat normal the cylinder alone sees p x / R, so friction during
the normal loading locks in an antisymmetric q (README, "Where the tangential-traction
error comes from").

The price, in these geometrically linear rows: a frictionless interface with tilted
normals resists a tangential translation (the normals tilt in opposite senses on the two
sides of the contact, a groove), so it holds a tangential load that a frictionless
contact of a cylinder on a flat cannot. Opt in per interface; `mortar` stays the default.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from app.contact.constraints import ContactConstraints
from app.contact.mortar import mortar_constraints
from app.mesh.model import Mesh

if TYPE_CHECKING:  # app.contact.discretisation imports this module
    from app.contact.discretisation import InterfaceSpec


def bisector_normal(nu_s: np.ndarray, kappa_s: np.ndarray, nu_m: np.ndarray,
                    kappa_m: np.ndarray) -> np.ndarray:
    """(p, 2) unit normals (master -> slave) bisecting the two sides' outward normals
    nu_s, nu_m (p, 2); the curvatures are not used."""
    v = nu_m - nu_s
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def mortar_bisector_constraints(mesh: Mesh, itf: InterfaceSpec,
                                index: int) -> ContactConstraints:
    """Dual mortar rows of one interface with `bisector_normal`."""
    return mortar_constraints(mesh, itf, index, normal_rule=bisector_normal)
