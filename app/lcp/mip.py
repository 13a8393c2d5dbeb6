"""A complementary basis of an LCP by mixed-integer search (HiGHS through scipy.optimize.milp).

Lemke's method ends on a secondary ray only when the LCP has no solution for copositive-plus
matrices; the frictional contact LCP with free floating-mode amplitudes is not one, and its
ray then proves nothing. `complementary_basis` searches the LCP's solutions directly, with
one binary per pair (z_i, w_i) and a bound on the scaled unknowns (big-M), and returns the
basis of the least sum of the scaled z (the least motion) it finds; `lemke`, warm-started
from it, solves and checks the answer. configs/multibody.toml --sd 1 --mesh-size 1.2 (step
1, 98 unknowns, 22 hourglass modes held by friction): Lemke ended on a secondary ray, the
search found a solution that Lemke's check accepts from its basis in 0 pivots.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp

MIP_BOUND = 1e3
"""Largest scaled unknown (z and w, both scaled to unit diagonal) the search admits."""

MIP_MAX_SIZE = 200
"""LCPs above this size are not searched (binaries: one per unknown)."""

MIP_NODES = 5000
"""Branch-and-bound nodes of one search (HiGHS): a limit that does not depend on the
machine's speed. multibody.toml --sd 1 --mesh-size 1.2 needs 352 and 503 (steps 1 and 3)."""

MIP_SECONDS = 600.0
"""Time limit of one search, a guard against a hang only (the node limit ends it first)."""

BASIC_REL = 1e-9
"""z_i above this x MIP_BOUND is basic in the returned basis."""


def complementary_basis(m: np.ndarray, q: np.ndarray, bound: float = MIP_BOUND,
                        seconds: float = MIP_SECONDS, widen: np.ndarray | None = None
                        ) -> tuple[np.ndarray | None, str]:
    """(basis (n,) bool or None, what the search found, in words) for LCP(m, q), m (n, n)
    and q (n,) scaled to a unit diagonal: z, w = m z + q >= 0, z_i <= bound widen_i y_i,
    w_i <= bound (1 - y_i), y binary, least sum(z). widen (n,) >= 1 (default 1): a
    caller's factor on the bound of the unknowns whose unit diagonal understates them (see
    `app.interface.coulomb.ContactLCP._searched`). None when there is no such solution
    (within the bounds), the LCP is above MIP_MAX_SIZE or the search ran out of nodes or
    time."""
    n = q.size
    if n == 0 or n > MIP_MAX_SIZE:
        return None, f"no mixed-integer search (size {n} > {MIP_MAX_SIZE})"
    zb = bound * (np.ones(n) if widen is None else np.maximum(widen, 1.0))
    eye, zero = np.eye(n), np.zeros((n, n))
    a = np.block([[m, zero], [eye, -np.diag(zb)], [m, bound * eye]])
    inf = np.full(n, np.inf)
    lo = np.concatenate([-q, -inf, -inf])
    hi = np.concatenate([inf, np.zeros(n), bound - q])
    res = milp(np.concatenate([np.ones(n), np.zeros(n)]),
               constraints=LinearConstraint(a, lo, hi),
               integrality=np.concatenate([np.zeros(n), np.ones(n)]),
               bounds=Bounds(np.zeros(2 * n), np.concatenate([inf, np.ones(n)])),
               options={"node_limit": MIP_NODES, "time_limit": seconds, "mip_rel_gap": 0.0})
    if res.status == 0 and res.x is not None:
        return res.x[:n] > BASIC_REL * zb, "a mixed-integer search found a basis"
    if res.status == 2:
        wider = "" if widen is None or not (widen > 1.0).any() else \
            f" ({int((widen > 1.0).sum())} of them up to {zb.max():.1e})"
        return None, ("a mixed-integer search found no solution with the scaled unknowns "
                      f"below {bound:.0e}{wider}")
    return None, f"the mixed-integer search ended without a basis ({res.message})"
