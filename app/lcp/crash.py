"""Crash basis for Lemke: a cheap guess of the active set, handed to Lemke as a warm start.

A cold Lemke run adds about one basic variable per pivot, so an LCP whose answer has k
positive z's costs at least k pivots of O(n k) each. A crash guesses the answer's active
set Z (z_i > 0) by block principal pivoting (Kostreva; Judice and Pires): solve
``M_ZZ z_Z = -q_Z``, then move every infeasible index at once (z_i < 0 leaves Z, w_i < 0
joins Z), and repeat. Each iteration is one solve with the current block; after the first
LU the changed indices are handled by a bordered Schur complement on the LU of the base
block (a few triangular solves per changed index), and the base is refactorised only
when many indices changed. Columns that are exact negatives of each other ("twins", e.g.
the forward and backward slips of one contact pair) never enter together (that block
would be singular).

The crash is only a guess: `lemke` checks the answer on the guessed basis and, when it is
not a solution, runs Lemke from it. Everything here works on the scaled LCP (`_ScaledM`).
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla

from app.lcp.check_product import CheckProduct
from app.lcp.scaling import ScaledM, gather
from app.lcp.slip_guess import slip_guess

DEEP_START = 0.5
"""A cold crash starts from the q~_i below this x min q~ (for contact: the deeper half of
the penetrations; most shallow ones open once the deep ones carry load, and block pivoting
adds those that do not)."""
MAX_ITERATIONS = 30
"""Block pivoting iterations before the best set so far is handed to Lemke."""
_MAX_RUNS = 4
"""Most column ranges of a `_TwinProduct`."""
PIVOT_MIN = 1e-13
"""A block whose LU has a pivot below this x its largest counts as singular."""
GROWTH_MAX = 1e10
"""A converged z~ larger than this x max |q~| is not returned (see crash_basis)."""
_GATHER_FLOPS = 60.0
"""Cost of gathering one entry of M (fancy indexing) in flops of an LU, for the choice
between a new factorization and bordered updates (measured at n = 1500, one thread:
about 2.5 ns an entry against 40 ps a flop of the LU of the 463 x 463 block)."""
_SMALL_BLAS = 250.0
"""A flop of the solves and products of a bordered update on a base block of k0 indices
costs 1 + _SMALL_BLAS / max(k0, 250) flops of an LU (thin BLAS-3 calls run slower than an
LU, more so on small blocks; below a few hundred indices both ways cost mostly call
overhead). Measured with one thread at the whole LCP's first round of the bench_lemke
LCPs (M read from memory): bordering 87 new indices on the 375 x 375 Cholesky factor of
the twins' stage took 3.3-4.3 ms against 3.9-5.4 ms for gathering and factorizing the
463 x 463 block (n = 1500), and 162 on a 747 x 747 one 15 ms against 25 ms for the
916 x 916 block (n = 3000)."""
_FEAS_REL = 1e-12
"""z_i or w_i counts as negative below -this x max(1, max |z|) (scaled units)."""
EXACT_AFTER = 8
"""A round on the whole LCP that follows one with at most this many infeasible indices is
expected to be the last: its product is the final check's (`CheckProduct`), a whole pass
over M instead of the two thirds that `_TwinProduct` reads, and the check does not
repeat it. (A round that then does not end costs a third of a pass more.)"""


TWIN_SEED = 20261123
"""Seed of the random row weights that find twins (fixed: repeatable guesses)."""


_WEIGHTS = np.zeros(0)


def _weights(n: int) -> np.ndarray:
    """n fixed random weights (standard normal, seed TWIN_SEED; drawn once, a view)."""
    global _WEIGHTS
    if _WEIGHTS.size < n:
        _WEIGHTS = np.random.default_rng(TWIN_SEED).standard_normal(max(n, 2 * _WEIGHTS.size))
        _WEIGHTS.flags.writeable = False
    return _WEIGHTS[:n]


def column_probe(M: np.ndarray, D: np.ndarray, rows: slice | None = None) -> np.ndarray:
    """(1, n) sums of the columns of D M D with random row weights r: (r D) M D, one BLAS
    pass over M (over the rows `rows` of M only, when given). Negated columns have negated
    sums (`twins_from_probe`); a non-finite entry of the rows read makes its column's sum
    non-finite."""
    Dr = D if rows is None else D[rows]
    Mr = M if rows is None else M[rows]
    r = _weights(Dr.size)
    with np.errstate(over="ignore", invalid="ignore"):
        return (((r * Dr) @ Mr) * D)[None, :]


PROBE_ROWS = 128
"""Rows of M read by `sampled_probe` (when n > 2 x this)."""


def probe_rows(n: int) -> slice:
    """The rows of `sampled_probe`: PROBE_ROWS rows evenly spaced over 0..n (n >= PROBE_ROWS),
    a strided view of M (no copy)."""
    step = n // PROBE_ROWS
    return slice(step // 2, step // 2 + step * PROBE_ROWS, step)


def sampled_probe(M: np.ndarray, D: np.ndarray) -> np.ndarray:
    """`column_probe` over the PROBE_ROWS rows `probe_rows` of M only: the column sums that
    find twins (`twins_from_probe`, then `verified_twins`) for a twelfth of a pass over M
    at n = 1500. It does not see every entry: the caller checks that M is finite
    otherwise (see `app.lcp.lemke._validate`)."""
    return column_probe(M, D, probe_rows(D.size))


def verified_twins(M: np.ndarray, twin: np.ndarray) -> np.ndarray:
    """Twins (from a sampled probe) kept only where M[i, i] = -M[i, j] and
    M[j, j] = -M[j, i] exactly (j = twin i): columns that are negatives of each other
    except in their own rows, e.g. twins with a regularized diagonal, which rows sampled
    elsewhere would take for twins. Other false twins only cost speed: the crash's guess
    is then off, never the checked answer."""
    i = np.flatnonzero(twin >= 0)
    j = twin[i]
    bad = (M[i, i] != -M[i, j]) | (M[j, j] != -M[j, i])
    out = twin.copy()
    out[i[bad]] = -1
    out[j[bad]] = -1
    return out


def find_twins(Ms: ScaledM) -> np.ndarray:
    """(n,) index of the column that is the negative of column i, or -1.

    Found from two products R^T M~ with random R (negated columns have negated sums); a
    false match would only keep two indices apart in the guess, never change an answer.
    """
    return twins_from_probe(column_probe(Ms.M, Ms.D))


def twins_from_probe(s: np.ndarray) -> np.ndarray:
    """Twins (see `find_twins`) from column sums s (k, n) with independent random weights
    (`column_probe`): columns i, j are twins when s[:, i] = -s[:, j] to 1e-12."""
    n = s.shape[1]
    twin = np.full(n, -1, dtype=np.int64)
    if n < 2 or not np.isfinite(s).all():
        return twin
    order = np.argsort(np.abs(s[0]), kind="stable")
    so = s[:, order]
    close = ((np.abs(so[:, 1:] + so[:, :-1]) <= 1e-12 * np.abs(so[:, 1:])).all(axis=0)
             & (so[0, 1:] != 0.0) & (np.sign(so[0, 1:]) != np.sign(so[0, :-1])))
    # pair k joins order[k] and order[k + 1]; in a run of consecutive close pairs, taking
    # them in turn where both are still free keeps every other one, from the run's first
    k = np.flatnonzero(close)
    if k.size:
        first = np.r_[True, np.diff(k) != 1]
        k = k[(k - k[first][np.cumsum(first) - 1]) % 2 == 0]
        i, j = order[k], order[k + 1]
        twin[i], twin[j] = j, i
    return twin


class _Factor:
    """Factors of a square block: Cholesky when it is symmetric positive definite (half the
    flops of an LU), else LU with partial pivoting. Both factor A^T (the Fortran-order view
    of a C-order A) in place: no copy of the block. dinv: the block is diag(1 / dinv) B
    diag(1 / dinv) and these are the factors of B (see `_factor`)."""

    def __init__(self, f, cholesky: bool, dinv: np.ndarray | None = None):
        self.f, self.cholesky, self.dinv = f, cholesky, dinv

    def solve(self, b: np.ndarray, overwrite: bool = False) -> np.ndarray:
        """A^-1 b; overwrite: b may be overwritten (no copy when it is in Fortran order)."""
        if self.dinv is not None:  # A^-1 b = dinv B^-1 (dinv b): exact powers of two
            s = self.dinv[:, None] if b.ndim == 2 else self.dinv
            b, overwrite = b * s, True
        if self.cholesky:
            x = sla.cho_solve(self.f, b, overwrite_b=overwrite, check_finite=False)
        else:
            x = sla.lu_solve(self.f, b, trans=1, overwrite_b=overwrite,  # (A^T)^T x = b
                             check_finite=False)
        if self.dinv is not None:
            x *= s
        return x


def _factor(A: np.ndarray, cholesky: bool = False,
            d: np.ndarray | None = None) -> _Factor | None:
    """Factors of square C-order A (overwritten), or None when a pivot is not finite or
    below PIVOT_MIN x the largest (numerically singular). Cheaper than the condition
    estimate of `app.lcp.scaling.lu_or_none` (about a fifth of the LU at n = 2000); enough
    for a guess, since the answer on the guessed set is checked. cholesky: try Cholesky
    first when A is symmetric.

    d: A is unscaled and the block to factor is diag(d) A diag(d), d powers of two. Its
    Cholesky factor is diag(d) L with L that of A, to the bit (every rounding scales
    exactly), so A is factorized as it is, without the two scaling passes, and the solves
    scale their right-hand sides (`_Factor`); when that fails, the LU gets the scaled
    block, as without d."""
    At = np.ascontiguousarray(A).T  # Fortran order: LAPACK works in place
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        if cholesky and _symmetric(A, d):
            dg = np.diagonal(At).copy()
            try:  # the lower factor: about a quarter faster than the upper one here
                c = sla.cho_factor(At, lower=True, overwrite_a=True, check_finite=False)
                dd = np.diagonal(c[0]) ** 2 * (1.0 if d is None else d * d)
                if np.isfinite(dd).all() and dd.min() >= PIVOT_MIN * dd.max() > 0:
                    return _Factor(c, True, None if d is None else 1.0 / d)
            except np.linalg.LinAlgError:
                pass
            # Cholesky wrote only the lower triangle: restore it from the upper one
            il = np.tril_indices(dg.size, -1)
            At[il] = At.T[il]
            np.fill_diagonal(At, dg)
        if d is not None:  # the LU factorizes the scaled block
            At *= d[:, None]
            At *= d
        try:
            lu = sla.lu_factor(At, overwrite_a=True, check_finite=False)
        except (ValueError, np.linalg.LinAlgError):
            return None
    d = np.abs(np.diagonal(lu[0]))
    ok = np.isfinite(d).all() and d.min() >= PIVOT_MIN * d.max() > 0
    return _Factor(lu, False) if ok else None


def _symmetric(A: np.ndarray, d: np.ndarray | None = None) -> bool:
    """A = A^T to round-off, tested on a few entries, then on one random vector v
    (A v = A^T v): two BLAS passes instead of a strided comparison of A with A^T. A block
    that is only nearly symmetric gets a Cholesky factor of its upper triangle: the guess
    is then a little off, never the checked answer. d: test diag(d) A diag(d) (powers of
    two: the same products to the bit, formed without scaling A)."""
    k = A.shape[0]
    i = np.arange(0, k, max(k // 16, 1))
    j = i[::-1]
    if not np.array_equal(A[i, j], A[j, i]):
        return False
    v = _weights(k)
    if d is None:
        a, b = A @ v, v @ A
    else:
        dv = d * v
        a, b = d * (A @ dv), d * (dv @ A)
    return bool(np.abs(a - b).max() <= 1e-12 * max(np.abs(a).max(), np.abs(b).max()))


class _BlockSolver:
    """Solves M~[Z, Z] x = b for a changing set Z.

    With the LU of a base block A0 = M~[Z0, Z0], a set Z = Z0 - R + A is solved through the
    bordered system [[A0, M~[Z0, A], E_R], [M~[A, Z0], M~[A, A], 0], [E_R^T, 0, 0]] (E_R
    frees the rows R and fixes x_R = 0): its Schur complement S = C - V A0^-1 U on the
    changed indices, then one small dense solve. Every index changed since the last
    factorization keeps its column A0^-1 u, row v and entries of S, so an iteration costs
    base-LU solves only for the indices that changed for the first time.
    """

    def __init__(self, Ms: ScaledM, qs: np.ndarray):
        self.Ms, self.qs = Ms, qs
        self.base = np.zeros(0, dtype=np.int64)
        self.in_base = np.zeros(qs.size, dtype=bool)
        self.lu = None
        self.factorizations = 0
        self.symmetric = False  # the blocks to come are symmetric (for the cost model)
        self._reset()

    def _reset(self) -> None:
        k0 = self.base.size
        self.keys = np.zeros(0, dtype=np.int64)  # changed indices seen since the factor
        self.key_pos = np.full(self.qs.size, -1, dtype=np.int64)  # row of a key, or -1
        self._YT = np.zeros((0, k0))  # rows: (A0^-1 u_key)^T, with spare rows
        self._V = np.zeros((0, k0))
        self.S = np.zeros((0, 0))
        self.last = None  # (sel, LU of S[sel, sel]) of the last solve
        self.x0 = None  # A0^-1 (-q~ on the base), the same for every set

    @property
    def YT(self) -> np.ndarray:
        return self._YT[: self.keys.size]

    @property
    def V(self) -> np.ndarray:
        return self._V[: self.keys.size]

    def retarget(self, qs: np.ndarray) -> _BlockSolver:
        """The same solver for another q~ (factors and bordered keys depend on M~ only)."""
        self.qs, self.x0, self.last = qs, None, None
        self.symmetric = False
        return self

    def factor(self, Z: np.ndarray) -> bool:
        self.base = Z.copy()
        self.in_base = np.zeros(self.qs.size, dtype=bool)
        self.in_base[Z] = True
        self.lu = self._factor_block(Z) if Z.size else None
        self.factorizations += 1
        self._reset()
        return Z.size == 0 or self.lu is not None

    def _factor_block(self, Z: np.ndarray) -> _Factor | None:
        """Factors of M~[Z, Z]: with the scaling D folded into the solves when mu = 1
        (the diagonal scaling of a cold crash; `_factor`'s d), else of the scaled block."""
        Ms = self.Ms
        if Ms.mu == 1.0:
            return _factor(gather(Ms.M, Z, Z), cholesky=True, d=Ms.D[Z])
        return _factor(Ms.sub(Z), cholesky=True)

    def _refactor_is_cheaper(self, k: int, changed: np.ndarray) -> bool:
        """Whether a new factorization of the k x k block (Cholesky when `symmetric`, else
        LU) costs less than bordering the changed indices (flop counts; gathering an entry
        of M counts as _GATHER_FLOPS, a flop of the bordering's BLAS calls as
        1 + _SMALL_BLAS / max(k0, 250))."""
        k0, K = self.base.size, self.keys.size
        new = int((self.key_pos[changed] < 0).sum())
        blas = (1.0 + _SMALL_BLAS / max(k0, 250)) * (2.0 * k0 * k0 * new
                                                   + 4.0 * k0 * (K + new) * new)
        bordered = (blas + 2.0 / 3.0 * changed.size ** 3
                    + 2.0 * _GATHER_FLOPS * (k0 + K + new) * new)
        factor = (1.0 if self.symmetric else 2.0) / 3.0 * k ** 3
        return bordered > factor + _GATHER_FLOPS * k * k

    def _add_keys(self, new: np.ndarray) -> None:
        """Columns, rows and Schur entries of indices changed for the first time."""
        b0 = self.base
        inbase = self.in_base[new]
        added = new[~inbase]
        U = np.zeros((b0.size, new.size), order="F")  # solved in place below
        V = np.zeros((new.size, b0.size))
        old_added = ~self.in_base[self.keys]
        oa = self.keys[old_added]
        if added.size:  # one gather of the columns, one of the rows
            b0oa = np.concatenate([b0, oa])
            cols = self.Ms.block(b0oa, added)
            rows = self.Ms.block(added, b0oa)
            U[:, ~inbase] = cols[: b0.size]
            V[~inbase] = rows[:, : b0.size]
        pos = np.searchsorted(b0, new[inbase])  # base is sorted
        U[pos, np.flatnonzero(inbase)] = 1.0
        V[np.flatnonzero(inbase), pos] = 1.0
        YT = self.lu.solve(U, overwrite=True).T
        c_nn = np.zeros((new.size, new.size))
        if added.size:
            c_nn[np.ix_(~inbase, ~inbase)] = self.Ms.sub(added)
        c_no = np.zeros((new.size, self.keys.size))
        c_on = np.zeros((self.keys.size, new.size))
        if added.size and old_added.any():
            c_no[np.ix_(~inbase, old_added)] = rows[:, b0.size:]
            c_on[np.ix_(old_added, ~inbase)] = cols[b0.size:]
        K = self.keys.size
        S = np.empty((K + new.size, K + new.size))
        S[:K, :K] = self.S
        S[:K, K:] = c_on - self.V @ YT.T
        S[K:, :K] = c_no - V @ self.YT.T
        if K + new.size > self._YT.shape[0]:  # grow the key rows by doubling
            cap = max(2 * (K + new.size), 16)
            self._YT = np.concatenate([self._YT[:K], np.zeros((cap - K, b0.size))])
            self._V = np.concatenate([self._V[:K], np.zeros((cap - K, b0.size))])
        S[K:, K:] = c_nn - V @ YT.T
        self.S = S
        self._YT[K:K + new.size] = YT
        self._V[K:K + new.size] = V
        self.key_pos[new] = K + np.arange(new.size)
        self.keys = np.concatenate([self.keys, new])

    def solve(self, zset: np.ndarray, rhs: np.ndarray | None = None,
              refactor: bool = True) -> np.ndarray | None:
        """x (n,) with M~_ZZ x_Z = rhs_Z (default -q~), 0 elsewhere; None when singular.
        refactor=False: the same set as the previous call (its factors are reused)."""
        n = self.qs.size
        b = -self.qs if rhs is None else rhs
        Z = np.flatnonzero(zset)
        inbase = self.in_base
        A = Z[~inbase[Z]]
        R = self.base[~zset[self.base]]
        changed = np.concatenate([A, R])
        if refactor and (self.lu is None or self._refactor_is_cheaper(Z.size, changed)):
            if not self.factor(Z):
                return None
            changed = np.zeros(0, dtype=np.int64)
        z = np.zeros(n)
        if Z.size == 0:
            return z
        b0 = self.base
        if rhs is not None:
            x0 = self.lu.solve(b[b0])
        else:
            if self.x0 is None:
                self.x0 = self.lu.solve(b[b0])
            x0 = self.x0
        if changed.size:
            if refactor or self.last is None:
                new = changed[self.key_pos[changed] < 0]
                if new.size:
                    self._add_keys(new)
                sel = self.key_pos[changed]
                lu_s = _factor(self.S[np.ix_(sel, sel)])
                if lu_s is None:
                    return None
                self.last = (sel, lu_s)
            sel, lu_s = self.last
            rhs2 = np.concatenate([b[A], np.zeros(R.size)]) - self.V[sel] @ x0
            t = lu_s.solve(rhs2)
            x0 = x0 - self.YT[sel].T @ t
            z[A] = t[: A.size]
        z[b0] = x0
        z[R] = 0.0
        return z if np.isfinite(z).all() else None


def block_solver(Ms: ScaledM) -> _BlockSolver:
    """A block solver of M~ for a caller to keep between LCPs with this M~ (its factors
    and bordered keys depend on M~ alone): `warm_solve`, `crash_basis`'s solver."""
    return _BlockSolver(Ms, np.zeros(Ms.n))


def warm_solve(solver: _BlockSolver, qs: np.ndarray, zset: np.ndarray) -> np.ndarray | None:
    """z~ with M~_ZZ z~_Z = -q~_Z, 0 elsewhere, on a kept block solver (bordered on its
    base block, which is factorized again only when that costs less), with one residual
    correction; None when singular or huge (as `_converged`)."""
    z = solver.retarget(qs).solve(zset)
    if z is None:
        return None
    return _converged(solver, zset, z, solver.Ms.matvec(z) + qs, qs, False)


def crash_basis(Ms: ScaledM, qs: np.ndarray, twin: np.ndarray | None = None,
                max_iterations: int = MAX_ITERATIONS, start: np.ndarray | None = None,
                exact: CheckProduct | None = None, solver: _BlockSolver | None = None
                ) -> tuple[np.ndarray, int, np.ndarray | None]:
    """Guessed active set (n,) bool by block principal pivoting, the iterations used, and
    z~ on that set when the iteration converged: with one residual correction applied, or
    as solved when the last round's product was `exact`'s (the final check's product,
    which a correction would make stale; see `_whole_product`).

    Without `start`, in up to three stages: first the LCP over the indices without a twin (for
    contact: the normal pressures, every pair sticking), from the deepest q~:
    Z = {i : q~_i < DEEP_START min q~}; then, when the twins form one range, the LCP of the
    twins alone with those z fixed (`_twin_stage`; for contact: the slips under those
    pressures); then the whole LCP from the union (or, without that stage, from the first
    answer, where the twins with w~_i < 0 join). Returns the set with the fewest infeasible
    indices met on the whole LCP (the exact answer's set when the iteration converged).
    start: another first set (e.g. a warm-start basis), with the whole LCP from the first
    iteration. exact: the final check's product for Ms = the diagonal scaling of the
    caller's M (`CheckProduct`), used in the rounds on the whole LCP expected to be last.
    solver: with start, a kept `block_solver` of this M~ for the rounds (retargeted to
    qs): a start a few indices from its base block is bordered, not factorized.
    """
    n = qs.size
    twin = find_twins(Ms) if twin is None else twin
    Z, stages = _first_set(Ms, qs, twin, start, max_iterations)
    if solver is not None and start is not None:
        stages.solver = solver.retarget(qs)
    product = _TwinProduct(Ms, twin)
    best, best_bad = Z.copy(), n + 1
    prev_bad = None  # infeasible indices of the last round on the whole LCP
    for it in range(1, max_iterations + 1):
        z = stages.solver.solve(Z)
        if z is None:
            return best, it + stages.extra, None
        tol = _FEAS_REL * max(1.0, float(np.abs(z).max()))
        if stages.part is not None:  # first stage: rows and columns of `part` only
            Z, w = stages.stage_round(z, Z, tol, it)
            if w is None:
                continue
            checked = False
        else:  # checked: w~ from the final check's product (no correction after it)
            w, checked = _whole_product(z, qs, product, exact, prev_bad)
        bad_z = Z & (z < -tol)
        bad_w = ~Z & (w < -tol)
        nbad = prev_bad = int(bad_z.sum() + bad_w.sum())
        if nbad < best_bad:
            best, best_bad = Z.copy(), nbad
        if nbad == 0:
            return Z, it + stages.extra, _converged(stages.solver, Z, z, w, qs, checked)
        Z = _untwin((Z & ~bad_z) | bad_w, Z, w, twin)
    return best, max_iterations + stages.extra, None


def _first_set(Ms: ScaledM, qs: np.ndarray, twin: np.ndarray, start: np.ndarray | None,
               max_iterations: int) -> tuple[np.ndarray, _Stages]:
    """The first set of `crash_basis` (n,) bool and its stages: without start, the deep
    q~ without a twin, with the first stages when the layout has them; else start
    untwinned, on the whole LCP from the first round."""
    if start is None:
        Z = (qs < DEEP_START * qs.min(initial=0.0)) & (twin < 0)
        part = _first_stage(twin)
        tpart = _twin_range(twin) if part is not None else None
    else:
        Z = _untwin(start.copy(), start, qs, twin)
        part = tpart = None
    return Z, _Stages(Ms, qs, twin, part, tpart, max_iterations)


def _converged(solver: _BlockSolver, Z: np.ndarray, z: np.ndarray, w: np.ndarray,
               qs: np.ndarray, checked: bool) -> np.ndarray | None:
    """z~ of a converged round: with one residual correction unless w~ came from the final
    check's product (checked); None when it is huge (see `crash_basis`)."""
    if not checked:
        dz = solver.solve(Z, rhs=np.where(Z, -w, 0.0), refactor=False)
        z = z + dz if dz is not None else z
    # a huge z~ comes from a numerically singular block (the pivot test of _factor
    # is weaker than a condition estimate): leave the solve to the caller's LU
    grown = np.abs(z).max() > GROWTH_MAX * np.abs(qs).max()
    return None if grown else z


class _Stages:
    """The rounds of `crash_basis` before the whole LCP: `part`, the index range of the
    first stage (None when it is over or absent), `tpart`, the twins' range (None once
    their stage ran or without it), the block solver of the rounds and `extra`, the
    iterations of the twins' stage."""

    def __init__(self, Ms: ScaledM, qs: np.ndarray, twin: np.ndarray, part: slice | None,
                 tpart: slice | None, max_iterations: int):
        self.Ms, self.qs, self.twin, self.max_iterations = Ms, qs, twin, max_iterations
        self.part, self.tpart, self.extra = part, tpart, 0
        self.solver = _BlockSolver(Ms, qs)
        self.solver.symmetric = part is not None

    def stage_round(self, z: np.ndarray, Z: np.ndarray, tol: float, it: int
              ) -> tuple[np.ndarray, np.ndarray | None]:
        """A first-stage round on z~ (solved on Z, iteration it): (the next set, None) when
        the first stages go on, else (Z, w~ of the whole LCP) and they are over."""
        Ms, qs, part = self.Ms, self.qs, self.part
        w = np.full(qs.size, np.inf)
        w[part] = Ms.matvec(z, part, rows=True) + qs[part]
        bad_z = Z & (z < -tol)
        if (bad_z.any() or (~Z & (w < -tol)).any()) and it < self.max_iterations // 2:
            return (Z & ~bad_z) | (~Z & (w < -tol)), None
        if self.tpart is not None:  # the twins' LCP with these z fixed, then the whole
            S = self._twins(z, w)
            if S is not None:
                self.part = None
                return (Z & ~bad_z) | S, None
        self.part = None
        self.solver.symmetric = False
        return Z, Ms.matvec(z, part) + qs  # second stage: every index may join

    def _twins(self, z: np.ndarray, w: np.ndarray) -> np.ndarray | None:
        """The twins' stage (`_twin_stage`) with the first stage's z~ fixed; w: its w~ on
        `part` (the twins' rows are set here). Its set, or None when it found none."""
        Ms, part, tpart = self.Ms, self.part, self.tpart
        v = Ms.D[part] * z[part]  # its q': the rows of the twins only
        w[tpart] = Ms.D[tpart] * (Ms.M[tpart, part] @ v) / Ms.mu + self.qs[tpart]
        S, k, s_solver = _twin_stage(Ms, w, self.twin, tpart, self.max_iterations)
        self.extra += k
        self.tpart = None
        if S is not None and S.any():  # its factors and bordered keys serve the whole LCP
            self.solver = s_solver.retarget(self.qs)
        return S


def _whole_product(z: np.ndarray, qs: np.ndarray, product: _TwinProduct,
                   exact: CheckProduct | None, prev_bad: int | None
                   ) -> tuple[np.ndarray, bool]:
    """w~ = M~ z~ + q~ of a round on the whole LCP, and whether it came from `exact` (the
    final check's product) rather than `product`. exact serves when it reads no more of M
    than `product` (a plain product), or when the last round had at most EXACT_AFTER
    infeasible indices (this one is then likely the last), and z~ >= 0."""
    if exact is not None and (product.runs is None or (prev_bad is not None
                                                       and prev_bad <= EXACT_AFTER)):
        w = exact(z)
        if w is not None:
            return w, True
    return product(z) + qs, False


def _twin_range(twin: np.ndarray) -> slice | None:
    """The index range of the twins when they form one range (the contact layout: the
    slips after the normal pressures), else None."""
    tw = np.flatnonzero(twin >= 0)
    if tw.size == 0 or tw[-1] - tw[0] + 1 != tw.size:
        return None
    return slice(int(tw[0]), int(tw[-1]) + 1)


def _twin_stage(Ms: ScaledM, w: np.ndarray, twin: np.ndarray, tpart: slice,
                max_iterations: int) -> tuple[np.ndarray | None, int, _BlockSolver]:
    """Block pivoting on the LCP over the twin indices (range tpart) alone, with the other
    z~ fixed: q' = w (n,), the w~ of the first stage's answer. For contact: the slips under
    the normal pressures found, a symmetric block (Cholesky) and products with M~[tpart,
    tpart] reading one column of each twin pair, so the cascade of slips that the whole
    LCP would repeat on its larger block and passes over M costs a fraction of it. The
    first set is `app.lcp.slip_guess.slip_guess`'s (a few projected Jacobi sweeps), else
    the trial guess (the pairs whose stick force leaves the cone: q'_i < 0).
    Returns the set (n,) bool that solves that LCP (None if none was found), the
    iterations used and the block solver (its factors serve the whole LCP next)."""
    n = w.size
    qt = np.zeros(n)
    qt[tpart] = w[tpart]
    solver = _BlockSolver(Ms, qt)
    solver.symmetric = True
    product = _TwinProduct(Ms, twin, tpart)
    none = np.zeros(n, dtype=bool)
    Z = slip_guess(Ms, qt, twin, tpart)
    if Z is None:  # the trial guess: the pairs whose stick force leaves the cone
        Z = _untwin(qt < -_FEAS_REL, none, qt, twin)
    for it in range(1, max_iterations + 1):
        if not Z.any():
            return Z, it, solver
        z = solver.solve(Z)
        if z is None:
            return None, it, solver
        tol = _FEAS_REL * max(1.0, float(np.abs(z).max()))
        wt = np.full(n, np.inf)
        wt[tpart] = product(z) + qt[tpart]
        bad_z = Z & (z < -tol)
        bad_w = ~Z & (wt < -tol)
        if not (bad_z.any() or bad_w.any()):
            return Z, it, solver
        Z = _untwin((Z & ~bad_z) | bad_w, Z, wt, twin)
    return None, max_iterations, solver


class _TwinProduct:
    """z~ -> M~ z~ reading one column of each twin pair (M[:, j] = -M[:, twin j]): a third
    less of M for the contact LCP. Used when the columns kept form at most _MAX_RUNS
    ranges, else the plain product. part: z~ is zero outside this index range and only
    its rows are wanted (returns (len(part),)): the block M~[part, part], twins read once."""

    def __init__(self, Ms: ScaledM, twin: np.ndarray, part: slice | None = None):
        self.Ms, self.part = Ms, part
        n = twin.size
        self.drop = np.flatnonzero((twin >= 0) & (twin < np.arange(n)))
        self.to = twin[self.drop]
        keep = np.ones(n + 2, dtype=bool)
        keep[1 + self.drop] = False
        keep[0] = keep[-1] = False
        if part is not None:  # columns outside the part hold no z
            keep[1:1 + part.start] = False
            keep[1 + part.stop:] = False
        edges = np.flatnonzero(np.diff(keep.astype(np.int8)))
        self.runs = [slice(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]
        if not self.drop.size or len(self.runs) > _MAX_RUNS:
            self.runs = None

    def __call__(self, z: np.ndarray) -> np.ndarray:
        Ms, rows = self.Ms, (slice(None) if self.part is None else self.part)
        if self.runs is None:
            return Ms.matvec(z, self.part, rows=True)
        v = Ms.D * z
        v[self.to] -= v[self.drop]
        y = Ms.M[rows, self.runs[0]] @ v[self.runs[0]]
        for r in self.runs[1:]:
            y += Ms.M[rows, r] @ v[r]
        return Ms.D[rows] * y / Ms.mu


def _first_stage(twin: np.ndarray) -> slice | None:
    """The index range of the first stage: the indices without a twin when they form one
    range [a, b) and twins exist (the layout of the contact LCP), else None (one stage)."""
    lone = np.flatnonzero(twin < 0)
    if lone.size in (0, twin.size) or lone[-1] - lone[0] + 1 != lone.size:
        return None
    return slice(int(lone[0]), int(lone[-1]) + 1)


def _untwin(Znew: np.ndarray, Zold: np.ndarray, w: np.ndarray, twin: np.ndarray) -> np.ndarray:
    """Drop one of each twin pair in Znew: the one that was in Zold (its twin asks to enter),
    else the one with the larger w."""
    i = np.flatnonzero(Znew & (twin >= 0))
    j = twin[i]
    both = Znew[j] & (i < j)
    i, j = i[both], j[both]
    drop_i = np.where(Zold[i], True, np.where(Zold[j], False, w[i] > w[j]))
    out = Znew.copy()
    out[i[drop_i]] = False
    out[j[~drop_i]] = False
    return out
