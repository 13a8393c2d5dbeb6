"""Lemke's complementary pivoting method for the linear complementarity problem (LCP).

LCP(M, q): given M (n x n, any matrix, not necessarily symmetric) and q (n,), find
z (n,) with

    z >= 0,   w = M z + q >= 0,   z_i w_i = 0 for every i.

`lemke` is the public solver; this module is its driver (scaling, starts, the final solve
and check). The package is split by concern:

- `app.lcp.result`: `LCPResult`, the statuses, the default pivot budget;
- `app.lcp.scaling`: the symmetric scaling and the dense helpers;
- `app.lcp.pivoting`: the pivoting rules shared by the two cores;
- `app.lcp.revised`: the revised core (the one `lemke` runs);
- `app.lcp.tableau`: the textbook full-tableau core (`lemke_tableau`, a slow reference);
- `app.lcp.crash`: the crash basis (block principal pivoting) for cold starts;
- `app.lcp.recovery`: the one recovery step after a run that ended "inaccurate" or on a
  secondary ray (restart from the final basis, `app.lcp.balance`, `app.lcp.repair`).

Conventions shared by both cores:

- Variables are numbered w_i -> i, z_i -> n + i, z0 -> 2 n. The basis system is
  ``I w - M z - d z0 = q`` with covering vector d (all ones after scaling for a cold start).
- Anti-cycling: lexicographic ratio test. Ties in the minimum ratio are broken by comparing
  the rows of ``B^-1 B0`` (B0 = starting basis) scaled by the pivot column; when z0 is among
  the tied rows it leaves (the run ends with a solution).
- The problem is first scaled symmetrically, ``M~ = D M D / mu``, ``q~ = D q / nu`` with D a
  positive diagonal of powers of two (Jacobi scaling, or the row/column maximum where the
  diagonal is too small), so pivot and tie tolerances are unit free (contact LCPs mix gap
  and force units). The LCP is invariant under this: z = (nu / mu) D z~, w = nu D^-1 w~.
- A run that ends with a candidate basis is never returned unchecked: z on the final basis is
  recomputed by a fresh dense solve (LU plus one refinement step), tiny negative entries
  are set to 0, w = M z + q is recomputed in the caller's units and checked (see `lemke`).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any, NamedTuple

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from app.lcp.check_product import CheckProduct
from app.lcp.crash import (
    PROBE_ROWS,
    block_solver,
    column_probe,
    crash_basis,
    find_twins,
    sampled_probe,
    twins_from_probe,
    verified_twins,
    warm_solve,
)
from app.lcp.matrix_cache import MatrixCache, for_matrix
from app.lcp.pivoting import _LEX_REL, _PIV_REL, _TIE_REL, _CoreOut, _lexmin  # noqa: F401
from app.lcp.recovery import RECOVERED, recover
from app.lcp.result import DEFAULT_TOL, STATUSES, LCPResult, default_max_pivots
from app.lcp.revised import (  # noqa: F401 (the knobs, for tests)
    _COMPACT_TERMS,
    _ILL_GAP,
    _REFINE_EVERY,
    _RES_REFACTOR,
    _core_revised,
    _Revised,
)
from app.lcp.scaling import RCOND_MIN as _RCOND_MIN  # noqa: F401
from app.lcp.scaling import ScaledM as _ScaledM
from app.lcp.scaling import absmax as _absmax
from app.lcp.scaling import diagonal_scaling, matrix_scaling, pow2, q_scaling
from app.lcp.scaling import lu_or_none as _lu_or_none  # noqa: F401
from app.lcp.scaling import row_blocks as _row_blocks
from app.lcp.tableau import _core_tableau

__all__ = ["LCPResult", "MatrixCache", "lemke", "lemke_tableau", "default_max_pivots",
           "STATUSES"]

_CHECK_ROWS = 32
"""Rows of M per block in the final check (a buffer that stays in cache)."""
_ROUND_MARGIN = 1e-8
"""Relative margin of the lower bound |q_i| + |w_i - q_i| of a row size in the final check
for the rounding of M z (n eps below it up to n = 4e7)."""
_SETTLE_REL = 1e-14
"""Rows of the final check whose violation is below this x the lower bound of their row
size pass without the row size (so `residual` stays a round-off figure)."""
_WARM_CRASH = 5
"""Block pivoting iterations tried from a warm-start basis that does not solve the LCP."""
_ABSMAX_KEEP = 4
"""The scalings D whose max |D M D| `_z_scale` keeps (the most recent): D depends on the
check's violating rows (`_floor_D`), so a run could add an entry of n x 8 bytes per
distinct set of them."""

_NEAR = 1e-6
"""A warm-start basis whose answer on a kept block solver (`_try_given`) fails the final
check by less than this relative violation is tried again with a fresh LU (the bordered
solve's round-off could be what fails); one that fails by more does not solve the LCP."""


def _memo(cache: MatrixCache | None, key: tuple, compute: Callable[[], Any],
          keep: int | None = None) -> Any:
    """compute(), kept in the cache under key when there is one (for this M); keep: see
    `MatrixCache.get`."""
    return compute() if cache is None else cache.get(key, compute, keep)


def _validate(M, q, sample: bool = False, cache: MatrixCache | None = None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """(M, q) as float arrays, the column probe of M (`app.lcp.crash.column_probe` with
    the diagonal scaling, one BLAS pass, which also shows any non-finite entry) and False;
    raises ValueError on bad shapes or non-finite data.

    sample (for a cold crash): when M is C-ordered, n > 2 PROBE_ROWS and some q_i < 0
    (with q >= 0 the answer z = 0 follows at once, so M is read whole), the probe reads
    PROBE_ROWS rows only (`sampled_probe`, enough for the twins), and the last value is
    True: M is then checked to be finite later, by the final check's product
    (`CheckProduct.finite`: a non-finite entry makes M z + q non-finite whatever z, since
    0 x inf and 0 x nan are nan), else by this function without sample, before any
    answer is returned or Lemke pivots. cache: M's `MatrixCache` (the probe and M's
    finiteness are kept; q is checked every time)."""
    if np.iscomplexobj(M) or np.iscomplexobj(q):  # (float() would drop the imaginary part)
        raise ValueError("M and q must be real (got complex entries)")
    if cache is None or M is not cache.M:  # (cache.M is float64: no new view of it)
        M = np.asarray(M, dtype=float)
    q = np.asarray(q, dtype=float)
    if q.ndim != 1 and not (q.ndim == 2 and q.shape[1] == 1):
        raise ValueError(f"q must be 1-D, shape (n,) or (n, 1), got shape {q.shape}")
    q = q.reshape(-1)
    n = q.size
    if M.shape != (n, n):
        raise ValueError(f"M must be ({n}, {n}) to match q of length {n}, got {M.shape}")
    # (q >= 0: z = 0 answers at once, after a full check of M anyway: no sampling)
    deferred = (sample and n > 2 * PROBE_ROWS and M.flags.c_contiguous
                and not (q >= 0).all())
    probe, finite = _memo(for_matrix(cache, M), ("probe", deferred),
                          lambda: _probe(M, deferred))
    if not (finite and np.isfinite(q).all()):
        raise ValueError("M and q must be finite")
    return M, q, probe, deferred


def _probe(M: np.ndarray, sampled: bool) -> tuple[np.ndarray, bool]:
    """The column probe of M (`sampled_probe` when sampled, else `column_probe`), with
    the diagonal scaling, and whether M is finite as far as it read (all of M when not
    sampled)."""
    if sampled:
        probe = sampled_probe(M, _diagonal_D(M))
    else:
        probe = column_probe(M, _diagonal_D(M)) if M.shape[0] else np.zeros((2, 0))
    return probe, bool(np.isfinite(probe).all() or np.isfinite(M).all())  # (overflow)


def _diagonal_D(M: np.ndarray) -> np.ndarray:
    """D of `diagonal_scaling` (1 / sqrt|M_ii| as powers of two)."""
    Ms, _, _ = diagonal_scaling(M, np.zeros(M.shape[0]))
    return Ms.D


def _check(M: np.ndarray, q: np.ndarray, z: np.ndarray, tol: float,
           w: np.ndarray | None = None, cache: MatrixCache | None = None):
    """w = M z + q and whether (z, w) passes the final check; returns (w, ok, comp, worst).
    w: M z + q formed by this expression already (`CheckProduct.w_for`), not formed again.
    cache: M's `MatrixCache` (the largest entry of the scaled M in the floor is kept).

    The row sizes s_i = |q_i| + sum_j |M_ij| z_j are formed only on the rows with a
    violation (w_i < 0, or w_i != 0 where z_i > 0) that their lower bound
    b_i = |q_i| + |w_i - q_i| <= s_i (less a margin for the rounding of M z) does not settle:
    a row with violation <= min(tol, _SETTLE_REL) b_i passes, and counts in `worst` with
    violation / b_i (a bound of its relative violation, at round-off level).

    The floor of s_i for rows whose terms cancel at round-off level is taken in the units
    of the diagonal scaling D (`_diagonal_D`), so that it does not grow with a column of M
    in other units than its z: 1e-4 max_j |M_ij| D_j x the z scale of `_z_scale` in those
    units (in unscaled units a 50% error of z passed where one column was 1e14 x the
    other).
    """
    w = M @ z + q if w is None else w
    neg = np.maximum(-w, 0.0)
    comp_res = np.where(z > 0, np.abs(w), 0.0)
    viol = np.maximum(neg, comp_res)
    bound = (np.abs(q) + np.abs(w - q)) * (1.0 - _ROUND_MARGIN)
    settled = (viol > 0) & (viol <= min(tol, _SETTLE_REL) * bound)
    worst_settled = float((viol[settled] / bound[settled]).max(initial=0.0))
    rows = np.flatnonzero((viol > 0) & ~settled)
    s = np.abs(q[rows])
    row_max = np.zeros(rows.size)  # max_j |M_ij| D_j
    D = _floor_D(M, rows) if rows.size else np.ones(0)
    buf = np.empty((min(_CHECK_ROWS, rows.size), q.size))  # one small buffer, reused
    for i0 in range(0, rows.size, _CHECK_ROWS):
        a = buf[: min(rows.size - i0, _CHECK_ROWS)]
        np.take(M, rows[i0:i0 + a.shape[0]], axis=0, out=a)
        np.abs(a, out=a)
        if z.any():
            s[i0:i0 + a.shape[0]] += a @ z
        a *= D
        row_max[i0:i0 + a.shape[0]] = a.max(axis=1) if a.size else 0.0
    # Floor for rows whose terms all cancel at round-off level (e.g. q_i = -1e-17 where the
    # rest of q is O(1)): 1e-4 x the row's largest coefficient x the problem's z scale, in
    # the units of the diagonal scaling (z = D z~).
    z_scale = _z_scale(M, q, z, row_max * D[rows], D, for_matrix(cache, M)) \
        if rows.size else 0.0
    s = np.maximum(s, 1e-4 * row_max * z_scale)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(viol[rows] > 0, viol[rows] / s, 0.0)
    worst = max(float(rel.max()) if rel.size else 0.0, worst_settled)
    if not (np.isfinite(z).all() and np.isfinite(w).all()):
        worst = math.inf  # z overflowed (e.g. M = [[1e-310]], q = -1): nan rows pass above
    ok = bool((z >= 0).all() and worst <= tol)
    comp = float(np.abs(z * w).max()) if z.size else 0.0
    return w, ok, comp, worst


def _floor_D(M: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """D of `_diagonal_D`, except for columns j whose diagonal is below 1e-6 of their
    largest entry in the rows `rows` (the same test as `scaling`, on those rows): there
    1 / sqrt of that entry. A round-off diagonal (a floating body's mode column of the
    contact LCP, 2e-28 where it is 0 in exact arithmetic) made D_j 7e13 and the floor of
    `_check` 5e12, so that a warm-start basis with w = -0.09 passed as solved (a load
    step penetrating by 5e-4 on a scene turned by 90 deg)."""
    D = _diagonal_D(M)
    cmax = np.zeros(M.shape[1])
    for i0 in range(0, rows.size, _CHECK_ROWS):
        np.maximum(cmax, np.abs(M[rows[i0:i0 + _CHECK_ROWS]]).max(axis=0), out=cmax)
    tiny = np.abs(np.diagonal(M)) < 1e-6 * cmax
    if tiny.any():
        D[tiny] = pow2(1.0 / np.sqrt(cmax[tiny]))
    return D


def _z_scale(M: np.ndarray, q: np.ndarray, z: np.ndarray, row_max: np.ndarray,
             D: np.ndarray, cache: MatrixCache | None = None) -> float:
    """max(max z~, max |q~| / max |M~|) in the diagonal scaling (M~ = D M D, q~ = D q,
    z = D z~); max |M~| is read from M (one pass, kept in the cache for this D) only when
    the largest row maximum already known (row_max, of M~; the diagonal) does not settle
    it."""
    z_max = float((z / D).max(initial=0.0))
    q_max = float(np.abs(D * q).max(initial=0.0))
    known = max(float(row_max.max(initial=0.0)), float((np.abs(np.diagonal(M)) * D * D).max()))
    if known > 0 and q_max / known <= z_max:
        return z_max  # max |M~| >= known, so max |q~| / max |M~| <= z_max
    m_max = _memo(cache, ("absmax", D.tobytes()), lambda: max(
        (float(_absmax(D[i0:i1, None] * M[i0:i1] * D)) for i0, i1 in _row_blocks(q.size)),
        default=0.0), keep=_ABSMAX_KEEP)
    return max(z_max, q_max / m_max if m_max > 0 else 0.0)


def _solve_on(Ms: _ScaledM, qs: np.ndarray, zset: np.ndarray) -> np.ndarray | None:
    """z~ with z~_Z = -M~_ZZ^-1 q~_Z (LU + one refinement), 0 elsewhere; None if singular."""
    n = qs.size
    Z = np.flatnonzero(zset)
    zt = np.zeros(n)
    if Z.size == 0:
        return zt
    A = Ms.sub(Z)
    lu = _lu_or_none(A)
    if lu is None:
        return None
    x = sla.lu_solve(lu, -qs[Z], check_finite=False)
    x -= sla.lu_solve(lu, A @ x + qs[Z], check_finite=False)
    if not np.isfinite(x).all():
        return None
    zt[Z] = x
    return zt


class _Problem:
    """Caller data, its scaled copy (formed on first use) and the final solve + check.
    cache: M's `MatrixCache` or None (the scaling, twins and LU factors are kept)."""

    def __init__(self, M: np.ndarray, q: np.ndarray, tol: float,
                 cache: MatrixCache | None = None):
        self.M, self.q, self.tol, self.cache = M, q, tol, for_matrix(cache, M)
        self._scaled = None

    def _scale(self):
        if self._scaled is None:  # `app.lcp.scaling.scaling`, D and mu kept
            D, mu = _memo(self.cache, ("scaling",), lambda: matrix_scaling(self.M))
            nu = q_scaling(D, self.q)
            self._scaled = (_ScaledM(self.M, D, mu), D * self.q / nu, D * (nu / mu))
        return self._scaled  # z = zfac * z~

    Ms = property(lambda self: self._scale()[0])
    qs = property(lambda self: self._scale()[1])
    zfac = property(lambda self: self._scale()[2])

    @property
    def twins(self) -> np.ndarray:
        """`app.lcp.crash.find_twins` of the scaled M."""
        return _memo(self.cache, ("twins",), lambda: find_twins(self.Ms))

    @property
    def block_solver(self):
        """The cache's block solver of the scaled M (`app.lcp.crash.block_solver`), or
        None without a cache."""
        if self.cache is None:
            return None
        return self.cache.get(("block_solver",), lambda: block_solver(self.Ms))

    def solve_on(self, zset: np.ndarray) -> np.ndarray | None:
        """`_solve_on` for the scaled LCP."""
        return _solve_on(self.Ms, self.qs, zset)

    def finish(self, zt: np.ndarray | None, zfac: np.ndarray | None = None,
               exact: CheckProduct | None = None):
        """Unscale (z = zfac * zt, by default the scaling's), clip, check (with exact's
        product when it was formed for this z). Returns (z, w, ok, comp, worst), or None
        if zt is None."""
        if zt is None:
            return None
        z = np.maximum(zt * (self.zfac if zfac is None else zfac), 0.0)
        w = None if exact is None else exact.w_for(z)
        w, ok, comp, worst = _check(self.M, self.q, z, self.tol, w, self.cache)
        return z, w, ok, comp, worst

    def candidate(self, core: _CoreOut):
        """Best checked answer from a core that reported a candidate basis."""
        first = self.finish(self.solve_on(core.zset))
        if first is not None and first[2]:
            return first
        second = self.finish(core.z)
        if second[2] or first is None:
            return second
        return first if first[4] <= second[4] else second


def _try_basis(P: _Problem, B0: np.ndarray, zt: np.ndarray | None = None,
               zfac: np.ndarray | None = None, exact: CheckProduct | None = None):
    """The checked answer on the complementary basis B0 (z_B = -M_BB^-1 q_B, one LU and one
    refinement step), or None when B0 is singular or its answer fails the check. This is
    exactly what a Lemke run from B0 that needs no pivot returns. zt: z~ on B0 already
    computed (e.g. by the crash; z = zfac * zt), tried first, checked with exact's
    product when that was formed for it."""
    if zt is not None:
        out = P.finish(zt, zfac, exact)
        if out[2]:
            return out
    out = P.finish(P.solve_on(B0))
    return out if out is not None and out[2] else None


def _try_given(P: _Problem, B0: np.ndarray):
    """`_try_basis` for a warm-start basis B0: with a cache, z on B0 from its kept block
    solver first (`app.lcp.crash.warm_solve`: no factorization when B0 is a few indices
    from its base block, e.g. the last solve's basis); the fresh LU of `_try_basis` only
    when that has no answer, or one that fails the check by less than _NEAR."""
    solver = P.block_solver
    if solver is not None:
        zt = warm_solve(solver, P.qs, B0)
        out = P.finish(zt)
        if out is not None and (out[2] or out[4] > _NEAR):
            return out if out[2] else None
    return _try_basis(P, B0)


class _Start(NamedTuple):
    """A start basis for Lemke: B0 (n,) bool (z_i basic), z~ on it already computed (zt, z =
    zfac * zt, checked with exact's product) or None, and the note that opens the message."""

    B0: np.ndarray
    zt: np.ndarray | None = None
    zfac: np.ndarray | None = None
    exact: CheckProduct | None = None
    note: str = ""


def _run(
    core,
    M,
    q,
    max_pivots: int | None,
    tol: float | None,
    basis,
    cold_start: bool = True,
    crash: bool = True,
    cache: MatrixCache | None = None,
) -> LCPResult:
    """One solve (see `lemke`): z = 0 when q >= 0, else Lemke from the warm-start basis or
    the crash guess (`_from_start`), and from the textbook start when that fails.

    An empty warm-start basis (z = 0, e.g. the last load step had every pair open) names
    the textbook start itself, so with crash it is treated as no basis: the crash guess.
    cache: a `MatrixCache`, used when it was made for this M (see `lemke`)."""
    if basis is not None and crash and not np.asarray(basis, dtype=bool).any():
        _given_basis(basis, np.asarray(q).size)  # (its shape is still checked)
        basis = None
    M, q, probe, deferred = _validate(M, q, sample=basis is None and crash, cache=cache)
    cache = for_matrix(cache, M)
    n = q.size
    tol, max_pivots = _checked_knobs(tol, max_pivots, n)
    if basis is not None:
        _given_basis(basis, n)  # a wrong shape is an error whatever q (q >= 0 ignored it)
    if (q >= 0).all():  # M was checked whole by _validate (no sampling when q >= 0)
        return LCPResult(np.zeros(n), q.copy(), 0, "solved", 0.0, np.zeros(n, dtype=bool),
                         "q >= 0: z = 0 solves it")
    P = _Problem(M, q, tol, cache)
    given = basis is not None
    start = None
    if given:
        start = _Start(_given_basis(basis, n))
    elif crash:
        start = _crash_start(M, q, probe, deferred, cache)
    if start is None or not start.B0.any():
        note = "" if start is None else start.note
        return _cold(core, P, M, q, tol, max_pivots, 0, 0, note, "none")
    out = _from_start(core, P, start, given, crash, cold_start, max_pivots)
    if isinstance(out, LCPResult):
        return out
    pivots, refacts, note = out
    return _cold(core, P, M, q, tol, max_pivots, pivots, refacts, note, "cold")


def _checked_knobs(tol: float | None, max_pivots: int | None, n: int) -> tuple[float, int]:
    """(tol, max_pivots) with their defaults (DEFAULT_TOL, `default_max_pivots(n)`);
    ValueError for a tol that is not positive and finite."""
    tol = DEFAULT_TOL if tol is None else float(tol)
    if not tol > 0 or not np.isfinite(tol):
        raise ValueError(f"tol must be a positive finite number, got {tol!r}")
    return tol, default_max_pivots(n) if max_pivots is None else int(max_pivots)


def _given_basis(basis, n: int) -> np.ndarray:
    """The warm-start basis as (n,) bool; ValueError on another shape, or on entries
    other than True/False (or 1/0)."""
    raw = np.asarray(basis)
    if raw.dtype != bool and not (raw.dtype.kind in "iuf" and np.isin(raw, (0, 1)).all()):
        raise ValueError("basis must be an (n,) bool array (True where z_i is basic), got "
                         f"dtype {raw.dtype} with entries other than True/False")
    B0 = raw.astype(bool).reshape(-1)
    if B0.shape != (n,):
        raise ValueError(f"basis must have shape ({n},), got {B0.shape}")
    return B0


def _crash_start(M: np.ndarray, q: np.ndarray, probe: np.ndarray, deferred: bool,
                 cache: MatrixCache | None = None) -> _Start:
    """The crash guess (`app.lcp.crash.crash_basis`) on the diagonal scaling: no pass over M
    beyond the probe (and the final check's product, formed in its last round). deferred:
    M is not yet known to be finite (see `_validate`); it is, before this returns."""
    Mc, qc, zfac = diagonal_scaling(M, q)
    exact = CheckProduct(M, q, Mc.D, zfac)  # the last round's product, the check's
    twin = twins_from_probe(probe)
    if deferred:
        twin = verified_twins(M, twin)
    quiet = np.errstate(all="ignore") if deferred else contextlib.nullcontext()
    with quiet:  # a non-finite M is reported below, not by warnings of the guess
        B0, iters, zt = crash_basis(Mc, qc, twin=twin, exact=exact)
    if deferred and not exact.finite:
        _validate(M, q, cache=cache)  # every entry of M, before an answer or a pivot
    return _Start(B0, zt, zfac, exact, f"crash basis ({iters} block pivoting iterations); ")


def _from_start(core, P: _Problem, start: _Start, given: bool, crash: bool, cold_start: bool,
                max_pivots: int) -> LCPResult | tuple[int, int, str]:
    """The checked answer from a start basis B0 (warm start if given, else the crash
    guess): on B0 itself, else (given and crash) on the basis of a few block pivoting
    iterations from it, else by Lemke from B0. When all fail: the result of a warm start
    without cold_start, else (pivots, refactorizations, note so far) for the cold start."""
    B0 = start.B0
    sol = _try_given(P, B0) if given else _try_basis(P, B0, start.zt, start.zfac, start.exact)
    if sol is not None:
        z, w, ok, comp, worst = sol
        msg = ("the warm-start basis solves it" if given
               else f"{start.note}the crash basis solves it")
        how = "accepted" if given else "crash"
        return LCPResult(z, w, 0, "solved", comp, B0.copy(), msg, how, 0, worst)
    if given and crash:  # block pivoting from the warm-start basis, then its check
        res = _warm_crash(P, B0)
        if res is not None:
            return res
    # covering vector B0 @ 1: Lemke on the LCP transformed by the pivot on B0
    d = -P.Ms.matvec(B0.astype(float))
    d[~B0] += 1.0
    res = core(P.Ms, P.qs, d, B0, max_pivots)
    pivots, refacts = res.pivots, res.refactorizations
    note = start.note
    run = "warm start" if given else "the run from the crash basis"
    if res.status == "solved":
        z, w, ok, comp, worst = P.candidate(res)
        if ok:
            msg = (f"{note}solved from the {'warm-start' if given else 'crash'} basis "
                   f"in {pivots} pivots")
            return LCPResult(z, w, pivots, "solved", comp, res.zset.copy(), msg,
                             "lemke" if given else "crash+lemke", refacts, worst)
        # (before: "ended with 'solved'", then a failure: it reached a basis, not a solution)
        note += (f"{run} reached a complementary basis after {res.pivots} pivots but its "
                 f"solution failed the check (worst relative violation {worst:.3g}); ")
    else:
        note += f"{run} ended with '{res.status}' after {res.pivots} pivots; "
    if given and not cold_start:
        z = np.maximum(res.z * P.zfac, 0.0)
        w, _, comp, worst = _check(P.M, P.q, z, P.tol, cache=P.cache)
        return LCPResult(z, w, pivots, "warm start failed", comp, res.zset.copy(),
                         note + "no cold start (cold_start=False)", "failed", refacts, worst)
    return pivots, refacts, note


def _warm_crash(P: _Problem, B0: np.ndarray) -> LCPResult | None:
    """The answer on the basis that _WARM_CRASH block pivoting iterations from the
    warm-start basis B0 reach, when it passes the check; else None."""
    B1, iters, zt = crash_basis(P.Ms, P.qs, twin=P.twins, start=B0,
                                max_iterations=_WARM_CRASH, solver=P.block_solver)
    sol = _try_basis(P, B1, zt) if zt is not None else None
    if sol is None:
        return None
    z, w, ok, comp, worst = sol
    msg = (f"solved on the basis found by {iters} block pivoting iterations from "
           "the warm-start basis")
    return LCPResult(z, w, 0, "solved", comp, B1.copy(), msg, "crash", 0, worst)


def _cold(core, P: _Problem, M, q, tol: float, max_pivots: int, pivots: int, refacts: int,
          note: str, warm: str) -> LCPResult:
    """Lemke from the textbook start (covering vector 1) with the pivots left, after any
    warm or crash start (`pivots`, `refacts` and `note` so far); the checked result."""
    n = q.size
    res = core(P.Ms, P.qs, np.ones(n), np.zeros(n, dtype=bool), max(max_pivots - pivots, 0))
    pivots += res.pivots
    refacts += res.refactorizations
    if res.status == "solved":
        z, w, ok, comp, worst = P.candidate(res)
        if ok:
            msg = f"{note}solved in {pivots} pivots"
            return LCPResult(z, w, pivots, "solved", comp, res.zset.copy(), msg, warm, refacts,
                             worst)
        msg = (
            f"{note}Lemke ended on a complementary basis after {pivots} pivots but the "
            f"solution fails the check (worst relative violation {worst:.3g} > tol {tol:.3g})"
        )
        return LCPResult(z, w, pivots, "inaccurate", comp, res.zset.copy(), msg, warm, refacts,
                         worst)
    z = np.maximum(res.z * P.zfac, 0.0)
    w, _, comp, worst = _check(M, q, z, tol, cache=P.cache)
    if res.status == "secondary ray":
        status = "secondary ray"
        msg = (
            f"{note}secondary ray after {pivots} pivots: no solution was found from this start "
            "(the artificial variable z0 could not be driven to 0); for contact this means no "
            "static equilibrium"
        )
    elif res.status == "singular":
        status = "inaccurate"
        msg = (f"{note}then the cold start's basis became numerically singular "
               f"({pivots} pivots in all)" if note else
               f"the basis became numerically singular after {pivots} pivots")
    else:
        status = "pivot limit"
        msg = f"{note}pivot limit ({max_pivots}) reached; z, w are the last iterate"
    return LCPResult(z, w, pivots, status, comp, res.zset.copy(), msg, warm, refacts, worst)


def _solve(core, M, q, max_pivots, tol, basis, cold_start, crash,
           cache: MatrixCache | None = None) -> LCPResult:
    """`_run`, then, when it ended "inaccurate" or on a secondary ray, the one recovery step
    of `app.lcp.recovery.recover` (restart from the final basis, the balanced LCP, the
    basis repair; the first result stands when every one fails). cache: `lemke`'s (it
    serves every run on the caller's M, none on a balanced copy)."""
    if sp.issparse(M):  # a dense solver: densified once here
        M = M.toarray()
    if max_pivots is not None and (isinstance(max_pivots, bool | np.bool_)
                                   or not isinstance(max_pivots, int | np.integer)
                                   or max_pivots < 0):
        raise ValueError(f"max_pivots must be an integer >= 0 or None, got {max_pivots!r}")
    if cache is not None and cache.M is not M:
        raise ValueError("cache: this MatrixCache was made for another matrix (pass the "
                         "array it was made for, or a new MatrixCache(M))")
    res = _run(core, M, q, max_pivots, tol, basis, cold_start, crash, cache)
    if res.ok or res.status not in RECOVERED:
        return res
    M, q, _, _ = _validate(M, q, cache=cache)
    tol = DEFAULT_TOL if tol is None else float(tol)

    def run(Mr, qr, budget, B, cold, crash_r):
        return _run(core, Mr, qr, budget, tol, B, cold, crash_r, cache)

    def check(Mr, qr, z):
        return _check(Mr, qr, z, tol, cache=cache)

    return recover(run, check, M, q, res, max_pivots, crash)


def lemke(
    M: np.ndarray,
    q: np.ndarray,
    *,
    max_pivots: int | None = None,
    tol: float | None = None,
    basis: np.ndarray | None = None,
    cold_start: bool = True,
    crash: bool = True,
    cache: MatrixCache | None = None,
) -> LCPResult:
    """Solve LCP(M, q): z >= 0, w = M z + q >= 0, z.w = 0, by Lemke's method.

    M: (n, n) real array (need not be symmetric; a scipy.sparse matrix is densified);
        q: (n,) or (n, 1), real. Another shape, complex or non-finite entries: ValueError.
    max_pivots: an integer >= 0 (else ValueError), the pivot budget, default
        `default_max_pivots(n)` (50 n + 100 + 2^min(n, 20)); when it is used up the
        status is "pivot limit" and z, w are the last iterate.
    tol: relative tolerance of the final check, default 1e-9 (positive and finite, else
        ValueError). With the row sizes
        s_i = |q_i| + sum_j |M_ij| z_j (the size of the terms that make w_i), a returned
        "solved" pair satisfies z >= 0 exactly, w_i >= -tol s_i, and |w_i| <= tol s_i
        wherever z_i > 0 (so |z_i w_i| <= tol z_i s_i). The check is per row, so it is
        independent of the units of each row (e.g. gaps and forces in one LCP). Except:
        s_i is at least 1e-4 x the row's largest coefficient x the z scale, both in the
        diagonal scaling's units, so that a row whose terms cancel at round-off level
        passes; a q_i that small against the rest of the scaled LCP (e.g. 1e-15 x the
        others where M_ii differs by 1e30) may so be left violated. z and w are finite.
    basis: optional (n,) bool warm start (0/1 accepted, other values a ValueError), True
        where z_i is guessed basic (for example `LCPResult.basis` of a previous call with
        the same M and a nearby q). If the complementary basis it names is feasible
        (z_B = -M_BB^-1 q_B >= 0, w >= 0, checked)
        the answer comes back with 0 pivots. Otherwise Lemke runs from that basis (the
        principal pivot transform of the LCP on B, covering vector 1 in transformed
        variables); if that fails (singular M_BB, secondary ray, pivot limit) a cold start
        follows. Pivots of all runs are counted.
    crash: with a basis that does not solve the LCP, first a few block principal pivoting
        iterations from it (warm_start "crash" when they end on the answer); without a
        basis, guess one by block principal pivoting (`app.lcp.crash`) and start from it
        as from a warm start (warm_start "crash" when the guess solves it,
        "crash+lemke" when Lemke finished from it, "cold" when that failed and a cold start
        followed). False: the textbook cold start (covering vector 1).
    cold_start: with a basis, False returns at once when the warm start fails (status
        "warm start failed", warm_start "failed") instead of starting cold, so that a
        caller can try another basis first.
    cache: a `MatrixCache(M)` made for this very array M (ValueError otherwise), for a
        caller that solves many LCPs with one M (e.g. a load step's debonding rounds):
        what depends on M alone (its check for finite entries, the scaling, the twins)
        is kept in it between calls instead of read from M again, and a warm-start basis
        and the block pivoting from it are solved on a kept factorization of a nearby
        basis block, bordered (`app.lcp.matrix_cache`): answers the same to round-off,
        checked as always. `MatrixCache` makes M read-only.

    Returns an `LCPResult`. "solved" only after the check above passes (z on the final
    basis is recomputed by a fresh LU solve); "secondary ray": no solution was found from
    this start (for a copositive-plus M, e.g. positive semidefinite, there is none; for
    contact: no static equilibrium); "inaccurate": a candidate failed the check. A run that
    ends "inaccurate" or on a secondary ray goes through one recovery step
    (`app.lcp.recovery`, in this order: warm starts from its final basis; the LCP solved
    again with rows and columns balanced, when their units differ widely; for a symmetric
    M, a warm start from the positive set of the convex QP, warm_start "qp"); pivots
    count every attempt.
    q >= 0 returns z = 0 with 0 pivots.
    """
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        res = _solve(_core_revised, M, q, max_pivots, tol, basis, cold_start, crash, cache)
    return _finite(res, q)


def _finite(res: LCPResult, q) -> LCPResult:
    """`res`, or, when its z or w is not finite (a solution beyond the float range: M and q
    finite but, e.g., M = [[1e-310]], q = [-1]), the pair z = 0, w = q with an empty basis
    and status "inaccurate", its message saying why: `lemke` promises finite z and w."""
    if np.isfinite(res.z).all() and np.isfinite(res.w).all():
        return res
    z = np.zeros_like(res.z)
    w = np.array(q, dtype=float).reshape(z.shape)
    msg = ("the answer overflows the float range (z or w not finite): rescale M and q "
           "(their units) so that z stays below 1e308; " + res.message)
    return replace(res, z=z, w=w, status="inaccurate", complementarity=0.0,
                   basis=np.zeros(z.shape, dtype=bool),
                   residual=float((w < 0).any()), message=msg)  # w_i = q_i < 0: 1


def lemke_tableau(
    M: np.ndarray,
    q: np.ndarray,
    *,
    max_pivots: int | None = None,
    tol: float | None = None,
    basis: np.ndarray | None = None,
    cold_start: bool = True,
    crash: bool = True,
    cache: MatrixCache | None = None,
) -> LCPResult:
    """Reference: `lemke` with the textbook full-tableau core (O(n^2) per pivot; the same
    arguments, starts, check and recovery; for tests, the checker and benchmarks)."""
    return _solve(_core_tableau, M, q, max_pivots, tol, basis, cold_start, crash, cache)


_lemke_tableau = lemke_tableau  # the former private name (tests and scripts use it)
