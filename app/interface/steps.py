"""Load steps with bonding-debonding iterations (METHOD.md section 4), on rank 0.

Per pair and step the state is one of STATE_NAMES; a bonded pair that opens or slips
debonds for good (a = c = 0 from then on) and the step is solved again from its start
until no new pair debonds. The tangential history tau_prev is carried between steps.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from app.interface.coulomb import ContactLCP, ContactSolution

BONDED, STICK, SLIP_PLUS, SLIP_MINUS, OPEN = 0, 1, 2, 3, 4
STATE_NAMES = ("bonded", "stick", "slip+", "slip-", "open")


@dataclass
class StepResult:
    """What one load step produced (rank 0)."""

    solution: ContactSolution
    state: np.ndarray  # (m,) int codes, see STATE_NAMES
    debonded_step: np.ndarray  # (m,) step (1-based) where the pair debonded, 0 = never
    iterations: int  # LCP solves in this step (1 + debonding re-solves)
    pivots: int
    seconds: float
    dissipation: float  # frictional work of this step, -sum q * (slip increment) >= 0
    status: str


@dataclass
class InterfaceHistory:
    """Per-pair state carried between steps."""

    a: np.ndarray  # (m,) current adhesion force (0 once debonded)
    c: np.ndarray  # (m,) current strength force
    bonded: np.ndarray  # (m,) bool
    tau_prev: np.ndarray  # (m,) relative tangential displacement at the end of last step
    debonded_step: np.ndarray  # (m,) int
    basis: np.ndarray | None = None
    older_basis: np.ndarray | None = None  # the basis before, tried when `basis` fails
    warm_start: bool = True


def classify(sol: ContactSolution, bonded: np.ndarray, tol_gap: float,
             tol_slip: float, frictionless: np.ndarray | None = None,
             tau_prev: np.ndarray | None = None) -> np.ndarray:
    """State code per pair from a solution.

    Frictional pairs slip when the LCP's slip variables are positive; frictionless pairs
    (`frictionless` mask, no tangential unknowns) slip when their relative tangential
    displacement changed from `tau_prev` by more than tol_slip.
    """
    state = np.full(sol.p.size, STICK, dtype=np.int64)
    slip_p = sol.slip_plus > tol_slip
    slip_m = sol.slip_minus > tol_slip
    if frictionless is not None and tau_prev is not None:
        dtau = np.where(frictionless, sol.tau - tau_prev, 0.0)
        slip_p |= dtau > tol_slip
        slip_m |= dtau < -tol_slip
    state[slip_p] = SLIP_PLUS
    state[slip_m & ~slip_p] = SLIP_MINUS
    state[bonded & ~slip_p & ~slip_m] = BONDED
    state[sol.gap > tol_gap] = OPEN
    return state


def solve_step(lcp: ContactLCP, hist: InterfaceHistory, step: int, gap_free: np.ndarray,
               tau_free: np.ndarray, mu: np.ndarray, e0: np.ndarray, tol_gap: float,
               tol_slip: float, max_iterations: int = 1000) -> StepResult:
    """Solve one load step, with debonding iterations; updates `hist` on success."""
    t0 = time.perf_counter()
    pivots = 0
    a, c, bonded = hist.a.copy(), hist.c.copy(), hist.bonded.copy()
    debonded_step = hist.debonded_step.copy()
    basis = [b for b in (hist.basis, hist.older_basis) if b is not None] \
        if hist.warm_start else None
    frictionless = np.ones(lcp.m, dtype=bool)
    frictionless[lcp.fric] = False
    for it in range(1, max_iterations + 1):
        sol = lcp.solve(gap_free, tau_free, hist.tau_prev, a, c, mu, e0, basis=basis)
        pivots += sol.pivots
        if sol.status != "solved":
            return StepResult(sol, classify(sol, bonded, tol_gap, tol_slip, frictionless,
                                            hist.tau_prev), debonded_step,
                              it, pivots, time.perf_counter() - t0, 0.0, sol.status)
        slipped = (sol.slip_plus + sol.slip_minus) > tol_slip
        new = bonded & ((sol.gap > tol_gap) | slipped)
        if not new.any():
            break
        bonded &= ~new
        a[new] = 0.0
        c[new] = 0.0
        debonded_step[new] = step
        if hist.warm_start:
            basis = sol.basis
    state = classify(sol, bonded, tol_gap, tol_slip, frictionless, hist.tau_prev)
    slip_inc = sol.slip_plus - sol.slip_minus
    dissipation = float(-np.sum(sol.q * slip_inc))
    hist.a, hist.c, hist.bonded = a, c, bonded
    hist.debonded_step = debonded_step
    hist.tau_prev = sol.tau.copy()
    if hist.basis is not None and sol.basis is not None and \
            not np.array_equal(hist.basis, sol.basis):
        hist.older_basis = hist.basis
    hist.basis = sol.basis
    return StepResult(sol, state, debonded_step, it, pivots, time.perf_counter() - t0,
                      dissipation, "solved")
