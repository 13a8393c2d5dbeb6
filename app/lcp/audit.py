"""The adversarial checker of the LCP solvers (scripts/check_lcp.py): solve each case of
`app.interface.audit_cases` with each solver and classify the outcome against an independent
reference (`app.lcp.exact`: enumeration for n <= 12, LP feasibility, the KKT residual).

Outcomes, worst first:
- "wrong": "solved" but the answer fails the independent check (relative row violation
  above WRONG_REL), or "solved" where no solution exists;
- "missed": no solution returned where one exists and the class guarantees that Lemke
  finds it (a P-matrix, or copositive-plus and feasible);
- "hang": the pivot limit (cycling) or more than HANG_SECONDS;
- "exception": an exception other than the documented ValueError (bad shapes, data,
  tol, basis), or none where one is due;
- "missed_unguaranteed" (reported, not a failure): a secondary ray where a solution
  exists but the class gives no guarantee (the frictional contact LCP);
- "ok".
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from app.lcp import exact
from app.lcp.lemke import lemke_tableau
from app.lcp.solvers import LCP_SOLVERS

WRONG_REL = 1e-6
"""A "solved" answer is wrong when some row violates w_i >= 0 or z_i w_i = 0 by more
than this x |q_i| + sum_j |M_ij| z_j (the size of the terms of w_i; 1000 x lemke's tol)."""
@dataclass
class Case:
    """One LCP to solve. scale: z of this LCP is z_ref / scale, where z_ref solves the
    LCP `ref` (M, q) (None: this one); kw: extra keyword arguments of the solver (basis,
    cold_start, ...); error: the call must raise ValueError."""

    cls: str
    M: np.ndarray
    q: np.ndarray
    guarantee: str
    kw: dict = field(default_factory=dict)
    ref: tuple[np.ndarray, np.ndarray] | None = None
    scale: np.ndarray | None = None
    error: bool = False
    expect: str | None = None  # "infeasible" when built to have no solution


FLOOR_REL = 1e-10
"""Floor of a row's size in `row_violation`, relative to the scale of the LCP (so that
with WRONG_REL a violation below 1e-16 of that scale is round-off)."""
HANG_SECONDS = 60.0
"""A call that takes longer counts as a hang."""
FAILURES = ("wrong", "missed", "hang", "exception")


def solvers() -> dict[str, Callable]:
    """Every registered solver (`app.lcp.solvers.LCP_SOLVERS`), and lemke's other paths:
    the textbook start (crash=False) and the full-tableau reference core."""
    out = dict(LCP_SOLVERS)
    lem = LCP_SOLVERS["lemke"]
    out["lemke(crash=False)"] = lambda M, q, **kw: lem(M, q, crash=False, **kw)
    out["lemke_tableau"] = lemke_tableau
    return out


def row_violation(M: np.ndarray, q: np.ndarray, z: np.ndarray) -> float:
    """max_i of the violation of w_i >= 0 (and of w_i = 0 where z_i > 0) relative to
    s_i = |q_i| + sum_j |M_ij| z_j; inf for a negative or non-finite z.

    s_i is at least FLOOR_REL x the problem's scale in the Jacobi scaling (D_i =
    1 / sqrt|M_ii|, 1 where M_ii = 0; M~ = D M D, q~ = D q, z~ = z / D): the row's largest
    |M~_ij| x max(max z~, max |q~| / max |M~|), back in row i's units (/ D_i), so that
    round-off on a degenerate row (q_i = 0, z_i = w_i = 1e-31) is not a violation."""
    if not (np.isfinite(z).all() and (z >= 0).all()):
        return np.inf
    w = M @ z + q
    viol = np.maximum(np.maximum(-w, 0.0), np.where(z > 0, np.abs(w), 0.0))
    dg = np.abs(np.diagonal(M))
    D = 1.0 / np.sqrt(np.where(dg > 0, dg, 1.0))
    Mt = np.abs(D[:, None] * M * D)
    big = Mt.max(initial=0.0)
    zs = max((z / D).max(initial=0.0), np.abs(D * q).max(initial=0.0) / big if big else 0.0)
    floor = FLOOR_REL * Mt.max(axis=1, initial=0.0) * zs / D
    rows = np.maximum(np.abs(q) + np.abs(M) @ z, floor)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(viol > 0, viol / rows, 0.0)
    return float(rel.max(initial=0.0))


class Reference:
    """What is known of a case's solutions: exists (True/False/None: unknown) and, when
    enumerated, the solutions of the case's own LCP (z of `ref` / scale)."""

    def __init__(self, case: Case):
        M, q = case.ref if case.ref is not None else (case.M, case.q)
        self.sols = None
        self.exists = None
        if q.size <= exact.MAX_ENUMERATE:
            sols = exact.solutions(M, q)
            if case.scale is not None:
                sols = [s / case.scale for s in sols]
            self.sols = sols
            self.exists = bool(sols)
        if case.guarantee == "P":
            self.exists = True
        elif case.guarantee == "copositive-plus" and not self.exists:
            self.exists = exact.feasible(M, q)
        if case.expect == "infeasible" and self.exists:
            raise AssertionError(f"{case.cls}: built infeasible but a solution exists")
        if case.expect == "infeasible":
            self.exists = False


def classify(case: Case, solve: Callable, ref: Reference) -> dict:
    """Run solve(case.M, case.q, **case.kw) and classify it (see the module docstring).
    Returns {"outcome", "status", "pivots", "seconds", "violation", "z_error"}."""
    t0 = time.perf_counter()
    try:
        res = solve(case.M, case.q, **case.kw)
    except ValueError as e:
        out = "ok" if case.error else "exception"
        return _row(out, f"ValueError: {e}", 0, time.perf_counter() - t0)
    except Exception as e:  # noqa: BLE001 (every other exception is a finding)
        return _row("exception", f"{type(e).__name__}: {e}", 0, time.perf_counter() - t0)
    dt = time.perf_counter() - t0
    if case.error:
        return _row("exception", f"no ValueError ({res.status})", res.pivots, dt)
    viol = row_violation(case.M, case.q, res.z)
    zerr = _z_error(res.z, ref)
    if res.status == "solved":
        bad = viol > WRONG_REL or ref.exists is False
        outcome = "wrong" if bad else ("hang" if dt > HANG_SECONDS else "ok")
    elif res.status == "pivot limit" or dt > HANG_SECONDS:
        outcome = "hang"
    elif res.status == "warm start failed" or not ref.exists:
        outcome = "ok"  # declined (cold_start=False), or a correct "no solution"
    elif case.guarantee in ("P", "copositive-plus"):
        outcome = "missed"
    else:
        outcome = "missed_unguaranteed"
    return _row(outcome, res.status, res.pivots, dt, viol, zerr)


def _z_error(z: np.ndarray, ref: Reference) -> float | None:
    """Distance of z to the nearest enumerated solution, relative to max |z_ref|."""
    if not ref.sols:
        return None
    d = [float(np.abs(z - s).max() / max(np.abs(s).max(), 1e-300)) for s in ref.sols]
    return min(d)


def _row(outcome: str, status: str, pivots: int, seconds: float, violation: float = 0.0,
         z_error: float | None = None) -> dict:
    return {"outcome": outcome, "status": status, "pivots": int(pivots),
            "seconds": round(seconds, 6), "violation": violation, "z_error": z_error}
