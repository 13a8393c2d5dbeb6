"""Candidate pairs: each solve's LCP holds only the pairs that can close (METHOD.md 4-5).

A pair that stays open carries no force (p = q = 0: its adhesion and strength are zero
unless it is bonded, and a bonded pair is always a candidate), so the full LCP's answer is
the answer of the LCP over the other pairs, with C restricted to them, plus zero forces on
the open ones. The candidates are predicted: pairs that are bonded, that carried a force
or were candidates before, and that the free gap brings within a margin of contact. After
the solve every other pair's gap is computed with the stored compliance (one product); a
pair that would penetrate joins and the solve is repeated, warm started; a solve that
fails (e.g. a floating body's equilibrium needs a pair that was not predicted) is repeated
over every pair. The answer is the full LCP's (to round-off), at the cost of an LCP over
the pairs near contact.

Bases travel in the full LCP's layout (p of every pair, s+ and s- of every frictional
pair, alpha+ and alpha-), so that warm starts survive changes of the candidate set.
"""

from __future__ import annotations

import numpy as np

from app.interface.coulomb import ContactLCP, ContactSolution, motion_size, pair_kinematics
from app.lcp import lemke
from app.lcp.solvers import LCPSolver


def candidate_pairs(configured: bool) -> bool:
    """Whether the LCP is solved over candidate pairs: the PETSc option
    -contact_candidate_pairs, else `analysis.candidate_pairs` (default true)."""
    from petsc4py import PETSc

    return bool(PETSc.Options().getBool("contact_candidate_pairs", configured))


def lcp_cache() -> bool:
    """Whether the contact LCP keeps a `app.lcp.matrix_cache.MatrixCache` over the run's
    solves: the PETSc option -contact_lcp_cache (default true; 0 for the solves without
    it, e.g. to time them: scripts/bench_debond.py)."""
    from petsc4py import PETSc

    return bool(PETSc.Options().getBool("contact_lcp_cache", True))


MARGIN = 0.1
"""Pairs whose free gap is below MARGIN x the deepest free penetration are candidates."""


