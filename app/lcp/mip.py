"""A complementary basis of an LCP by mixed-integer search (HiGHS through scipy.optimize.milp).

Lemke's method ends on a secondary ray only when the LCP has no solution for copositive-plus
matrices; the frictional contact LCP with free floating-mode amplitudes is not one, and its
ray then proves nothing. `complementary_basis` searches the LCP's solutions directly, with
one binary per pair (z_i, w_i) and a bound on the scaled unknowns (big-M), and returns the
basis of the least sum of the scaled z (the least motion) it finds that the caller's check
(`lemke` warm-started from it) accepts. configs/multibody.toml --sd 1 --mesh-size 1.2 (step
1, 98 unknowns, 22 hourglass modes held by friction): Lemke ended on a secondary ray, the
search found a solution that Lemke's check accepts from its basis in 0 pivots.

Free of units: LCP(m, t q) has the solutions t z (t > 0), and a scene in other units (every
E, load and bond strength x s) has the same unit-diagonal m and q x sqrt(s) (the scaled
unknowns carry sqrt(force x length)). The search sees q scaled to max |q| = MIP_SCALE and
bounds the unknowns relative to it, so the verdict and the basis do not depend on the
units. Before, the bound (1e3) applied to the unknowns as they came: multibody.toml --sd 1
--mesh-size 1.2 with its moduli, loads and bond strengths x 1e6 stopped with `no static
equilibrium` (none below 1e3) where its own units (max |q| 1.05 at step 1) complete.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp

MIP_SCALE = 1e3
"""max |q| of the LCP the search sees: HiGHS's tolerances are absolute (feasibility 1e-7 to
1e-6), and at max |q| = 1 they let w_i = -8e-7 through: two_blocks.toml's stiff floating
block (README "Floating bodies") then read a false solution whose basis Lemke's check
refused, at 1e3 the right one (w >= -5e-11;
tests/test_interface_steps.py::test_a_stiff_floating_block_at_1e11_finds_the_equilibrium_lemkes_ray_missed)."""

MIP_BOUNDS = (1e1, 1e2, 1e3)
"""The bounds on the scaled unknowns (z and w, times max |q|) tried in turn, the next only
when the last found none or none that the caller accepts: HiGHS's integrality tolerance
(1e-6) lets z_i reach 1e-6 x its bound where y_i = 0, and with 1e3 that slack found a false
solution of multibody.toml --sd 1 --mesh-size 1.2 at step 3 (sum of z 0.55 x the true one,
both bases refused), which 1e1 and 1e2 do not (tests/test_interface_floating.py, 1.2)."""

MIP_BOUND = MIP_BOUNDS[-1]
"""Largest scaled unknown (relative to max |q|) the search admits."""

MIP_MAX_SIZE = 200
"""LCPs above this size are not searched (binaries: one per unknown)."""

MIP_WORK = 1.2e7
"""Branch-and-bound nodes x n^2 of one bound's search (HiGHS), the search ending when a bound
reaches it: a limit that does not depend on the machine's speed, and bounds the time, a
node of an LCP of size n costing roughly 2e-6 n^2 s or more (7 ms at n = 39, 17-50 ms at
98, 250 ms at 200 on 2 shared cores; README "Floating bodies", cost): 1,250 nodes at n =
98, where multibody.toml --sd 1 --mesh-size 1.2 needs 582, 300 at 200. Per bound, since
HiGHS does not report the nodes of a proof that there is no solution. Before, 5,000 nodes
at any size: a random dense LCP of 200 took 426 s to reach them."""

MIP_SECONDS = 600.0
"""Time limit of one search, a guard against a hang only (the node limit ends it first)."""

BASIC_REL = 1e-9
"""z_i above this x its bound is basic in the first basis tried."""


def _search(m: np.ndarray, q: np.ndarray, zb: np.ndarray, bound: float, nodes: int,
            seconds: float):
    """HiGHS's answer to: z, w = m z + q >= 0, z_i <= zb_i y_i, w_i <= bound (1 - y_i), y
    binary, least sum(z) (m (n, n), q (n,), zb (n,))."""
    n = q.size
    eye, zero = np.eye(n), np.zeros((n, n))
    a = np.block([[m, zero], [eye, -np.diag(zb)], [m, bound * eye]])
    inf = np.full(n, np.inf)
    lo = np.concatenate([-q, -inf, -inf])
    hi = np.concatenate([inf, np.zeros(n), bound - q])
    return milp(np.concatenate([np.ones(n), np.zeros(n)]),
                constraints=LinearConstraint(a, lo, hi),
                integrality=np.concatenate([np.zeros(n), np.ones(n)]),
                bounds=Bounds(np.zeros(2 * n), np.concatenate([inf, np.ones(n)])),
                options={"node_limit": nodes, "time_limit": seconds, "mip_rel_gap": 0.0})


def complementary_basis(m: np.ndarray, q: np.ndarray,
                        accept: Callable[[np.ndarray], bool] = lambda basis: True, *,
                        widen: np.ndarray | None = None, bounds: tuple[float, ...] = MIP_BOUNDS,
                        work: float = MIP_WORK, seconds: float = MIP_SECONDS
                        ) -> tuple[np.ndarray | None, str]:
    """(basis (n,) bool or None, what the search found, in words) for LCP(m, q), m (n, n)
    and q (n,) scaled to a unit diagonal. With q' = MIP_SCALE q / max |q|, for each bound b
    in turn: z, w = m z + q' >= 0, z_i <= b MIP_SCALE widen_i y_i, w_i <= b MIP_SCALE (1 -
    y_i), y binary, least sum(z); its bases z > BASIC_REL x the bound and y, each given to
    `accept` (e.g. Lemke's check), the first accepted returned. widen (n,) >= 1 (default 1):
    a caller's factor on the bound of the unknowns whose unit diagonal understates them (see
    `app.interface.coulomb.ContactLCP._searched`). None when no bound has an accepted
    solution, the LCP is above MIP_MAX_SIZE or the search ran out of nodes (MIP_WORK / n^2
    over all bounds) or time. A node limit that ends a bound with a solution keeps it (not
    the least sum(z), but a solution)."""
    n = q.size
    if n == 0 or n > MIP_MAX_SIZE:
        return None, f"no mixed-integer search (size {n} > {MIP_MAX_SIZE})"
    top = float(np.abs(q).max())
    qs = q * (MIP_SCALE / top) if top > 0 else q
    factor = np.ones(n) if widen is None else np.maximum(widen, 1.0)
    nodes, end = max(int(work / n ** 2), 1), time.monotonic() + seconds
    notes: list[str] = []
    for b in bounds:
        bound = b * MIP_SCALE
        zb = bound * factor
        res = _search(m, qs, zb, bound, nodes, max(end - time.monotonic(), 1.0))
        nodes -= int(getattr(res, "mip_node_count", 0) or 0)
        if res.x is not None:
            z, y = res.x[:n] > BASIC_REL * zb, res.x[n:] > 0.5
            # both: within HiGHS's integrality tolerance a y_i of 1e-6 lets z_i reach 1e-6
            # x its bound with w_i > 0 (z's basis then singular), and y_i = 1 where z_i =
            # w_i = 0 can make y's singular
            for basis in ([z] if np.array_equal(z, y) else [z, y]):
                if accept(basis):
                    return basis, ("a mixed-integer search found a basis (the scaled "
                                   f"unknowns below {b:.0e} x the largest constant term)")
            notes.append(f"one below {b:.0e} that Lemke's check did not accept")
        elif res.status != 2:
            notes.append(f"none before its limit ({res.message})")
            break
        elif b == bounds[-1]:
            wider = "" if widen is None or not (widen > 1.0).any() else \
                f" ({int((widen > 1.0).sum())} of them up to {b * factor.max():.1e})"
            notes.append(f"no solution with the scaled unknowns below {b:.0e} x the largest "
                         f"constant term{wider}")
        if nodes <= 0 and b != bounds[-1]:
            notes.append("no nodes left")
            break
    return None, "a mixed-integer search found " + ", then ".join(notes)
