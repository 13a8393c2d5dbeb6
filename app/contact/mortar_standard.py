"""Mortar with standard multipliers (`discretisation = "mortar-standard"`).

The same segmentation, contact normal and master interpolation as `mortar`
(app/contact/mortar.py), but the multiplier of slave node j is tested with its own
linear shape function N_j instead of the dual phi_j: the weighted gap and slip are

    g~_j = n_j . (sum_k S_jk x_k - sum_l M_jl x_l) / cover_j,
    S_jk = int N_j N_k ds (slave, banded),   M_jl = int N_j N_l(eta(s)) ds (master),

both over the covered pieces of the slave segments, cover_j = sum_l M_jl. The LCP
unknown of node j is then cover_j lambda_j, with lambda the nodal values of a
piecewise-linear traction lambda(s) = sum_j lambda_j N_j(s): p and q in the output are
those nodal values (where the master covers the node's support), and the nodal forces
on the bodies are G^T of the unknowns (slave node j receives sum_k S_jk lambda_k, not
p_j x length_j).

Why it is opt-in (README "Contact discretisations", measured with
scripts/bench_mortar.py): it passes the patch test like the dual rows, and on the
structured hertz_patch mesh it is as good (L2(p) 0.75% at a/40 against 0.78%), but on
unstructured meshes the nodal complementarity lambda_j >= 0 _|_ g~_j >= 0 on a banded S
lets the traction wobble: Hertz a/40 1.10% (dual 0.89%), and multibody `indent` on a
block2 meshed at the arc's size 11.8% of max p off a local fit (dual 0.9%). Each row
also couples three slave nodes instead of one.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from app.contact.constraints import ContactConstraints
from app.contact.mortar import Multipliers, mortar_constraints
from app.mesh.model import Mesh

if TYPE_CHECKING:  # app.contact.discretisation imports this module
    from app.contact.discretisation import InterfaceSpec


def standard_multipliers(s: np.ndarray) -> np.ndarray:
    """The linear shape functions (2, ...) of a slave segment at parameters s in [0, 1]:
    N_1 = 1 - s, N_2 = s."""
    return np.stack([1 - s, s])


STANDARD = Multipliers("standard", standard_multipliers, slave_mass=True)


def mortar_standard_constraints(mesh: Mesh, itf: InterfaceSpec,
                                index: int) -> ContactConstraints:
    """Mortar rows of one interface with the standard multipliers `STANDARD`."""
    return mortar_constraints(mesh, itf, index, multipliers=STANDARD)
