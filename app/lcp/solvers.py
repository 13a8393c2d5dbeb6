"""The registry of LCP solvers: a new solver is one module with a function of the
`LCPSolver` signature and one entry in LCP_SOLVERS. Lemke is the solver of record."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from app.errors import InputError
from app.lcp.lemke import lemke
from app.lcp.matrix_cache import MatrixCache
from app.lcp.result import LCPResult


class LCPSolver(Protocol):
    """Solve w = M z + q >= 0, z >= 0, z.w = 0 (M (n, n), q (n,)).

    basis: a warm-start complementary basis (n,) bool (True: z_i basic); cold_start: on
    a warm start that fails, start again cold (True) or return status "warm start failed"
    (False, so that the caller can try another basis). The result's `basis` is the final
    complementary basis, for the next warm start. cache: a `MatrixCache` made for this M
    (the caller solves many LCPs with it), where the solver may keep what it derives from
    M alone; a solver may ignore it, and must return the same answer either way.
    """

    def __call__(self, M: np.ndarray, q: np.ndarray, *, basis: np.ndarray | None = None,
                 max_pivots: int | None = None, cold_start: bool = True,
                 cache: MatrixCache | None = None) -> LCPResult: ...


LCP_SOLVERS: dict[str, LCPSolver] = {"lemke": lemke}
"""LCP solvers by `analysis.lcp_solver` name."""


def lcp_solver(name: str, where: str = "analysis.lcp_solver") -> LCPSolver:
    """The registered solver `name`, or a one-line InputError listing them."""
    try:
        return LCP_SOLVERS[name]
    except (KeyError, TypeError):
        raise InputError(f"{where} = {name!r}: use one of "
                         f"{', '.join(map(repr, LCP_SOLVERS))}") from None
