"""What an LCP solve returns: `LCPResult`, its statuses and the default pivot budget."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["STATUSES", "WARM_STARTS", "DEFAULT_TOL", "LCPResult", "default_max_pivots"]

STATUSES = ("solved", "secondary ray", "pivot limit", "inaccurate", "warm start failed")
"""Possible `LCPResult.status` values ("inaccurate": a candidate failed the final check;
"warm start failed": a basis with cold_start=False that did not solve the LCP)."""

WARM_STARTS = ("none", "accepted", "crash", "crash+lemke", "lemke", "cold", "qp", "failed")
"""Possible `LCPResult.warm_start` values: "none" (q >= 0, or the textbook start without a
basis), "accepted" (the given basis solved it), "crash" (the crash guess, or block pivoting
from the given basis, solved it), "crash+lemke" (Lemke pivoted from the crash guess),
"lemke" (Lemke pivoted from the given basis), "cold" (a textbook start followed a failed
start), "qp" (the recovery's start from the convex QP), "failed" (cold_start=False)."""

DEFAULT_TOL = 1e-9
"""Default relative tolerance of the final check (see `lemke`)."""


def default_max_pivots(n: int) -> int:
    """Default pivot budget for an LCP of size n: 50 n + 100 + 2^min(n, 20).

    Contact LCPs need about n pivots; the 2^n term lets small LCPs with exponentially long
    Lemke paths (Murty's triangular examples: 2^n pivots) finish.
    """
    return 50 * n + 100 + 2 ** min(n, 20)


@dataclass
class LCPResult:
    """Outcome of `lemke`.

    z, w: (n,) arrays with w = M z + q (for "solved" a checked solution; otherwise the last
    iterate, z >= 0 but not a solution). pivots: number of basis exchanges (all runs,
    including a failed warm start). status: one of `STATUSES`. complementarity: max_i
    |z_i w_i| of the returned pair. basis: (n,) bool, True where z_i is basic at the end;
    pass it as ``basis=`` to a later call with the same M. message: human readable summary.
    warm_start: how the answer was started, one of `WARM_STARTS` ("none", "accepted",
    "crash", "crash+lemke", "lemke", "cold", "qp", "failed").
    """

    z: np.ndarray
    w: np.ndarray
    pivots: int
    status: str
    complementarity: float
    basis: np.ndarray
    message: str
    warm_start: str = "none"
    refactorizations: int = field(default=0)
    residual: float = 0.0
    """Largest relative violation of the final check (see `lemke`, tol); 0 for q >= 0."""

    @property
    def ok(self) -> bool:
        """True when status == "solved" (z passed the final check)."""
        return self.status == "solved"