class CandidateLCP:
    """The contact LCP of a run, solved over candidate pairs (same `solve` as ContactLCP).

    c: (2m, 2m) compliance, normal rows first; mu (m,); frictional (m,) bool;
    n_modes = G_n R (m, r), t_modes = G_t R (m, r) for floating bodies (their rigid motion
    is not in the free gap: the check after the solve includes it, and a sub-LCP that
    fails is solved again over every pair); cache: as ContactLCP's.
    """

    def __init__(self, c: np.ndarray, mu: np.ndarray, frictional: np.ndarray,
                 n_modes: np.ndarray | None = None, t_modes: np.ndarray | None = None,
                 solver: LCPSolver = lemke, cache: bool = True):
        self.solver, self.use_cache = solver, cache
        m = mu.size
        self.m, self.c, self.mu, self.frictional = m, c, mu, frictional
        self.fric = np.flatnonzero(frictional)
        self.mf = self.fric.size
        self.r = 0 if n_modes is None else n_modes.shape[1]
        self.nm = np.zeros((m, 0)) if n_modes is None else n_modes
        self.tm_all = np.zeros((m, 0)) if t_modes is None else t_modes
        self.tm = self.tm_all[self.fric]
        self.n_modes, self.t_modes = n_modes, t_modes
        self.fric_rank = np.full(m, -1, dtype=np.int64)
        self.fric_rank[self.fric] = np.arange(self.mf)
        self.full_size = m + 2 * self.mf + 2 * self.r
        self.cand = np.zeros(m, dtype=bool)
        self._sub: tuple[bytes, ContactLCP, np.ndarray] | None = None
        self.size = 0  # size of the LCP of the last solve
        self.dependent_tangential = 0
        self.candidates_added = 0  # pairs added by the check after a solve (whole run)

    # ---- the LCP over a candidate set ------------------------------------------------
    def layout(self, cand: np.ndarray) -> np.ndarray:
        """Full-layout index of each unknown of the LCP over `cand` (its own layout)."""
        m, mf, r = self.m, self.mf, self.r
        idx = np.flatnonzero(cand)
        fr = self.fric_rank[idx]
        fr = fr[fr >= 0]
        base = m + 2 * mf
        return np.concatenate([idx, m + fr, m + mf + fr, base + np.arange(r),
                               base + r + np.arange(r)]).astype(np.int64)

    def sub_lcp(self, cand: np.ndarray) -> tuple[ContactLCP, np.ndarray]:
        """(ContactLCP over the pairs in cand, its layout map); cached for the last set."""
        key = cand.tobytes()
        if self._sub is not None and self._sub[0] == key:
            return self._sub[1], self._sub[2]
        idx = np.flatnonzero(cand)
        rows = np.concatenate([idx, self.m + idx])
        lcp = ContactLCP(self.c[np.ix_(rows, rows)], self.mu[idx], self.frictional[idx],
                         None if self.n_modes is None else self.n_modes[idx],
                         None if self.t_modes is None else self.t_modes[idx], self.solver,
                         self.use_cache)
        lay = self.layout(cand)
        self._cols = np.ascontiguousarray(self.c[:, rows])  # (2m, 2 |cand|) for `_expand`
        self._sub = (key, lcp, lay)
        return lcp, lay

    def predict(self, gap_free: np.ndarray, a: np.ndarray, c: np.ndarray) -> np.ndarray:
        """Candidates for a solve: the earlier ones, bonded pairs (a or c nonzero) and pairs
        whose free gap is below MARGIN x the deepest free penetration."""
        depth = max(0.0, -float(gap_free.min(initial=0.0)))
        return self.cand | (a != 0) | (c != 0) | (gap_free <= MARGIN * depth)

    # ---- solve --------------------------------------------------------------------------
    def solve(self, gap_free: np.ndarray, tau_free: np.ndarray, tau_prev: np.ndarray,
              a: np.ndarray, c: np.ndarray, mu: np.ndarray, e0: np.ndarray, *,
              basis: np.ndarray | list[np.ndarray] | None = None,
              max_pivots: int | None = None) -> ContactSolution:
        """As `ContactLCP.solve` (bases in the full layout), over the candidate pairs."""
        cand = self.predict(gap_free, a, c)
        bases = [b for b in (basis if isinstance(basis, list) else [basis]) if b is not None]
        pivots = 0
        while True:
            sol, lay = self._solve_on(cand, gap_free, tau_free, tau_prev, a, c, mu, e0,
                                      bases, max_pivots)
            pivots += sol.pivots
            if sol.status != "solved":
                if cand.all():
                    break
                # e.g. a floating body whose equilibrium needs pairs that were not
                # predicted: the full LCP decides (and reports any failure)
                cand = np.ones(self.m, dtype=bool)
                continue
            scale = max(float(np.abs(gap_free).max(initial=0.0)), 1e-300)
            joins = ~cand & (sol.gap < -1e-13 * scale)
            if not joins.any():
                break
            cand = cand | joins
            self.candidates_added += int(joins.sum())
            bases = [sol.basis]  # the answer so far, new pairs nonbasic
        sol.pivots = pivots
        if sol.status == "solved":
            self.cand = cand | (sol.p != 0)
        return sol

    def _solve_on(self, cand, gap_free, tau_free, tau_prev, a, c, mu, e0, bases, max_pivots):
        lcp, lay = self.sub_lcp(cand)
        self.size, self.dependent_tangential = lcp.size, lcp.dependent_tangential
        idx = np.flatnonzero(cand)
        sub_bases = [b[lay] for b in bases]
        s = lcp.solve(gap_free[idx], tau_free[idx], tau_prev[idx], a[idx], c[idx], mu[idx],
                      e0, basis=sub_bases or None, max_pivots=max_pivots)
        return self._expand(s, idx, lay, gap_free, tau_free, tau_prev), lay

    def _expand(self, s: ContactSolution, idx, lay, gap_free, tau_free, tau_prev
                ) -> ContactSolution:
        """The sub-LCP's answer on every pair: zero forces on the others, their gap and
        tangential displacement from the stored compliance (one product)."""
        m = self.m
        p, q = np.zeros(m), np.zeros(m)
        p[idx], q[idx] = s.p, s.q
        cl = self._cols @ np.concatenate([s.p, s.q])  # (one product: see pair_kinematics)
        gap, tau, gap_terms, tau_terms = pair_kinematics(
            (cl[:m], cl[m:]), self.nm, self.tm_all if self.r else None, s.alpha, gap_free,
            tau_free)
        splus, sminus = np.zeros(m), np.zeros(m)
        splus[idx], sminus[idx] = s.slip_plus, s.slip_minus
        gap[idx], tau[idx] = s.gap, s.tau
        others = np.ones(m, dtype=bool)
        others[idx] = False
        slipping = others & self.frictional  # free pairs: the slip is the tangential motion
        dtau = tau - tau_prev
        splus[slipping] = np.maximum(dtau[slipping], 0.0)
        sminus[slipping] = np.maximum(-dtau[slipping], 0.0)
        basis = None
        if s.basis is not None:
            basis = np.zeros(self.full_size, dtype=bool)
            basis[lay] = s.basis
            fr = self.fric_rank[slipping]
            basis[m + fr] = splus[slipping] > 0
            basis[m + self.mf + fr] = sminus[slipping] > 0
        motion = motion_size(*gap_terms, *tau_terms)
        motion[idx] = np.maximum(motion[idx], s.motion)
        return ContactSolution(p, q, gap, tau, splus, sminus, s.alpha, s.pivots, s.status,
                               basis, s.residual, s.message, motion, s.accuracy)
