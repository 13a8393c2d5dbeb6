"""The one recovery step of `lemke`: what follows a run that ended "inaccurate" or on a
secondary ray, before that result is returned.

Policy, in this order; the first attempt whose answer passes the final check (in the
caller's units) is returned, with the pivots of every attempt; when all fail, the first
result is returned (its status and message) with the pivots of every attempt:

1. restart from the final basis (only after "inaccurate": the run stopped on a
   complementary basis whose z_B has an entry just below 0, round-off on an
   ill-conditioned path such as a soft floating body pressed between stiff ones): a warm
   start from it (block pivoting, then Lemke, no cold start), up to RESTARTS times, each
   from the basis the last one ended on;
2. the balanced LCP (only when M's rows and columns are in very different units,
   `app.lcp.balance`): LCP(R M C, R q) solved afresh (crash, Lemke, then step 1 on it),
   z = C z'; the steps after this one work on the balanced LCP;
3. the basis repair (only for a symmetric M, `app.lcp.repair`): a warm start (no crash,
   no cold start) from the positive set of the convex QP (non-negative least squares).

Every attempt draws on one pivot budget: what the first run left of `max_pivots` (default
`default_max_pivots(n)`). The steps do not nest: each runs at most once per `lemke` call.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

from app.lcp.balance import balance
from app.lcp.repair import is_symmetric, qp_basis
from app.lcp.result import LCPResult, default_max_pivots

RESTARTS = 3
"""Most warm starts from a final basis (step 1)."""
RECOVERED = ("inaccurate", "secondary ray")
"""Statuses the recovery acts on ("pivot limit": no budget left; "warm start failed": the
caller tries another basis)."""


class Run(Protocol):
    """One solve of `lemke` without recovery (`app.lcp.lemke._run` with its core and tol)."""

    def __call__(self, M: np.ndarray, q: np.ndarray, max_pivots: int,
                 basis: np.ndarray | None, cold_start: bool, crash: bool) -> LCPResult: ...


Check = Callable[[np.ndarray, np.ndarray, np.ndarray], tuple]
"""check(M, q, z) -> (w, ok, complementarity, worst): lemke's final check (`_check`)."""


class _Budget:
    """The pivots spent by the attempts and what is left of the budget."""

    def __init__(self, total: int, spent: int):
        self.total, self.spent = total, spent

    @property
    def left(self) -> int:
        return max(self.total - self.spent, 0)

    def charge(self, res: LCPResult) -> LCPResult:
        self.spent += res.pivots
        return res


def recover(run: Run, check: Check, M: np.ndarray, q: np.ndarray, res: LCPResult,
            max_pivots: int | None, crash: bool) -> LCPResult:
    """res, or the first answer of the recovery steps (see the module docstring). M, q:
    the caller's data (float arrays, validated); crash: the caller's crash flag (steps 1
    and 2 use it)."""
    if res.ok or res.status not in RECOVERED:
        return res
    budget = _Budget(default_max_pivots(q.size) if max_pivots is None else int(max_pivots),
                     res.pivots)
    if res.status == "inaccurate":
        again = _restarts(run, M, q, res, budget, crash)
        if again is not None:
            return _solved(again, res, budget, "then, from its final basis: ")
    Mc, qc, colf = M, q, None
    rc = balance(M)
    if rc is not None:
        r, c = rc
        Mc, qc, colf = r[:, None] * M * c, r * q, c
        out = _balanced(run, check, M, q, Mc, qc, c, budget, crash)
        if out is not None:
            return _solved(out, res, budget, "then, on the balanced LCP (rows and "
                           "columns in units of their largest entry): ")
    if is_symmetric(Mc):
        again = _repaired(run, check, M, q, Mc, qc, colf, budget)
        if again is not None:
            again.warm_start = "qp"
            again.message = (f"{res.message}; then solved from the positive set of the "
                             f"convex QP (non-negative least squares) in {again.pivots} "
                             "pivots")
            again.pivots = budget.spent
            return again
    res.pivots = budget.spent
    return res


def _balanced(run: Run, check: Check, M: np.ndarray, q: np.ndarray, Mc: np.ndarray,
              qc: np.ndarray, c: np.ndarray, budget: _Budget, crash: bool
              ) -> LCPResult | None:
    """Step 2: the balanced LCP (Mc = R M C, qc = R q) solved afresh, then step 1 on it
    after "inaccurate"; its answer in the caller's units (z = C z'), or None when it
    fails there."""
    again = budget.charge(run(Mc, qc, budget.left, None, True, crash))
    if not again.ok and again.status == "inaccurate":
        again = _restarts(run, Mc, qc, again, budget, crash) or again
    if not again.ok:
        return None
    return _unbalanced(check, M, q, again, c)


def _repaired(run: Run, check: Check, M: np.ndarray, q: np.ndarray, Mc: np.ndarray,
              qc: np.ndarray, colf: np.ndarray | None, budget: _Budget) -> LCPResult | None:
    """Step 3: a warm start (no crash, no cold start) on (Mc, qc) from the positive set of
    the convex QP; its answer in the caller's units (z = colf z' when balanced), or None."""
    B = qp_basis(Mc, qc)
    if B is None:
        return None
    again = budget.charge(run(Mc, qc, budget.left, B, False, False))
    if again.ok and colf is not None:
        again = _unbalanced(check, M, q, again, colf)
    return again if again is not None and again.ok else None


def _restarts(run: Run, M: np.ndarray, q: np.ndarray, res: LCPResult, budget: _Budget,
              crash: bool) -> LCPResult | None:
    """Step 1: up to RESTARTS warm starts, each from the basis the last run ended on; the
    first solved result, or None."""
    basis = res.basis
    for _ in range(RESTARTS):
        if basis is None or not basis.any():
            return None
        again = budget.charge(run(M, q, budget.left, basis, False, crash))
        if again.ok:
            return again
        basis = again.basis
    return None


def _unbalanced(check: Check, M: np.ndarray, q: np.ndarray, res: LCPResult,
                c: np.ndarray) -> LCPResult | None:
    """The answer of the balanced LCP in the caller's units (z = C z'), checked on the
    caller's M and q; None when it fails there."""
    z = res.z * c
    w, ok, comp, worst = check(M, q, z)
    if not ok:
        return None
    return LCPResult(z, w, res.pivots, "solved", comp, res.basis, res.message, res.warm_start,
                     res.refactorizations, worst)


def _solved(again: LCPResult, first: LCPResult, budget: _Budget, how: str) -> LCPResult:
    """The recovered answer with the pivots of every attempt and the first run's message."""
    again.pivots = budget.spent
    again.message = f"{first.message}; {how}{again.message}"
    return again
