"""The modified Coulomb interface law as an LCP (METHOD.md sections 4 and 5).

Plain numpy, runs on rank 0. Notation, per pair (m pairs; the `frictional` subset F of
size mf has tangential unknowns; r rigid-body modes of floating bodies):
- p (m): normal force on the slave, compression positive; q (mf): tangential force on
  the slave along t; a, c: pair adhesion and strength forces (traction x tributary length
  x thickness); mu: friction coefficient; F = mu p + c the friction bound.
- gap = gap_free + C_nn p + C_nt q + N alpha, tau = tau_free + C_tn p + C_tt q + T alpha
  (tau: relative tangential displacement, slave minus master, along t).
- alpha (r): amplitudes of the floating bodies' rigid modes; equilibrium of those bodies
  is e0 + N^T p + T^T q = 0 (e0 = R^T f, the external load on the modes).

With H = C_tt^-1, A = C_nn - C_nt H C_tn, Bm = C_nt H, V = N - Bm T, W = H T,
Z = T^T H T and D = mu on the frictional rows, the unknowns
z = (p + a, s+, s-, alpha+, alpha-) >= 0 and w = (gap, F + q, F - q, -eq, +eq) >= 0 give

    M = [[ A,        Bm,   -Bm,    V,    -V  ],
         [ D - Bm^T,  H,    -H,   -W,     W  ],
         [ D + Bm^T, -H,     H,    W,    -W  ],
         [-V^T,      -W^T,   W^T,  Z,    -Z  ],
         [ V^T,       W^T,  -W^T, -Z,     Z  ]]

(the two last block rows hold the equality e0 + N^T p + T^T q = 0 as two inequalities
with free alpha = alpha+ - alpha-). M depends only on C, mu and the rigid-mode coupling:
it is built once per run; load steps and debonding iterations change only the vector q.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.errors import SolveError
from app.lcp import lemke
from app.lcp.conditioning import determined_accuracy
from app.lcp.coulomb_matrix import coulomb_matrix, fixed_rows, tie_fixed
from app.lcp.matrix_cache import MatrixCache
from app.lcp.mip import complementary_basis
from app.lcp.result import DEFAULT_TOL, LCPResult
from app.lcp.scaling import absmax, row_blocks
from app.lcp.solvers import LCPSolver


@dataclass
class ContactSolution:
    """Result of one LCP solve (forces on the slave, kinematics from the LCP)."""

    p: np.ndarray  # (m,) normal force
    q: np.ndarray  # (m,) tangential force (0 for frictionless pairs)
    gap: np.ndarray  # (m,)
    tau: np.ndarray  # (m,) relative tangential displacement (frictional pairs; else from C)
    slip_plus: np.ndarray  # (m,)
    slip_minus: np.ndarray  # (m,)
    alpha: np.ndarray  # (r,)
    pivots: int
    status: str
    basis: np.ndarray | None
    residual: float = 0.0  # Lemke's relative check residual (scaled LCP)
    message: str = ""  # Lemke's own summary of the solve
    motion: np.ndarray | float = 0.0  # (m,) per pair: largest term of its gap and tau sums
    accuracy: float = 0.0  # relative accuracy round-off allows p, q, alpha (`_accuracy`)


def motion_size(*terms: np.ndarray) -> np.ndarray:
    """(m,) per pair, the largest |entry| of the terms (each (m,)) that its gap and tau add
    up (free motion, C lam, the modes' motion): the size whose round-off the pair's
    kinematics carry. A stiff body loaded on a soft one moves by its contact forces and
    modes, not its free motion: their terms are large and cancel to a gap of round-off
    (see `app.interface.steps`). Per pair, not the largest over the problem: a stiff bond
    beside such a soft contact (its own terms 1e-8, the soft ones 0.09) stayed bonded at
    1.35 times its strength, its opening of 5e-9 read against 1e-7 x 0.09."""
    if not terms:
        return np.zeros(0)
    return np.abs(np.stack(terms)).max(axis=0)


def pair_kinematics(c_lam: tuple[np.ndarray, np.ndarray], n_modes: np.ndarray,
                    t_modes: np.ndarray | None, alpha: np.ndarray, gap_base: np.ndarray,
                    tau_base: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple, tuple]:
    """(gap, tau, gap terms, tau terms), (m,) each, of the contact forces' motion c_lam =
    (C_n lam, C_t lam) (m,) each and the mode amplitudes alpha (r,): gap = gap_base +
    C_n lam + N alpha and tau = tau_base + C_t lam + T alpha (N = n_modes (m, r), T =
    t_modes (m, r), None for no term; summed left to right), and the terms whose round-off
    those sums carry (`motion_size`). gap_base: the free gap; tau_base: the free tau (tau),
    or tau_free - tau_prev (then tau is the step's motion tau - tau_prev). The one sum of
    `ContactLCP` and of `app.interface.candidates` (the pairs outside the candidates).
    The callers form C lam: a BLAS product's last bits depend on the matrix's row count
    (its row blocking), and each keeps the products its answers were measured with."""
    gap_terms = (gap_base, c_lam[0], n_modes @ alpha)
    tau_terms = (tau_base, c_lam[1])
    if t_modes is not None:
        tau_terms += (t_modes @ alpha,)
    gap = gap_terms[0] + gap_terms[1] + gap_terms[2]
    tau = tau_terms[0] + tau_terms[1]
    for term in tau_terms[2:]:
        tau = tau + term
    return gap, tau, gap_terms, tau_terms


POLISH_REL = 1e-12
"""`ContactLCP._polished` keeps its answer when it leaves the basis's signs by at most this
times the pair's own force and motion terms (round-off of the solve, not a wrong basis).
Its solve leaves gaps of 1e-15 of those terms; with 1e-9 a pair that a stiff floating body
(E = 1e12 on 1e3) penetrated by its own compliance, 5.6e-12 beside terms of 8e-3, passed
as open at p = 0 and the pressure ran 0..18.9 in place of 9.06..13.7
(`tests/test_interface_steps.py`)."""

POLISH_GATE = 1e-10
"""`ContactLCP._off_basis`: a closed pair's gap, an open pair's penetration, a sticking
pair's tangential motion or a slipping pair's motion against its slip above this times its
motion terms (or a pair's q off its bound by this of its force terms) calls for
`ContactLCP._polished` (below the state tolerance, 1e-7, of `app.interface.steps`, so that
no such round-off reaches the pair states). 1e-10, not 1e-8 (before): a stiff floating
body's forces move its gaps by its own compliance only (two_blocks.toml, E = 1e10..1e11 on
1e3), so gaps of 1e-9 of the motion terms were forces tens of percent off: at 1e-8 the
mortar block at E = 1e10 was mirror-symmetric to 1.8e-3 only (2.1e-9 now), and a
tangential cycle at 1e11 (node-to-segment, mu = 0.3) read p, q 31% off 1e10's and 1e12's
with the right states (now 1e-6). The shipped configs fire on the same solves at both."""

UNSHIFTED_PIVOTS = 8
"""Block pivots `ContactLCP._unshifted` tries on Lemke's final basis before keeping z."""

PIVOT_RULES = ("block", "worst", "least")
"""The pivot rules of `ContactLCP._polished` in turn (`_flipped`), each from where the one
before cycled or ran out; once "least" cycles too, a tabu step (`_unseen`) between its
flips."""

SINGLE_FLIPS = 16
"""The re-solve's budget beyond UNSHIFTED_PIVOTS: `ContactLCP._polished` makes at most
UNSHIFTED_PIVOTS + SINGLE_FLIPS dense solves of size ~2m in all, whatever m and rule
(block pivots that cycle early leave their share to the one-pair flips): the stiff
floating block at 1e12 (tests/test_interface_steps.py) settles after 6 solves in all;
without a cap the worst case was m more solves (m = 1000: 0.5 s each, 8 min, against 4 s
before; reviewer `review6`). min(m, 16) before: small LCPs ran out after m flips where a
few more settle them."""


def _force_size(p: np.ndarray, q: np.ndarray, a: np.ndarray, c: np.ndarray,
                mu: np.ndarray) -> np.ndarray:
    """(m,) a pair's own force terms, |a| + |c| + |p| + |q| + |mu p| (+1e-300): the scale
    its normal and stick signs are judged against (`_basis_errors`, `_law_error`)."""
    return np.abs(a) + np.abs(c) + np.abs(p) + np.abs(q) + np.abs(mu * p) + 1e-300


def _fixed_pairs(c: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(fixed_n, fixed_t, c): the pairs whose normal (tangential) compliance is round-off,
    below FIXED_REL of the largest (`fixed_rows`; both sides of the pair prescribed, e.g. the end
    pairs of a bonded block whose sides are prescribed), and the compliance with those rows
    and columns set to zero and a stiff tie FIXED_COMPLIANCE_REL x the largest on their
    diagonal. Their force moves nothing (the supports take it), so any value is an answer;
    the round-off of their compliance and free gap, 1e-35 and -1e-20, gave p = 3.8e14 there,
    which the normal force and the reactions of the interface then carried, and their q
    differed between 1 and 2 ranks by 5e-8. With the tie and their round-off free motion
    zeroed (`ContactLCP._free_motion`) such a pair carries p = q = 0 (its p + a basic)."""
    diag = np.diagonal(c).copy()
    fixed = []
    for start in (0, m):
        rows, tie = fixed_rows(diag[start: start + m])
        fixed.append(rows)
        if rows.any():  # (a copy: the caller's compliance is kept)
            c = tie_fixed(c, np.flatnonzero(rows) + start, tie)
    return fixed[0], fixed[1], c


def _rejudged(res, ms: np.ndarray, qs: np.ndarray, qsize: np.ndarray) -> None:
    """Lemke's 'inaccurate' answer `res` (on the scaled LCP ms, qs) judged again with each
    row's size counting the terms that cancelled in its constant (qsize (n,), scaled): res
    becomes 'solved' when no row's violation exceeds DEFAULT_TOL of
    qsize_i + sum_j |ms_ij| z_j. Lemke judges row i against |q_i| + sum_j |M_ij| z_j, and
    a load exactly at the adhesion's strength makes the balance rows' constant e0 - N^T a
    exactly 0: node-to-segment on pull_off.toml pulled by a traction of a = 2 (the pairs
    at p = -a, a degenerate basis) ended 'inaccurate' with a violation of 9.2e-14 in that
    row, round-off of its terms (N^T a ~ 2) but 6.7e-8 of Lemke's floor of its size.
    Kept beside Lemke's check, not in it: that check sees only (M, q), the cancelled terms
    are this caller's (`_constant_terms`), and passing them would add an argument to
    `app.lcp.lemke` and to every `LCPSolver`; judged here, the test serves each solver."""
    z = res.z
    if z.size == 0 or not (np.isfinite(z).all() and (z >= 0).all()):
        return
    w = ms @ z + qs
    viol = np.maximum(np.maximum(-w, 0.0), np.where(z > 0, np.abs(w), 0.0))
    size = qsize + np.abs(ms) @ z
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(viol > 0, viol / size, 0.0)
    worst = float(rel.max(initial=0.0))
    if np.isfinite(worst) and worst <= DEFAULT_TOL:
        res.status, res.w, res.residual = "solved", w, worst
        res.message += (f"; accepted against the terms of its constant vector (worst "
                        f"relative violation {worst:.3g}: the balance of a load at the "
                        "bond's strength cancels)")


def _reach(big: np.ndarray, inv: np.ndarray, skip: np.ndarray | None = None) -> np.ndarray:
    """(n,): each column's largest M_ij^2 / M_ii over the rows i with inv_i = 1 / M_ii > 0,
    leaving out the entries where skip(i0, i1) (a (rows, n) bool block) is True."""
    n = big.shape[0]
    reach = np.zeros(n)
    for i0, i1 in row_blocks(n):  # (no n x n temporary)
        blk = big[i0:i1]
        r = blk * blk * inv[i0:i1, None]
        if skip is not None:
            r[skip(i0, i1)] = 0.0
        np.maximum(reach, r.max(axis=0), out=reach)
    return reach


def _symmetric_scaling(big: np.ndarray) -> np.ndarray:
    """d (n,): the symmetric scaling of the LCP matrix big (n, n), 1 / sqrt(ref) with ref
    its diagonal entry where that is not round-off, else the column's largest |entry| (1
    for an empty column). A diagonal entry is round-off when it is below 1e-12 x its
    column's largest M_ij^2 / M_ii (rows with M_ii > 0): the entry that the scaling by the
    diagonals would make 1e6 times the unit diagonal. That measure has the units of the
    diagonal entry: compliance for p, whose column also holds mu and dimensionless
    couplings. Compared with those directly (before), the p columns of an interface whose
    compliance was below 1e-12 (E ~ 1e15 on unit geometry) were scaled by mu and lost
    their forces (configs/hard/tangential_contrast.toml, floating: p 11% off).

    A row whose own diagonal is round-off by that test (a floating mode that slides no
    pair: Z ~ 1e-35 beside V ~ 1) is left out of the reach of the columns whose diagonal
    is larger relative to their largest entry than its own: of such a pair of rows it is
    the round-off one (before: it made p columns fall back to their largest entry, 216
    times their diagonal on configs/hard/squeezed.toml turned by 90 deg, whose first step
    took 26 Lemke pivots instead of 6)."""
    n = big.shape[0]
    diag = np.abs(np.diagonal(big))
    inv = np.divide(1.0, diag, out=np.zeros(n), where=diag > 0)
    colmax = absmax(big, axis=0) if n else np.zeros(0)
    reach = _reach(big, inv)
    own = diag > 1e-12 * reach
    suspect = (diag > 0) & ~own
    if suspect.any():
        rel = np.divide(diag, colmax, out=np.zeros(n), where=colmax > 0)
        reach = _reach(big, inv, lambda i0, i1: suspect[i0:i1, None]
                       & (rel[i0:i1, None] < rel[None, :]))
        own = diag > 1e-12 * reach
    ref = np.where(own, diag, colmax)
    return 1.0 / np.sqrt(np.where(ref > 0, ref, 1.0))


States = tuple[np.ndarray, np.ndarray, np.ndarray]
"""Pair states (closed, slip+, slip-), (m,) bool each: closed gap = 0 (else p = -a); slip+
q = -(c + mu p) with tau - tau_prev >= 0, slip- q = +(c + mu p) with it <= 0; a frictional
pair with neither sticks (tau = tau_prev)."""


def _state_key(states: States) -> bytes:
    """The key of a set of pair states in the re-solve's sets of states seen."""
    return np.concatenate(states).tobytes()


def _with_pair(states: States, i: int, shut: bool, plus: bool, minus: bool) -> States:
    """New arrays: states with pair i closed = shut, slip+ = plus, slip- = minus."""
    closed, sp_b, sm_b = (s.copy() for s in states)
    closed[i], sp_b[i], sm_b[i] = shut, plus, minus
    return closed, sp_b, sm_b


def _flipped(states: States, flips: tuple[np.ndarray, ...], rule: str) -> States:
    """The pair states (closed, slip+, slip-) (m,) bool each after the pivot flips =
    (normal flips, new slip+, new slip-, each pair's violation over its tolerance) of
    `ContactLCP._basis_errors`, by `rule` (`ContactLCP._polished`): "block" every pair
    that left its signs, "worst" only the one that left them most, "least" only the
    first (lowest index) that left them (Murty's least-index rule)."""
    closed = states[0]
    if rule == "block":
        return closed ^ flips[0], flips[1], flips[2]
    off = flips[3]
    i = int(np.argmax(off)) if rule == "worst" else int(np.argmax(off > 1.0))
    return _with_pair(states, i, bool(closed[i] ^ flips[0][i]), bool(flips[1][i]),
                      bool(flips[2][i]))


def _unseen(states: States, off: np.ndarray, fric: np.ndarray,
            seen: set[bytes]) -> States | None:
    """The first set of pair states not in seen (keys `_state_key`) that differs from
    states (closed, slip+, slip-) (m,) bool each in one pair, the first pair off (off (m,)
    bool) first: its tangential state (stick, slip+, slip-, frictional pairs fric (m,)
    only) with its normal state, then with the other; None when every one was seen
    (`ContactLCP._polished`, once Murty's least-index rule comes back)."""
    closed = states[0]
    tangential = ((False, False), (True, False), (False, True))
    for i in np.flatnonzero(off):
        for shut in (bool(closed[i]), not closed[i]):
            for plus, minus in tangential if fric[i] else tangential[:1]:
                new = _with_pair(states, int(i), shut, plus, minus)
                if _state_key(new) not in seen:
                    return new
    return None


class ContactLCP:
    """The LCP matrix of a run and the constant vector of each solve."""

    def __init__(self, c: np.ndarray, mu: np.ndarray, frictional: np.ndarray,
                 n_modes: np.ndarray | None = None, t_modes: np.ndarray | None = None,
                 solver: LCPSolver = lemke, cache: bool = True):
        """c: (2m, 2m) compliance, normal rows first then tangential; mu (m,);
        frictional (m,) bool; n_modes = G_n R (m, r), t_modes = G_t R (m, r); solver: an
        entry of app.lcp.solvers.LCP_SOLVERS; cache: keep a MatrixCache of the LCP
        matrix for the solver over the solves (False: none, each solve reads M afresh)."""
        self.solver = solver
        m = mu.size
        if not np.isfinite(c).all():
            raise SolveError("the contact compliance is not finite (overflow or underflow in "
                             "the solve): check the Young's moduli and the loads")
        self.m = m
        self.fixed, self.fixed_t, c = _fixed_pairs(c, m)
        self.c = c
        cm = coulomb_matrix(c, mu, frictional, n_modes, t_modes)
        self.fric, self.mf = cm.fric, cm.fric.size
        self.r = 0 if n_modes is None else n_modes.shape[1]
        self.nm, self.tm = cm.nm, cm.tm
        self.tm_all = np.zeros((m, 0)) if t_modes is None else t_modes
        self.h, self.bm, self.v, self.w, self.z = cm.h, cm.bm, cm.v, cm.w, cm.z
        self.apply_h = cm.apply_h  # H x with the null-space tie apart (exact sums)
        # the null space of the Jacobi-scaled C_tt (mf, n_null) orthonormal, for `_accuracy`
        self.null_t = np.zeros((cm.fric.size, 0))
        if cm.tie is not None:
            vn = cm.tie * np.sqrt(np.abs(np.diagonal(c)[m:][cm.fric]))[:, None]
            self.null_t = vn / np.linalg.norm(vn, axis=0)
        # the frictional pairs tied here are dependent directions too (zero rows of C_tt;
        # `tangential_stiffness` gets them tied, so it does not count them)
        self.dependent_tangential = cm.dependent + int(self.fixed_t[cm.fric].sum())
        self.edges = edges = cm.edges
        big, n, mf = cm.M, cm.M.shape[0], cm.fric.size
        i0, i2 = edges[1], edges[3]
        # Rows of the slip unknowns (w = F +- q, F = mu p + c) divided by max(mu, 1): a
        # positive row scaling keeps the LCP's solutions, and it keeps a huge mu (1e12:
        # full stick) from burying the compliance of the p columns under the mu entries.
        self.row_scale = np.ones(n)
        if mf:
            inv_mu = 1.0 / np.maximum(mu[cm.fric], 1.0)
            self.row_scale[i0:i2] = np.concatenate([inv_mu, inv_mu])
            big[i0:i2] *= self.row_scale[i0:i2, None]
        # Symmetric diagonal scaling z = d z', w' = d w (complementarity is kept): brings
        # compliance-sized and stiffness-sized blocks to unit diagonal for Lemke. Only the
        # scaled matrix is kept (scaled in place: one n x n array).
        self.scaling = _symmetric_scaling(big)
        big *= self.scaling[:, None]
        big *= self.scaling[None, :]
        if not np.isfinite(big).all():
            raise SolveError("the contact LCP matrix is not finite (overflow in the "
                             "compliance): check the Young's moduli and the loads")
        self.M_scaled = big  # what Lemke gets: R D M D (R: row_scale)
        # what the solver derives from M alone, kept over the run's solves (only q
        # changes between them); it makes M_scaled read-only
        self.cache = MatrixCache(big) if cache else None

    @property
    def M(self) -> np.ndarray:
        """The unscaled LCP matrix (formed on demand from the scaled one: a new array)."""
        d = self.scaling
        return self.M_scaled / (d * self.row_scale)[:, None] / d[None, :]

    @property
    def size(self) -> int:
        return self.M_scaled.shape[0]

    def _free_motion(self, gap_free: np.ndarray, tau_free: np.ndarray,
                     tau_prev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(gap_free, tau_prev - tau_free), (m,) each, with the round-off (below 1e-12 of
        the largest) of the pairs the supports fix (`_fixed_pairs`) set to zero: their
        motion is prescribed, and its round-off times their stiff tie was a force."""
        dtau = tau_prev - tau_free
        gap_free = gap_free.copy() if self.fixed.any() else gap_free
        for fixed, x in ((self.fixed, gap_free), (self.fixed_t, dtau)):
            if fixed.any():
                big = max(float(np.abs(x).max(initial=0.0)),
                          float(np.abs(tau_free).max(initial=0.0)) if x is dtau else 0.0)
                x[fixed & (np.abs(x) <= 1e-12 * big)] = 0.0
        return gap_free, dtau

    def constant(self, gap_free: np.ndarray, tau_free: np.ndarray, tau_prev: np.ndarray,
                 a: np.ndarray, c: np.ndarray, mu: np.ndarray, e0: np.ndarray) -> np.ndarray:
        """The LCP constant vector for one solve (all arguments per pair, (m,); e0 (r,))."""
        return self._constant_terms(*self._free_motion(gap_free, tau_free, tau_prev), a, c,
                                    mu, e0)[0]

    def _constant_terms(self, gap_free: np.ndarray, dtau: np.ndarray, a: np.ndarray,
                        c: np.ndarray, mu: np.ndarray,
                        e0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(the constant vector, the size of its terms (n,) >= its magnitude) from the free
        motion of `_free_motion` (gap_free, tau_prev - tau_free): the motion part's
        magnitude plus the bond part's terms (`_bond_sizes`), for the rows where they
        cancel (a load exactly at the adhesion's strength, e0 = N^T a: `_rejudged`)."""
        out = self._parts(gap_free, dtau, np.zeros(self.m), np.zeros(self.m), e0)
        # entries that are round-off of exact cancellations (e.g. F = 0 and no tangential
        # motion) are set to zero, so that Lemke does not pivot on them; judged on the
        # motion part alone (a = c = 0), relative to its largest entry: with the bond's
        # part in the measure, a strength c of 1e20 set every free gap to zero, and a = c =
        # 1e12 on one pair zeroed the other pairs' slip rows. Not per block: a block that
        # is all round-off (the tangential motion of a symmetric scene) is then its own
        # measure and kept, and Lemke pivoted on it (initial_gap.toml step 2: 7 pivots
        # from the crash guess in place of 0)
        scaled = np.abs(self.scaling * self.row_scale * out)
        out[scaled < 1e-14 * scaled.max(initial=0.0)] = 0.0
        size = np.abs(out)
        if a.any() or c.any():  # the bond's part; c - mu a that is round-off is zero
            base = c - mu * a
            base[np.abs(base) <= 1e-14 * np.maximum(np.abs(c), np.abs(mu * a))] = 0.0
            zero = np.zeros(self.m)
            out = out + self._parts(zero, zero, a, base, np.zeros(self.r))
            size = size + self._bond_sizes(a, base)
        return out, size

    def _bond_sizes(self, a: np.ndarray, base: np.ndarray) -> np.ndarray:
        """The size of the terms of the bond's part of the constant vector (`_parts` at
        gap_free = dtau = e0 = 0), every product taken in absolute values: the balance
        rows' N^T a sums forces of both signs (the moment of the pairs' adhesion)."""
        f = self.fric
        cnt_f = np.abs(self.c[: self.m, self.m:][:, f])
        hxi = np.abs(self.h) @ (cnt_f.T @ a)
        qg = np.abs(self.c[: self.m, : self.m]) @ a + cnt_f @ hxi
        eq = np.abs(self.nm).T @ a + np.abs(self.tm).T @ hxi
        return np.concatenate([qg, np.abs(base[f]) + hxi, np.abs(base[f]) + hxi, eq, eq])

    def _parts(self, gap_free: np.ndarray, dtau: np.ndarray, a: np.ndarray,
               base: np.ndarray, e0: np.ndarray) -> np.ndarray:
        """The constant vector, linear in (gap_free, dtau, a, base, e0): base is the
        friction bound at p = 0, c - mu a (m,)."""
        f = self.fric
        cnt_f = self.c[: self.m, self.m:][:, f]
        xi = dtau[f] + cnt_f.T @ a
        hxi = self.apply_h(xi)
        qg = gap_free - self.c[: self.m, : self.m] @ a + cnt_f @ hxi
        eq = e0 - self.nm.T @ a + self.tm.T @ hxi
        return np.concatenate([qg, base[f] + hxi, base[f] - hxi, -eq, eq])

    def solve(self, gap_free: np.ndarray, tau_free: np.ndarray, tau_prev: np.ndarray,
              a: np.ndarray, c: np.ndarray, mu: np.ndarray, e0: np.ndarray, *,
              basis: np.ndarray | list[np.ndarray] | None = None,
              max_pivots: int | None = None) -> ContactSolution:
        """Solve the LCP and recover p, q, gap, tau and alpha. basis: a warm-start basis,
        or a list of them tried in order (newest first); when none solves it, Lemke starts
        from its crash basis, then cold."""
        free = self._free_motion(gap_free, tau_free, tau_prev)  # (the q recovery's too)
        qv, qsize = self._constant_terms(*free, a, c, mu, e0)
        if not np.isfinite(qv).all():
            raise SolveError("the contact LCP's constant vector is not finite (overflow in "
                             "the free gaps): check the loads and the Young's moduli")
        ms, qs = self.M_scaled, self.scaling * self.row_scale * qv
        res = self._lemke(ms, qs, basis, max_pivots)
        if res.status == "inaccurate":
            _rejudged(res, ms, qs, self.scaling * self.row_scale * qsize)
        settled = self._settled_inaccurate(res, free, a, c, mu, e0)
        # (frictionless, M is copositive-plus and the ray proves there is no solution)
        if self.r and (res.status == "inaccurate" or
                       (res.status == "secondary ray" and self.mf)):
            res = self._searched(res, ms, qs)
        z = self._lemkes_z(res, settled is None, a, gap_free, tau_free, tau_prev, c, mu, e0)
        sol = self._recovered(z, free, gap_free, tau_free, res)
        if res.status != "solved" or res.basis is None:
            return sol
        basis = np.asarray(res.basis, dtype=bool)
        states = self._basis_states(basis)
        if settled is None and self._off_basis(sol, basis, tau_prev, free, c, mu):
            settled = self._polished_kept(sol, basis, free, a, c, mu, e0)
        if settled is not None:
            states = settled[3:]
            sol = self._settled_solution(settled, sol, gap_free, tau_free, tau_prev, res)
            # (sol.basis stays Lemke's: the settled states' basis as the next step's warm
            # start gave the same answers with more pivots, README "Hard cases", the
            # basis handed on)
        sol.accuracy = self._accuracy(*states, mu)
        return sol

    def _lemke(self, ms: np.ndarray, qs: np.ndarray,
               basis: np.ndarray | list[np.ndarray] | None,
               max_pivots: int | None) -> LCPResult:
        """The solver's result on the scaled LCP (ms, qs): from each warm-start basis in
        turn (the newest first) until one does not fail, else from the crash basis, then
        cold; its pivots summed over the tries."""
        candidates = [b for b in (basis if isinstance(basis, list) else [basis])
                      if b is not None]
        pivots = 0
        for b in candidates:
            res = self.solver(ms, qs, basis=b, max_pivots=max_pivots, cold_start=False,
                              cache=self.cache)
            pivots += res.pivots
            if res.status != "warm start failed":
                break
        else:  # no warm start (or none worked): the crash basis, then the cold start
            res = self.solver(ms, qs, max_pivots=max_pivots, cache=self.cache)
            pivots += res.pivots
        res.pivots = pivots
        return res

    def _lemkes_z(self, res, unshift: bool, a: np.ndarray, gap_free: np.ndarray,
                  tau_free: np.ndarray, tau_prev: np.ndarray, c: np.ndarray, mu: np.ndarray,
                  e0: np.ndarray) -> np.ndarray:
        """(size,) the unscaled z of the solver's result res with p (not p + a) on the
        normal rows; where unshift and res is solved with a >> the forces (p holds
        round-off of a), solved again on its basis without the shift (`_unshifted`)."""
        e = self.edges
        z = self.scaling * res.z
        z[: e[1]] -= a  # p on the normal rows
        if unshift and res.status == "solved" and res.basis is not None and \
                a.max(initial=0.0) > 1e3 * np.abs(z[: e[1]]).max(initial=0.0):
            unshifted = self._unshifted(res.basis, a, gap_free, tau_free, tau_prev, c, mu, e0)
            if unshifted is not None:
                z = unshifted
        return z

    def _recovered(self, z: np.ndarray, free: tuple[np.ndarray, np.ndarray],
                   gap_free: np.ndarray, tau_free: np.ndarray, res) -> ContactSolution:
        """The ContactSolution of z (`_lemkes_z`): p, the slips and alpha from z, q = H
        (tau_prev - tau_free - C_tn p + s+ - s- - T alpha) on the frictional pairs."""
        m, f, e = self.m, self.fric, self.edges
        p = z[: e[1]]
        sp_, sm_ = z[e[1]: e[2]], z[e[2]: e[3]]
        alpha = z[e[3]: e[4]] - z[e[4]: e[5]]
        q = np.zeros(m)
        splus = np.zeros(m)
        sminus = np.zeros(m)
        if self.mf:
            cnt_f = self.c[:m, m:][:, f]
            rhs = free[1][f] - cnt_f.T @ p + sp_ - sm_ - self.tm @ alpha
            q[f] = self.apply_h(rhs)
            splus[f], sminus[f] = sp_, sm_
        return self._solution(p, q, alpha, gap_free, tau_free, splus, sminus, res)

    def _polished_kept(self, sol: ContactSolution, basis: np.ndarray,
                       free: tuple[np.ndarray, np.ndarray], a: np.ndarray, c: np.ndarray,
                       mu: np.ndarray, e0: np.ndarray) -> tuple[np.ndarray, ...] | None:
        """`_polished` from Lemke's basis, kept only when it keeps the law
        (`_law_error`) at least as well as Lemke's answer sol (or within POLISH_REL)."""
        settled = self._polished(basis, free, a, c, mu, e0)
        if settled is not None and self._law_error(settled[:3], free, a, c, mu) > max(
                self._law_error((sol.p, sol.q, sol.alpha), free, a, c, mu), POLISH_REL):
            return None
        return settled

    def _settled_solution(self, settled: tuple[np.ndarray, ...], sol: ContactSolution,
                          gap_free: np.ndarray, tau_free: np.ndarray, tau_prev: np.ndarray,
                          res) -> ContactSolution:
        """The ContactSolution of a settled re-solve (p, q, alpha, closed, slip+, slip-),
        its slip variables from its own motion tau - tau_prev on its slipping pairs."""
        p, q, alpha, _, sp_b, sm_b = settled
        moved = self._solution(p, q, alpha, gap_free, tau_free, sol.slip_plus,
                               sol.slip_minus, res).tau - tau_prev
        splus = np.where(sp_b, np.maximum(moved, 0.0), 0.0)
        sminus = np.where(sm_b, np.maximum(-moved, 0.0), 0.0)
        return self._solution(p, q, alpha, gap_free, tau_free, splus, sminus, res)

    def _settled_inaccurate(self, res, free: tuple[np.ndarray, np.ndarray], a: np.ndarray,
                            c: np.ndarray, mu: np.ndarray,
                            e0: np.ndarray) -> tuple[np.ndarray, ...] | None:
        """`_polished` from the final basis of Lemke's 'inaccurate' result res, before the
        mixed-integer search: when its pivots settle on an answer that keeps the law
        (`_law_error`, its equations too) to DEFAULT_TOL, Lemke's own tolerance, res
        becomes 'solved', its residual that law error and its message says so, and the
        answer is returned; else None, res as it was. Lemke's answer
        failed its check by round-off of the condensed LCP, its basis is often right or a
        few pivots off (two_blocks.toml, the upper block floating at E = 1e13 on 1e3, mu =
        0.5, node-to-segment, the tangential cycle's step 3: 'inaccurate', 1.3e-7 > 1e-9;
        settled in 5 solves, p and q within 1.3e-6 of E = 1e12's largest p, where the
        search spent 77 s and found none: README "Hard cases")."""
        if res.status != "inaccurate" or res.basis is None:
            return None
        settled = self._polished(np.asarray(res.basis, dtype=bool), free, a, c, mu, e0)
        if settled is None:
            return None
        # judged on the law itself (its equations too: a near-singular state system keeps
        # the signs `_polished` checks and not its gaps), at Lemke's own tolerance; the
        # step's `lcp_residual` is then this measure, not Lemke's failed check
        law = self._law_error(settled[:3], free, a, c, mu)
        if not law <= DEFAULT_TOL:
            return None
        res.status, res.residual = "solved", law
        res.message += ("; its pair states re-solved from the compliance settle (the answer "
                        f"is theirs, not Lemke's; law error {law:.3g})")
        return settled

    def _accuracy(self, closed: np.ndarray, sp_b: np.ndarray, sm_b: np.ndarray,
                  mu: np.ndarray) -> float:
        """The relative accuracy that round-off allows the answer on these pair states
        (m,) bool each (closed; slip+ and slip- of the frictional pairs): eps x the
        condition estimate of the system of `_on_states` (unit diagonal scaling) over the
        unknowns it does not fix alone: p and q of the closed pairs and the mode
        amplitudes (an open pair's p = -a and its q = 0 or +-(c - mu a) are exact), with a
        unit tie on the dependent tangential directions (`tangential_parts`); of p and q
        alone when only mode amplitudes are not unique (a mode no closed pair holds slides
        on slipping pairs: multibody.toml --sd 1 --mesh-size 1.2 read 1.0, "off by up to 1",
        with its forces unique; `determined_accuracy`). It grows with the stiffness
        contrast between bodies in contact: a stiff body's share of C is round-off beside a
        soft one's (README "Hard cases", `lcp_accuracy`)."""
        m, r = self.m, self.r
        keep = np.concatenate([closed, closed, np.ones(r, dtype=bool)])
        if not keep.any():  # every pair open (or none): the answer is exact
            return 0.0
        zero = np.zeros(m)
        k = self._state_system(closed, sp_b, sm_b & ~sp_b, self._fric_mask(), (zero, zero),
                               zero, zero, mu, np.zeros(r))[0]
        if self.null_t.shape[1]:  # dependent directions (a force split that is not unique):
            # their unit tie, so that only the determined part is judged
            stick = ~sp_b[self.fric] & ~sm_b[self.fric] & closed[self.fric]
            rows = m + self.fric[stick]
            nt = self.null_t[stick]
            k[np.ix_(rows, rows)] += nt @ nt.T
        free = np.arange(keep.sum()) >= 2 * closed.sum()  # the mode amplitudes
        return determined_accuracy(k[np.ix_(keep, keep)], free)

    def _searched(self, res, ms: np.ndarray, qs: np.ndarray):
        """Lemke's failed result `res` on the scaled LCP (ms, qs) of a problem with floating
        modes, or Lemke's answer from a basis of `complementary_basis` when one solves
        it. With free mode amplitudes and friction the LCP is not copositive-plus: its
        secondary ray does not prove that there is no equilibrium (multibody.toml --sd 1
        --mesh-size 1.2 has one, with 22 hourglass modes held by friction). The search
        bounds each slip by `_slip_widen` times MIP_BOUND: in its own compliance's units."""
        tried: list = []

        def accept(basis: np.ndarray) -> bool:
            tried.append(self.solver(ms, qs, basis=basis, cold_start=False,
                                     cache=self.cache))
            return tried[-1].status == "solved"

        basis, found = complementary_basis(ms, qs, accept, widen=self._slip_widen())
        if basis is not None:
            again = tried[-1]
            again.pivots += res.pivots
            again.message = (f"{res.message}; {found} (Lemke's ray proves nothing with "
                             f"free modes and friction); {again.message}")
            return again
        if tried:
            found += (f"; Lemke from the search's last candidate basis ended "
                      f"'{tried[-1].status}'")  # (before: "(Lemke: ...)" after the count)
        res.message += f"; {found}"
        return res

    def _slip_widen(self) -> np.ndarray:
        """(n,) the factor sqrt(C_tt,ii) / d_i (>= 1 on the slip unknowns s+-, 1 elsewhere)
        on the mixed-integer search's bound: a slip s of the pair's own compliance scale
        sqrt(C_tt,ii) counts 1, as p at sqrt(A_ii) does. Lemke's scaling d = 1 / sqrt(H_ii),
        H = C_tt^-1, measures the slip by the stiffest direction of C_tt instead: where a
        stiff floating body's slave nodes outnumber the soft master's (node-to-segment on
        two_blocks.toml, 11 on 9, E = 1e10..1e12 on 1e3), H_ii grows with E and the
        answer's scaled slip with sqrt(E) (822, 2.4e3, 7.6e3 at step 3 of a tangential
        cycle): the bound of 1e3 excluded it at 1e11, where Lemke ended on its ray."""
        e, f = self.edges, self.fric
        widen = np.ones(self.size)
        own = np.sqrt(np.abs(np.diagonal(self.c)[self.m:][f]))
        for k in (1, 2):
            widen[e[k]:e[k + 1]] = np.maximum(own / self.scaling[e[k]:e[k + 1]], 1.0)
        return widen

    def _solution(self, p: np.ndarray, q: np.ndarray, alpha: np.ndarray,
                  gap_free: np.ndarray, tau_free: np.ndarray, splus: np.ndarray,
                  sminus: np.ndarray, res) -> ContactSolution:
        """The ContactSolution of forces (p, q, alpha): gap and tau recovered from C."""
        gap, tau, gap_terms, tau_terms = self._kinematics(p, q, alpha, gap_free, tau_free)
        return ContactSolution(p, q, gap, tau, splus, sminus, alpha, res.pivots, res.status,
                               res.basis, res.residual, res.message,
                               motion_size(*gap_terms, *tau_terms))

    def _kinematics(self, p: np.ndarray, q: np.ndarray, alpha: np.ndarray,
                    gap_base: np.ndarray, tau_base: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, tuple, tuple]:
        """`pair_kinematics` of this LCP's pairs (C with the fixed pairs' ties; C_n lam and
        C_t lam as two products)."""
        m, lam = self.m, np.concatenate([p, q])
        return pair_kinematics((self.c[:m] @ lam, self.c[m:] @ lam), self.nm,
                               self.tm_all if self.r else None, alpha, gap_base, tau_base)

    def _off_basis(self, sol: ContactSolution, basis: np.ndarray, tau_prev: np.ndarray,
                   free: tuple[np.ndarray, np.ndarray], c: np.ndarray,
                   mu: np.ndarray) -> bool:
        """Whether Lemke's answer contradicts its own basis by more than POLISH_GATE of a
        pair's motion terms: a closed pair (p + a basic) with a gap, an open one (p = -a)
        with a negative gap, a frictional pair without a basic slip variable that moved
        tangentially; or of its forces: such a sticking pair with |q| over its bound
        c + mu p (c, mu (m,); at a contrast of 1e11 one was 3.3e-5 over, `kkt` 3.3e-5, and
        the load step's states differed from those at 1e6), beyond POLISH_GATE of its
        forces plus `_q_reach` (an open pair without a bond has bound 0 and no forces: its
        q of 1e-13, round-off, fired on multibody.toml --sd 1 --mesh-size 1.2, and the
        re-solve's tabu step settled on other states with a hourglass amplitude of 316 for
        9.4 and `kkt_pairs` 2.8e-11 for 1.7e-13); or a slipping pair off its side of the
        cone (`_slip_off`). The gap and motion tolerances and `_q_reach` are of the step's
        motion terms (free = (gap_free, tau_prev - tau_free), the LCP's constant: Lemke's
        q is H times them), not of `sol.motion`, whose tau terms hold the absolute
        tau_free: a pair slid 1e2 before the step read a sticking q 1e-6 over its bound as
        round-off (reviewer `review15`), and a pair slid 1e4 a closed gap or a sticking
        motion 1e-4 of the step's motion (session 30); the motion tau - tau_prev is
        judged beyond its own round-off, 4 eps max(|tau|, |tau_prev|), too. A floating
        body's T alpha is its whole slide (alpha is not the step's): with tau_free -
        tau_prev one term, the step's rigid motion, and 4 eps |T| |alpha| in that
        round-off (one slid 1e4 hid a gap or motion of 1e-7, reviewer `review19`); q,
        H times the LCP's constant less T alpha, carries |H| times that round-off beside
        `_q_reach` of the step's motion (T alpha a term of it hid a sticking q 1e-4 over
        its bound at 1e4).
        Round-off of the condensed LCP (`_polished`); elsewhere Lemke's answer is kept
        as it is."""
        m, f = self.m, self.fric
        _, _, gap_terms, tau_terms = self._kinematics(sol.p, sol.q, sol.alpha, free[0],
                                                      -free[1])
        # the step's, not the slide so far: a floating body's T alpha holds its slide so
        # far (alpha is its whole motion) as tau_prev does, and with tau_free - tau_prev
        # adds up to the step's rigid motion (one term)
        rigid = tau_terms[0] + tau_terms[2] if self.r else tau_terms[0]
        motion = motion_size(*gap_terms, rigid, tau_terms[1])
        tol = POLISH_GATE * motion
        _, plus, minus = self._basis_states(basis)
        stick = np.zeros(m, dtype=bool)
        stick[f] = ~plus[f] & ~minus[f]
        moved = sol.tau - tau_prev
        # (tau, tau_prev and T alpha hold the slide so far: moved carries its round-off)
        slid = np.maximum(np.abs(sol.tau), np.abs(tau_prev))
        if self.r:
            slid = np.maximum(slid, np.abs(self.tm_all) @ np.abs(sol.alpha))
        round_t = 4 * np.finfo(float).eps * slid
        tol_t = tol + round_t
        bound = c + mu * sol.p
        forces = np.abs(c) + np.abs(mu * sol.p) + np.abs(sol.q)
        reach = self._q_reach(motion)
        if self.r and f.size:  # q = H (tau_prev - tau_free - T alpha ...): H times their
            # round-off, |H| |that of T alpha|, in the units POLISH_GATE judges forces in
            reach[f] += np.abs(self.h) @ round_t[f] / POLISH_GATE
        over = np.abs(sol.q) - bound > POLISH_GATE * (forces + reach)
        closed = basis[:m]
        return bool((closed & (np.abs(sol.gap) > tol)).any() or
                    (~closed & (sol.gap < -tol)).any() or
                    (stick & ((np.abs(moved) > tol_t) | over)).any() or
                    self._slip_off(sol.q, moved, bound, forces + reach, tol_t, plus, minus).any())

    def _slip_off(self, q: np.ndarray, moved: np.ndarray, bound: np.ndarray,
                  forces: np.ndarray, tol: np.ndarray, plus: np.ndarray,
                  minus: np.ndarray) -> np.ndarray:
        """(m,) bool: the pairs with one basic slip variable (plus: slip+, q = -bound,
        tau - tau_prev = moved >= 0; minus: slip-) whose answer leaves it by more than
        POLISH_GATE: moved against it beyond tol (m,) (`_off_basis`: that of the step's
        motion terms, plus the round-off of moved), or q off -+bound
        beyond that of forces: the pair's forces plus the force the step's motion terms
        make through its own tangential compliance (`_q_reach`: q is recovered as H times
        that motion, so its round-off is of that size where the pair's forces are not,
        e.g. an open pair's q at bound 0). Node-to-segment at a contrast of 1e10
        (two_blocks.toml, the upper block floating, mu = 0.5, a tangential cycle) gave an
        open pair q = -4.1e-4, `kkt` 3.4e-5 and `kkt_pairs` 1.7e-4 with a warning; no gap
        or motion was off."""
        one = plus ^ minus
        side = np.where(plus, q + bound, q - bound)
        back = np.where(plus, moved < -tol, moved > tol)
        return one & (back | (np.abs(side) > POLISH_GATE * forces))

    def _q_reach(self, motion: np.ndarray, normal: bool = False) -> np.ndarray:
        """(m,) the force a pair's motion terms (motion (m,)) make through its own
        tangential compliance, motion / C_tt,ii (normal: C_nn,ii; 0 where it is 0): the
        size of the round-off of Lemke's q (p), recovered as H times motion, where the
        pair's own forces are zero (an open pair of no bond: bound c + mu p = 0)."""
        own = np.diagonal(self.c)[: self.m] if normal else np.diagonal(self.c)[self.m:]
        return np.divide(motion, own, out=np.zeros(self.m), where=own > 0)

    def _fric_mask(self) -> np.ndarray:
        """(m,) bool: the pairs with tangential unknowns (frictional)."""
        fric = np.zeros(self.m, dtype=bool)
        fric[self.fric] = True
        return fric

    def _basis_states(self, basis: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(closed, slip+, slip-) (m,) bool each, new arrays, read from an LCP basis
        (size,) bool: p basic, and the frictional pairs' s+ and s- basic (both may be)."""
        m, f, e = self.m, self.fric, self.edges
        plus, minus = np.zeros(m, dtype=bool), np.zeros(m, dtype=bool)
        plus[f], minus[f] = basis[e[1]: e[2]], basis[e[2]: e[3]]
        return basis[:m].copy(), plus, minus

    def _polished(self, basis: np.ndarray, free: tuple[np.ndarray, np.ndarray],
                  a: np.ndarray, c: np.ndarray, mu: np.ndarray,
                  e0: np.ndarray) -> tuple[np.ndarray, ...] | None:
        """(p, q, alpha, closed, slip+ mask, slip- mask) from the compliance C itself, not the
        LCP's condensed form (q = H x, H = C_tt^-1), on Lemke's final basis corrected by up
        to UNSHIFTED_PIVOTS block pivots. Where C_tt has near-null directions (a stiff body
        bonded on a soft one: eigenvalues 7e-13 beside 4e-4 at a contrast of 1e9) the
        condensed matrix cancels terms of H's size: Lemke's p, its residual round-off, was
        striped by the full adhesion (pair forces -20..24 for 1.4..2, two pairs at p = -a
        in its basis), gaps of 3e-9 read open and the bond broke. Per pair: gap = 0
        (closed) or p = -a (open); stick tau = tau_prev, slip+/- q = -+(c + mu p), q = 0
        without tangential unknowns; and the balance N^T p + T^T q = -e0. Block pivots
        flip every pair that leaves its signs; once a set of states comes back (they cycle:
        node-to-segment at a contrast of 1e9 flipped two pairs over their bound together,
        then both slid back, with period 3, and Lemke's p, 100% off, was kept) or after
        UNSHIFTED_PIVOTS of them, only the pair furthest off (`_flipped`); once those come
        back, only the first pair off (Murty's least-index rule), from where each rule
        before stopped; once that comes back too, the first state set one pair off from
        the current one not yet seen (`_unseen`, a tabu step); UNSHIFTED_PIVOTS +
        SINGLE_FLIPS solves in all. A rule's cycle is
        a set of states it saw itself (one seen under the rule before leads elsewhere).
        A set of states whose system is singular (a floating body's mode that no closed
        or sticking pair holds) counts as seen: the rule goes on from the last solved
        states (it gave up there: 6 of check_resolve's 3000 LCPs with one mode added).
        None (Lemke's answer kept) when Lemke's own states' system is singular or the
        pivots do not settle."""
        fric = self._fric_mask()
        closed, sp_b, sm_b = self._basis_states(basis)
        sm_b &= ~sp_b
        rules = iter(PIVOT_RULES)
        rule = next(rules)
        seen: set[bytes] = set()  # the states visited under this rule
        last = None  # the last set of states whose system was solved, and its flips
        for _ in range(UNSHIFTED_PIVOTS + SINGLE_FLIPS):
            seen.add(_state_key((closed, sp_b, sm_b)))
            x = self._on_states(closed, sp_b, sm_b, fric, free, a, c, mu, e0)
            if x is None:  # singular (e.g. no closed pair holds a floating mode): back
                if last is None:  # to the last solved states, whose flip is now seen
                    return None
                (closed, sp_b, sm_b), flips = last
            else:
                flips = self._basis_errors(x, closed, sp_b, sm_b, fric, free, a, c, mu)
                if flips is None:
                    return (*x, closed, sp_b, sm_b)
                last = (closed, sp_b, sm_b), flips
            new = _flipped((closed, sp_b, sm_b), flips, rule)
            # a rule's states come back (it cycles) or block pivots ran UNSHIFTED_PIVOTS:
            # the next rule from the current states (a state seen under another rule is
            # no cycle of this one: its successor differs)
            while _state_key(new) in seen or (
                    rule == "block" and len(seen) >= UNSHIFTED_PIVOTS):
                if rule == "least":  # the last rule: the first unseen of the pairs' states
                    new = _unseen((closed, sp_b, sm_b), flips[3] > 1.0, fric, seen)
                    if new is None:
                        return None
                    break
                rule = next(rules, None)
                if rule is None:
                    return None
                seen = {_state_key((closed, sp_b, sm_b))}
                new = _flipped((closed, sp_b, sm_b), flips, rule)
            closed, sp_b, sm_b = new
        return None

    def _on_states(self, closed: np.ndarray, sp_b: np.ndarray, sm_b: np.ndarray,
                   fric: np.ndarray, free: tuple[np.ndarray, np.ndarray], a: np.ndarray,
                   c: np.ndarray, mu: np.ndarray,
                   e0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """(p, q, alpha) of the linear system of one set of pair states (`_polished`),
        solved with unit diagonal scaling; None when singular or not finite."""
        k, rhs, size = self._state_system(closed, sp_b, sm_b, fric, free, a, c, mu, e0)
        m = self.m
        try:
            x = np.linalg.solve(k, rhs) / size
        except np.linalg.LinAlgError:
            return None
        if not np.isfinite(x).all():
            return None
        return x[:m], x[m: 2 * m], x[2 * m:]

    def _state_system(self, closed: np.ndarray, sp_b: np.ndarray, sm_b: np.ndarray,
                      fric: np.ndarray, free: tuple[np.ndarray, np.ndarray], a: np.ndarray,
                      c: np.ndarray, mu: np.ndarray,
                      e0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(K / size size^T, rhs / size, size): the linear system of `_on_states` in the
        unknowns x * size, x = (p, q, alpha) (2m + r,), scaled to unit diagonal (the
        column's largest entry where the diagonal is zero: the balance rows)."""
        m, r = self.m, self.r
        gap_free, dtau = free
        stick = fric & ~sp_b & ~sm_b
        slipping = sp_b | sm_b
        k = np.zeros((2 * m + r, 2 * m + r))
        rhs = np.zeros(2 * m + r)
        ident = np.eye(m)
        k[:m, : 2 * m] = np.where(closed[:, None], self.c[:m], 0.0)
        k[:m, :m] += np.where(closed[:, None], 0.0, ident)
        k[:m, 2 * m:] = np.where(closed[:, None], self.nm, 0.0)
        rhs[:m] = np.where(closed, -gap_free, -a)
        sign = np.where(sp_b, -1.0, 1.0)
        k[m: 2 * m, : 2 * m] = np.where(stick[:, None], self.c[m:], 0.0)
        k[m: 2 * m, 2 * m:] = np.where(stick[:, None], self.tm_all, 0.0)
        k[m: 2 * m, m: 2 * m] += np.where(stick[:, None], 0.0, ident)
        k[m: 2 * m, :m] -= np.where(slipping[:, None], (sign * mu)[:, None] * ident, 0.0)
        rhs[m: 2 * m] = np.where(stick, dtau, np.where(slipping, sign * c, 0.0))
        k[2 * m:, : 2 * m] = np.vstack([self.nm, self.tm_all]).T
        rhs[2 * m:] = -e0
        size = np.sqrt(np.abs(np.diagonal(k)))
        size = np.where(size > 0, size, np.sqrt(np.abs(k).max(axis=0) + 1e-300))
        return k / size[:, None] / size[None, :], rhs / size, size

    def _basis_errors(self, x: tuple[np.ndarray, np.ndarray, np.ndarray],
                      closed: np.ndarray, sp_b: np.ndarray, sm_b: np.ndarray,
                      fric: np.ndarray, free: tuple[np.ndarray, np.ndarray], a: np.ndarray,
                      c: np.ndarray, mu: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        """None when x = (p, q, alpha) keeps the states' signs, each to POLISH_REL of the
        pair's own terms (p + a >= 0 closed, gap >= 0 open, |q| <= c + mu p stick, slip in
        its sign slipping); else (normal flips, new slip+ mask, new slip- mask, each pair's
        largest violation over its tolerance (m,): above 1 where it left its signs)."""
        p, q, alpha = x
        gap, slip, fs, gs, ts = self._pair_scales(x, free, a, c, mu)
        ftol, gtol, ttol = POLISH_REL * fs, POLISH_REL * gs, POLISH_REL * ts
        bound = c + mu * p
        stick = fric & ~sp_b & ~sm_b
        off_n = np.where(closed, -(p + a) / ftol, -gap / gtol)
        off_t = np.where(stick, (np.abs(q) - bound) / ftol,
                         np.where(sp_b, -slip, np.where(sm_b, slip, 0.0)) / ttol)
        flip_n = off_n > 1.0
        over = stick & (off_t > 1.0)
        back = ~stick & fric & (off_t > 1.0)
        if not (flip_n.any() or over.any() or back.any()):
            return None
        new_sp = (sp_b & ~back) | (over & (q < 0))
        new_sm = (sm_b & ~back) | (over & (q > 0))
        return flip_n, new_sp, new_sm, np.maximum(off_n, off_t)

    def _pair_scales(self, x: tuple[np.ndarray, np.ndarray, np.ndarray],
                     free: tuple[np.ndarray, np.ndarray], a: np.ndarray, c: np.ndarray,
                     mu: np.ndarray) -> tuple[np.ndarray, ...]:
        """(gap, slip, force size, gap size, tau size), (m,) each, of x = (p, q, alpha) on
        the step's free motion free = (gap_free, tau_prev - tau_free): slip = tau -
        tau_prev, the pair's own force terms (`_force_size`) and its gap's and tau's
        motion terms (`motion_size`, + 1e-300): the scales `_basis_errors` and
        `_law_error` judge each pair's signs against."""
        p, q, alpha = x
        gap, slip, gap_terms, tau_terms = self._kinematics(p, q, alpha, free[0], -free[1])
        return (gap, slip, _force_size(p, q, a, c, mu), motion_size(*gap_terms) + 1e-300,
                motion_size(*tau_terms) + 1e-300)

    def _law_error(self, x: tuple[np.ndarray, np.ndarray, np.ndarray],
                   free: tuple[np.ndarray, np.ndarray], a: np.ndarray, c: np.ndarray,
                   mu: np.ndarray) -> float:
        """The largest violation of the interface law by x = (p, q, alpha), whatever the
        pair states, each pair against its own terms (as `_basis_errors`, without
        POLISH_REL; the slip against all its motion terms, as `_off_basis`): p + a >= 0,
        gap >= 0, min(p + a, gap) = 0; frictional pairs |q| <= c + mu p and min(|slip|,
        |q + sign(slip) (c + mu p)|) = 0 (stick or slide on the cone); p and q against
        its forces plus the force its motion terms make through its own compliance
        (motion / C_nn,ii, `_q_reach`: their round-off where the pair has no force, e.g.
        an open pair's p of 1e-15 at a = 0). `solve` keeps Lemke's answer where the re-solve's is
        worse by this and above POLISH_REL: multibody.toml --sd 1 --mesh-size 1.2, before
        the gate judged q with `_q_reach`, re-solved step 3 onto other states at 2.9e-11
        (a hourglass amplitude of 316 for 9.4) where Lemke's answer kept the law to
        1.9e-13."""
        p, q, alpha = x
        gap, slip, fs, gs, ts = self._pair_scales(x, free, a, c, mu)
        motion = np.maximum(gs, ts)  # (as `_off_basis`'s slip test)
        pa = (p + a) / (fs + self._q_reach(motion, normal=True))
        g = gap / gs
        err = np.maximum(np.maximum(-pa, -g), np.abs(np.minimum(pa, g)))
        bound = c + mu * p
        qs = fs + self._q_reach(motion)  # (q's round-off at bound 0)
        on_cone = np.abs(q + np.sign(slip) * bound) / qs
        fric = np.maximum((np.abs(q) - bound) / qs,
                          np.minimum(np.abs(slip) / motion, on_cone))
        err = np.where(self._fric_mask(), np.maximum(err, fric), err)
        return float(err.max(initial=0.0))

    def _unshifted(self, basis: np.ndarray, a: np.ndarray, gap_free: np.ndarray,
                   tau_free: np.ndarray, tau_prev: np.ndarray, c: np.ndarray,
                   mu: np.ndarray, e0: np.ndarray) -> np.ndarray | None:
        """(p, s+, s-, alpha+, alpha-) (unscaled; p compression positive) on Lemke's final
        basis, solved for p rather than p + a. Lemke's unknown p + a holds p only to the
        round-off of a, so a bond far stronger than its forces (a = 1e12 against forces of
        1) lost p altogether: the pairs read open and all debonded at the first pull. With
        y = z - a on the normal rows, w = M y + q0 (q0: the constant vector at a = 0), and
        the basic y solve M_BB y_B = -(q0_B + M_BN y_N), y_N = -a on the nonbasic normal
        rows (open pairs), 0 elsewhere. None (Lemke's z kept) when that system is singular
        or its answer still leaves the basis's signs by more than round-off after
        UNSHIFTED_PIVOTS block pivots."""
        d, m = self.scaling, self.m
        q0 = d * self.row_scale * self.constant(gap_free, tau_free, tau_prev,
                                                np.zeros_like(a), c, mu, e0)
        shift = np.zeros(self.size)
        shift[:m] = a / d[:m]  # a in the scaled unknowns
        b = np.asarray(basis, dtype=bool).copy()
        # Lemke's basis was found on p + a, to round-off of the largest a: where it is wrong
        # for a pair of small a, a few block pivots (basic z < 0 leaves, nonbasic w < 0
        # enters) on the exact unshifted system correct it
        for _ in range(UNSHIFTED_PIVOTS):
            y, w = self._on_basis(b, shift, q0)
            if y is None:
                return None
            # sign checks against the unshifted scales (forces, not a: p + a >= 0 of a weak
            # bond beside a strong one was judged against the strong one's a before)
            z_bad = b & (y + shift < -1e-9 * max(float(np.abs(y[b]).max(initial=0.0)), 1e-300))
            # w_i = sum_j M_ij y_j + q0_i against the size of its own terms (not the
            # largest w: a strength c of 1e12 in one pair's slip rows hid a penetration)
            terms = np.abs(q0) + np.abs(self.M_scaled) @ np.abs(y)
            w_bad = ~b & (w < -1e-9 * np.maximum(terms, 1e-300))
            if not (z_bad.any() or w_bad.any()):
                break
            b ^= z_bad | w_bad
        else:
            return None
        y[m:] = np.maximum(y[m:], 0.0)
        return d * y

    def _on_basis(self, b: np.ndarray, shift: np.ndarray,
                  q0: np.ndarray) -> tuple[np.ndarray | None, np.ndarray]:
        """(y, w) of the scaled LCP on basis b (z basic) without the shift: y_N = -shift,
        M_BB y_B = -(q0_B + M_BN y_N), w = M y + q0; y None when singular or not finite."""
        ms, nb = self.M_scaled, ~b
        y = np.where(b, 0.0, -shift)
        try:
            y[b] = np.linalg.solve(ms[np.ix_(b, b)], -(q0[b] + ms[np.ix_(b, nb)] @ y[nb]))
        except np.linalg.LinAlgError:
            return None, y
        w = ms @ y + q0
        if not (np.isfinite(y).all() and np.isfinite(w).all()):
            return None, w
        return y, w
