"""Load steps with bonding-debonding iterations (METHOD.md section 4), on rank 0.

Per pair and step the state is one of STATE_NAMES; a bonded pair that opens or slips
debonds for good (a = c = 0 from then on) and the step is solved again from its start
until no new pair debonds. The tangential history tau_prev is carried between steps.
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from app.interface.candidates import CandidateLCP, candidate_pairs, lcp_cache
from app.interface.coulomb import ContactLCP, ContactSolution
from app.interface.floating import split_modes
from app.interface.weak_modes import held_mode_entries
from app.lcp.coulomb_matrix import fixed_rows
from app.lcp.solvers import lcp_solver

if TYPE_CHECKING:
    from app.interface.contact import ContactSetup
    from app.interface.floating import FloatingModes

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
class WarmStart:
    """The LCP solver's warm-start state over the load steps: the last step's
    complementary basis and the one before it (tried when the last one fails)."""

    enabled: bool = True
    basis: np.ndarray | None = None
    older: np.ndarray | None = None

    def candidates(self) -> list[np.ndarray] | None:
        """The bases to try, newest first; None when warm starts are off."""
        if not self.enabled:
            return None
        return [b for b in (self.basis, self.older) if b is not None]

    def record(self, basis: np.ndarray | None) -> None:
        """The basis of a solved step becomes the newest; a different one ages."""
        if self.basis is not None and basis is not None and \
                not np.array_equal(self.basis, basis):
            self.older = self.basis
        self.basis = basis


@dataclass
class InterfaceHistory:
    """Per-pair state carried between steps."""

    a: np.ndarray  # (m,) current adhesion force (0 once debonded)
    c: np.ndarray  # (m,) current strength force
    bonded: np.ndarray  # (m,) bool
    tau_prev: np.ndarray  # (m,) relative tangential displacement at the end of last step
    debonded_step: np.ndarray  # (m,) int
    warm: WarmStart = field(default_factory=WarmStart)


STATE_REL = 1e-7
"""A pair opens (gap) or slips (slip variables) when that is above STATE_REL x the larger of
the problem's displacement scale (the loads' contact motion at their largest history factor,
`_applied_scale`) and the pair's own motion terms (`ContactSolution.motion`).
The scale alone is the loads' free contact motion: a load on a stiff body pressed on a
soft one barely moves the contact freely (1e-11 for E = 1e12 on E = 1e3), while its contact
forces and rigid modes move it by 8e-3 and leave gaps of 1e-10 of round-off; a tolerance of
1e-7 x 1e-11 read them as open, and a bond of 100 under tractions of 10 debonded at every
pair (two_blocks.toml with the upper E = 1e10; 3 of 11 pairs at E = 1e8 over 1e3)."""


def state_tolerance(tol: float, sol: ContactSolution) -> np.ndarray:
    """(m,) the gap and slip tolerance of each pair of one solution: tol (STATE_REL x the
    problem's scale) or STATE_REL x the pair's own motion terms, whichever is larger. The
    largest terms of the whole problem instead masked a bond's opening beside a soft
    contact (`app.interface.coulomb.motion_size`)."""
    return np.maximum(tol, STATE_REL * np.asarray(sol.motion, dtype=float))


CONTACT_REL = 1e-10
"""A pair counts in an interface's contact_length when its normal force exceeds this x
the problem's force scale (the round-off forces, 1e-15 of it, of a zone at zero load
counted as contact, by chance of their sign and differently on 1 and 2 ranks)."""


def pair_dissipation(sol: ContactSolution) -> np.ndarray:
    """(m,) frictional work of each pair in the step, -q x (slip increment) >= 0 (force
    per thickness x thickness x length)."""
    return -sol.q * (sol.slip_plus - sol.slip_minus)


def classify(sol: ContactSolution, bonded: np.ndarray, tol_gap: float | np.ndarray,
             tol_slip: float | np.ndarray, frictionless: np.ndarray | None = None,
             tau_prev: np.ndarray | None = None) -> np.ndarray:
    """State code per pair from a solution; tol_gap, tol_slip (length) scalars or per
    pair (m,) (`state_tolerance`).

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
               tol_slip: float, max_iterations: int | None = None) -> StepResult:
    """Solve one load step, with debonding iterations; updates `hist` on success.

    Each re-solve debonds at least one pair, so the bonded pairs + 1 solves (the default
    max_iterations) always settle; a smaller cap that does not is status 'debonding did not
    settle' (the history kept)."""
    t0 = time.perf_counter()
    pivots = 0
    a, c, bonded = hist.a.copy(), hist.c.copy(), hist.bonded.copy()
    if max_iterations is None:
        max_iterations = int(bonded.sum()) + 1
    debonded_step = hist.debonded_step.copy()
    basis = hist.warm.candidates()
    frictionless = np.ones(lcp.m, dtype=bool)
    frictionless[lcp.fric] = False

    def ended(sol: ContactSolution, iterations: int, status: str) -> StepResult:
        """The result of a step that stops without an answer (the history kept)."""
        return StepResult(sol, classify(sol, bonded, state_tolerance(tol_gap, sol),
                                        state_tolerance(tol_slip, sol), frictionless,
                                        hist.tau_prev), debonded_step, iterations, pivots,
                          time.perf_counter() - t0, 0.0, status)

    for it in range(1, max_iterations + 1):
        sol = lcp.solve(gap_free, tau_free, hist.tau_prev, a, c, mu, e0, basis=basis)
        pivots += sol.pivots
        if sol.status != "solved":
            return ended(sol, it, sol.status)
        new = _newly_debonded(sol, bonded, frictionless, hist.tau_prev,
                              state_tolerance(tol_gap, sol), state_tolerance(tol_slip, sol))
        if not new.any():
            break
        bonded &= ~new
        a[new] = 0.0
        c[new] = 0.0
        debonded_step[new] = step
        if hist.warm.enabled:
            basis = sol.basis
    else:
        sol.message = (f"{max_iterations} solves left pairs to debond (the last solve's "
                       "newly debonded pairs still carried their bond)")
        return ended(sol, max_iterations, "debonding did not settle")
    state = classify(sol, bonded, state_tolerance(tol_gap, sol),
                     state_tolerance(tol_slip, sol), frictionless, hist.tau_prev)
    dissipation = float(pair_dissipation(sol).sum())
    _commit(hist, sol, a, c, bonded, debonded_step)
    return StepResult(sol, state, debonded_step, it, pivots, time.perf_counter() - t0,
                      dissipation, "solved")


def _commit(hist: InterfaceHistory, sol: ContactSolution, a: np.ndarray, c: np.ndarray,
            bonded: np.ndarray, debonded_step: np.ndarray) -> None:
    """The solved step's bonds, its tangential motion and its basis become the history."""
    hist.a, hist.c, hist.bonded = a, c, bonded
    hist.debonded_step = debonded_step
    hist.tau_prev = sol.tau.copy()
    hist.warm.record(sol.basis)


def _newly_debonded(sol: ContactSolution, bonded: np.ndarray, frictionless: np.ndarray,
                    tau_prev: np.ndarray, tol_gap: float | np.ndarray,
                    tol_slip: float | np.ndarray) -> np.ndarray:
    """(m,) bool: the bonded pairs that the solution opens (gap > tol_gap) or slides (slip
    variables, or for pairs without tangential unknowns the tangential motion since
    tau_prev, above tol_slip)."""
    slipped = (sol.slip_plus + sol.slip_minus) > tol_slip
    # pairs without tangential unknowns (mu = c = 0: an adhesive bond with no shear
    # strength) slip whenever they move tangentially
    slipped |= frictionless & (np.abs(sol.tau - tau_prev) > tol_slip)
    return bonded & ((sol.gap > tol_gap) | slipped)


def _applied_scale(unit: list[np.ndarray], cases, g0: np.ndarray,
                   floor: float = 1e-300) -> float:
    """The largest contact motion the run's loads make, bounded per load case by its
    largest history factor x its unit motion (`unit`, (2m,) each), or the largest initial
    gap |g0|; `floor` when both are 0. (With `unit` the cases' summed |load| (1,) and no
    g0, the loads' force scale.) With the unit motion alone, the same pull written as
    uy = 1 with a history of 1e-3 .. 3e-3 got a state tolerance 1e3 times that of
    uy = 1e-3 with 1 .. 3: a bond pulled 3e-5 past its strength held at p = -a with its
    gap open by 5.5e-8 below that tolerance, where the other form debonded every pair
    (hard/pull_off.toml); a force of 1e9 x 1e-9 read contact_length 0 where 1 x 1 read 1."""
    sizes = [float(np.abs(np.asarray(case.history, dtype=float)).max(initial=0.0))
             * float(np.abs(x).max(initial=0.0)) for case, x in zip(cases, unit, strict=True)]
    return max(max(sizes, default=0.0), float(np.abs(g0).max(initial=0.0)), floor)


@dataclass
class StepSolution:
    """A load step's contact answer (rank 0; broadcast to every rank).

    status: "solved", or why not ("secondary ray", "unbalanced load", ...; `message`
    says more). When solved: lam (2m,) pair forces, normal rows then tangential;
    alpha (r,) floating-mode amplitudes; kinematics (2m,) the LCP's
    (gap - g0 - closed_overlap, tau);
    state, debonded_step (m,) int; tau_prev (m,) tau before the step; slip (m,)
    accumulated; a, c (m,) adhesion and strength forces in force at this step; f_scale
    and u_scale the problem's force and displacement scales (the largest load; the
    largest contact motion of a load case at its largest history factor, or initial gap,
    `_applied_scale`); compliance_diag (2m,) the diagonal
    of the compliance C (normal rows, then tangential), each pair's own scale for the
    per-pair law check (`app.output.pair_law`); load_scale the part of f_scale from the
    loads alone (without the bond's a and c: the per-pair kinematic scale); contact_work
    lam . G K^-1 G^T lam >= 0 (force x length), the pair forces' work through the motion
    they make, set by the driver's recovery (`app.output.pair_law.tied_coupling`);
    closed_overlap (m,) the overlap (> 0; < 0 a gap) the supports prescribe at pairs fixed
    on both sides that the step read as closed (within the state tolerance,
    `ContactStepper._prescribed_overlap`): the LCP solved those pairs at gap 0, the
    kinematics (and the field) keep the overlap, and the per-pair law allows it
    (`app.output.pair_law.pair_residuals`); info the step's summary.json entries.
    """

    status: str
    message: str = ""
    lam: np.ndarray | None = None
    alpha: np.ndarray | None = None
    kinematics: np.ndarray | None = None
    state: np.ndarray | None = None
    debonded_step: np.ndarray | None = None
    tau_prev: np.ndarray | None = None
    slip: np.ndarray | None = None
    a: np.ndarray | None = None
    c: np.ndarray | None = None
    f_scale: float = 0.0
    u_scale: float = 0.0
    compliance_diag: np.ndarray | None = None
    load_scale: float = 0.0
    contact_work: float = 0.0
    closed_overlap: np.ndarray | None = None
    info: dict = field(default_factory=dict)

    @property
    def solved(self) -> bool:
        return self.status == "solved"


@dataclass
class StepStart:
    """The interface history at the start of a load step, which a consistency re-solve
    of that step restarts from."""

    step: int
    history: InterfaceHistory
    slip: np.ndarray


class ContactStepper:
    """Rank-0 state of the contact problem over the load steps."""

    def __init__(self, setup: ContactSetup, c_mat: np.ndarray, cases, unit, rhs,
                 floating: FloatingModes | None):
        """unit: K^-1 b per load case; rhs: the load cases' right-hand sides b (forces
        with the Dirichlet lifting, zero on prescribed DOFs)."""
        self.setup = setup
        self.start: StepStart | None = None  # set by step(), used by refine()
        pr = setup.pairs
        m = pr.n_pairs
        self.m = m
        g = setup.g
        self.gu = [g @ uc for uc in unit]  # (2m,) per load case
        self.c_diag = np.diagonal(c_mat).copy()  # each pair's own scale (pair_law)
        # both sides prescribed (normal); a row of compliance exactly 0 too, which
        # `fixed_rows` finds none of when every normal row is (no scale in the block)
        self.fixed_n = fixed_rows(self.c_diag[:m])[0] | (self.c_diag[:m] <= 0.0)
        self.fixed_t = fixed_rows(self.c_diag[m:])[0] & setup.frictional  # (tangential)
        fit = np.array([i.interference for i in setup.cfg.interfaces], dtype=bool)
        self.fit = fit[pr.interface] if fit.size else np.zeros(m, dtype=bool)
        # (m,) the initial overlap a pair without `interference` has: within its
        # interface's penetration_tol (deeper is an input error), geometry that touches
        self.tolerated = np.where(self.fit, 0.0, np.maximum(-pr.g0, 0.0))
        # (m,) an interference fit's pairs whose node the supports hold on both sides
        # though their row is not round-off (mortar-standard's end row: `_prescribed_overlap`)
        self.held_fit = setup.held_n & self.fit & (setup.node_g0 < 0.0) & ~self.fixed_n
        # their node's own normal gap per load case (m,): the row's weighted gap reaches
        # free nodes, whose free motion is no part of the supports' overlap
        self.node_gu = ([setup.node_rows @ uc for uc in unit] if self.held_fit.any()
                        else [])
        self.v_keep = self.v_null = None
        self.floating = floating
        if floating is not None and floating.r.shape[1]:
            gr = g @ floating.r  # (2m, r)
            self.n_modes, self.t_modes = gr[:m], gr[m:]
            self.modes_full = (self.n_modes, self.t_modes)  # for the held-mode check
            self.v_keep, self.v_null = split_modes(self.n_modes,
                                                   self.t_modes[setup.frictional])
            if self.v_null.shape[1]:  # amplitudes no pair sees: left out of the LCP
                self.n_modes = self.n_modes @ self.v_keep
                self.t_modes = self.t_modes @ self.v_keep
            else:
                self.v_keep = self.v_null = None
            self.e0 = [floating.r.T @ b for b in rhs]
            self.mode_names = floating.names
        else:
            self.n_modes = self.t_modes = None
            self.e0 = [np.zeros(0) for _ in cases]
            self.mode_names = []
        lcp_class = CandidateLCP if candidate_pairs(setup.cfg.candidate_pairs) else ContactLCP
        self.lcp = lcp_class(c_mat, setup.mu, setup.frictional, self.n_modes, self.t_modes,
                             lcp_solver(setup.cfg.lcp_solver), lcp_cache())
        self.undetermined = [] if self.v_null is None else [
            self.mode_names[int(np.argmax(np.abs(v)))] for v in self.v_null.T]
        self.hist = InterfaceHistory(
            a=np.where(setup.bonded, setup.a, 0.0), c=np.where(setup.bonded, setup.c, 0.0),
            bonded=setup.bonded.copy(), tau_prev=np.zeros(m),
            debonded_step=np.zeros(m, dtype=np.int64),
            warm=WarmStart(enabled=setup.cfg.warm_start))
        self.slip = np.zeros(m)
        scale = _applied_scale(self.gu, cases, pr.g0)
        self.tol = STATE_REL * scale
        self.u_scale = scale if scale > 1e-300 else 0.0  # the KKT check's floor
        self.load_scale = _applied_scale([np.abs(b).sum(keepdims=True) for b in rhs],
                                         cases, np.zeros(0), floor=0.0)
        self.f_scale = max(self.load_scale, np.abs(self.hist.a).max(initial=0.0),
                           np.abs(self.hist.c).max(initial=0.0))

    def refine(self, step: int, cases, correction: np.ndarray) -> StepSolution | None:
        """Re-solve step `step` (the one `step()` solved last) with the free gap and
        tangential displacement shifted by `correction` (2m,) (the consistency refinement,
        see `app.condensation.recovery.mismatch`): from the history at the start of the
        step, warm-started from the last basis. None (the last good solve kept) if it
        fails."""
        if self.start is None or self.start.step != step:
            raise ValueError(f"refine(step={step}) needs step({step}) solved first")
        kept = (copy.deepcopy(self.hist), self.slip.copy())
        warm = self.hist.warm
        self.hist = copy.deepcopy(self.start.history)
        self.slip = self.start.slip.copy()
        self.hist.warm = warm
        out = self._solve(step, cases, correction)
        if not out.solved:
            self.hist, self.slip = kept
            return None
        return out

    def step(self, step: int, cases) -> StepSolution:
        """Solve load step `step` (0-based) from the current history, which it updates."""
        self.start = StepStart(step, copy.deepcopy(self.hist), self.slip.copy())
        return self._solve(step, cases, None)

    def _free_terms(self, step: int, cases) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
        """Free gap (m,), free tangential displacement (m,) and the floating-mode load e0 of
        step `step` (0-based); the last item names modes loaded but not resistable ("" if
        none)."""
        m = self.m
        gap_free = self.setup.pairs.g0.copy()
        tau_free = np.zeros(m)
        e0 = np.zeros(len(self.mode_names))
        for case, gu, e in zip(cases, self.gu, self.e0, strict=True):
            h = case.history[step]
            gap_free += h * gu[:m]
            tau_free += h * gu[m:]
            if e.size:
                e0 += h * e
        if self.v_null is not None and self.v_null.shape[1]:
            loaded = np.abs(self.v_null.T @ e0) > 1e-9 * max(self.f_scale, 1e-300)
            if loaded.any():
                names = ", ".join(n for n, k in zip(self.undetermined, loaded, strict=True)
                                  if k)
                return gap_free, tau_free, e0, names
            e0 = self.v_keep.T @ e0
        return gap_free, tau_free, e0, ""

    def _prescribed_overlap(self, gap_free: np.ndarray, step: int,
                            cases) -> tuple[str, np.ndarray]:
        """(why no contact force can close the step's free gap, or "", the overlap (m,)
        read as closed, < 0 a gap): a pair whose motion
        the supports fix on both sides (`fixed_rows`: its force moves nothing) and whose
        free gap is below -tol (the state tolerance) is held in the master by the
        prescribed displacements themselves (their push, or an interference fit's g0 they
        hold: `_overlap_message`). Its stiff tie (`app.lcp.coulomb_matrix.
        tie_fixed`) turned the overlap into a force of overlap / (1e-12 x the largest
        compliance): 9.9e10 on `shear_off.toml` with the block's sides moved 1e-4 more
        down than the base's, a run that completed. A free gap within -tol of 0 reads as
        closed (set to 0 in `gap_free`; that overlap is returned, `StepSolution.
        closed_overlap`): before, an overlap of 1e-13 gave that pair 99. So does a gap
        within +tol (returned as a negative overlap): before, a bonded pair pulled apart by
        1e-13 held at p = -a, its tie's pull capped at the adhesion. So does an initial
        overlap without `interference` (`tolerated`: within the interface's
        penetration_tol, input that reads as touching) plus tol: before, clamped strips
        1e-9 into each other were refused where exactly touching ones ran. An interference
        fit's pair whose node the supports hold (`held_fit`) is refused alike though its
        row reaches a free node: mortar-standard took the clamped fit of README "Hard
        cases" with max p 116, 229, 455, 906 at h = 0.1 .. 0.0125 (p ~ 1/h, no limit)."""
        closed = np.zeros(self.m)
        allow = self.tol + self.tolerated  # and an initial overlap the geometry allows
        deep = self.fixed_n & (gap_free < -allow)
        shallow = self.fixed_n & (gap_free >= -allow) & (gap_free <= self.tol)
        closed[shallow] = -gap_free[shallow]
        gap_free[shallow] = 0.0
        judged, g0 = gap_free, self.setup.pairs.g0
        if self.held_fit.any():  # a held fit's node: its own gap, which the supports fix
            node = self.setup.node_g0 + sum((case.history[step] * gu for case, gu in
                                             zip(cases, self.node_gu, strict=True)), 0.0)
            held = self.held_fit & (node < -allow)
            if held.any():
                deep = deep | held
                judged = np.where(self.held_fit, node, gap_free)
                g0 = np.where(self.held_fit, self.setup.node_g0, g0)
        if not deep.any():
            return "", closed
        return self._overlap_message(deep, judged, g0), closed

    def _settle_prescribed_slip(self, tau_free: np.ndarray) -> None:
        """A frictional pair the supports fix tangentially on both sides (`fixed_rows`)
        whose prescribed slip this step, tau_free - tau_prev, is within the state tolerance
        has not slid: its tau_prev (in the history) takes tau_free. Its stiff tie turned
        that round-off into a shear capped at the strength: the end pairs of
        `shear_off.toml` with the block's ux 1e-13 ahead of the base's carried c + mu p
        each (tangential force 0.1346 against 0.0721), sticking, without a word."""
        prev = self.hist.tau_prev
        still = self.fixed_t & (np.abs(tau_free - prev) <= self.tol)
        prev[still] = tau_free[still]

    def _held_friction_note(self) -> str:
        """For a failed solve: the frictional pairs whose normal motion the supports fix
        on both sides but whose tangential motion is free. Their normal force moves
        nothing (any share is an equilibrium, the supports take the rest), so neither it
        nor the friction it bounds is determined, and the LCP finds no answer that uses
        it: both interface curves of a strip held at uy = 0 under a sideways load read
        only 'no static equilibrium' before."""
        m = self.m
        # (judged against the whole diagonal: with every normal row held, the normal
        # block alone has no scale and `fixed_rows` finds none)
        fixed = fixed_rows(self.c_diag)[0]
        held = fixed[:m] & ~fixed[m:] & self.setup.frictional
        if not held.any():
            return ""
        pr = self.setup.pairs
        k = int(np.flatnonzero(held)[0])
        name = self.setup.cfg.interfaces[int(pr.interface[k])].name
        return (f"; {int(held.sum())} frictional pair(s) of interface {name!r} have both "
                "sides held in their normal by the supports (first at the slave node "
                f"x={pr.position[k][0]:.6g}, y={pr.position[k][1]:.6g}): their normal force "
                "moves nothing and is not determined, so neither is the friction it bounds; "
                "leave one side of the interface free in its normal")

    def _overlap_message(self, deep: np.ndarray, gap_free: np.ndarray,
                         g0: np.ndarray) -> str:
        """Why the pairs `deep` (m,) bool, both sides prescribed, cannot be solved: at the
        deepest, an initial overlap g0 < 0 (an interference fit) the supports hold, or
        one they push (gap_free - g0 < 0, their prescribed displacements). A fit whose
        both sides are held has no finite-energy answer (README "Hard cases", the
        clamped interference fit): before, it was said to be the supports' push. g0 (m,):
        the initial gaps gap_free starts from."""
        pr = self.setup.pairs
        k = int(np.flatnonzero(deep)[np.argmin(gap_free[deep])])
        x, y = pr.position[k]
        name = self.setup.cfg.interfaces[int(pr.interface[k])].name
        where = f"{int(deep.sum())} pair(s) of interface {name!r}"
        at = f"deepest {-gap_free[k]:.3g} at the slave node x={x:.6g}, y={y:.6g}"
        g0, pushed = float(g0[k]), float(gap_free[k] - g0[k])
        if g0 < 0.0 and self.fit[k]:
            by = (f"; the supports push {-pushed:.3g} more" if pushed < -self.tol else
                  f"; the supports close {pushed:.3g} of it" if pushed > self.tol else "")
            return (f"the supports hold both sides of {where} where they overlap the "
                    f"master ({at}: the interference fit's initial overlap {-g0:.3g}{by}):"
                    " no contact force can push them apart, and the fit has no "
                    "finite-energy answer at a held edge; leave one side free there (e.g. "
                    "rollers on the bodies' sides) or prescribe the supports to close the "
                    "overlap")
        return (f"the supports push {where} into the master, whose both sides they "
                f"prescribe ({at}): no contact force can separate them; make the "
                "prescribed displacements of the two bodies agree there (or leave one "
                "side free)")

    def _interface_info(self, sol, state: np.ndarray, debonded: np.ndarray) -> dict:
        """Per-interface figures of a solved step: forces (per unit thickness x thickness),
        max pressure, state counts and zone lengths, debonding."""
        pr = self.setup.pairs
        length_t = pr.length * self.setup.cfg.thickness
        per_if = {}
        work = pair_dissipation(sol)
        p_min = CONTACT_REL * self.f_scale  # round-off forces are no contact
        for i, itf in enumerate(self.setup.cfg.interfaces):
            sel = pr.interface == i
            per_if[itf.name] = {
                "n_pairs": int(sel.sum()),
                "normal_force": float(sol.p[sel].sum()),
                "tangential_force": float(sol.q[sel].sum()),
                "max_pressure": float((sol.p[sel] / length_t[sel]).max(initial=0.0)),
                "states": {name: int(np.sum(state[sel] == k))
                           for k, name in enumerate(STATE_NAMES)},
                # zone sizes (sum of pair lengths) and the intact bond (for studies)
                "state_lengths": {name: float(pr.length[sel & (state == k)].sum())
                                  for k, name in enumerate(STATE_NAMES)},
                "contact_length": float(pr.length[sel & (sol.p > p_min)].sum()),
                "debonded_pairs": int(np.sum(debonded[sel] > 0)),
                "bond_strength_force": float(self.hist.c[sel].sum()),
                # this interface's share of the step's frictional work (solve_step)
                "dissipation": float(work[sel].sum()),
            }
        return per_if

    def _step_info(self, step: int, res, alpha: np.ndarray) -> dict:
        """summary.json figures of a solved step (states, LCP, modes, held modes)."""
        sol, pr = res.solution, self.setup.pairs
        length_t = pr.length * self.setup.cfg.thickness
        info = {
            "n_pairs": self.m,
            "states": {name: int(np.sum(res.state == k)) for k, name in enumerate(STATE_NAMES)},
            "interfaces": self._interface_info(sol, res.state, res.debonded_step),
            "max_contact_pressure": float((sol.p / length_t).max(initial=0.0)),
            "lcp_size": getattr(self.lcp, "full_size", self.lcp.size),
            "lcp_size_solved": self.lcp.size,
            "lemke_pivots": res.pivots,
            "lcp_residual": sol.residual,
            "lcp_accuracy": sol.accuracy,
            "dependent_tangential_directions": self.lcp.dependent_tangential,
            "lcp_seconds": res.seconds,
            "lcp_solves": res.iterations,
            "debonded_this_step": int(np.sum(res.debonded_step == step + 1)),
            "dissipation": res.dissipation,
        }
        if self.mode_names:
            info["rigid_modes"] = dict(zip(self.mode_names, map(float, alpha), strict=True))
        if self.undetermined:
            info["undetermined_modes"] = self.undetermined
        if self.mode_names:  # unloaded modes held only by contact: how far they slid it
            held = held_mode_entries(sol.p, sol.q, sol.tau, pr.interface, pr.length,
                                     *self.modes_full, self.setup.frictional, self.floating,
                                     [i.name for i in self.setup.cfg.interfaces])
            if held:
                info["contact_held_modes"] = held
        return info

    def _solve(self, step: int, cases, correction: np.ndarray | None) -> StepSolution:
        m, pr = self.m, self.setup.pairs
        gap_free, tau_free, e0, unresisted = self._free_terms(step, cases)
        if unresisted:
            return StepSolution("unbalanced load", f"a load on {unresisted}; the contact "
                                f"cannot resist {unresisted}")
        if correction is not None:
            gap_free += correction[:m]
            tau_free += correction[m:]
        pressed, closed = self._prescribed_overlap(gap_free, step, cases)
        if pressed:
            return StepSolution("prescribed penetration", pressed)
        self._settle_prescribed_slip(tau_free)
        tau_prev = self.hist.tau_prev.copy()
        res = solve_step(self.lcp, self.hist, step + 1, gap_free, tau_free, self.setup.mu,
                         e0, self.tol, self.tol)
        sol = res.solution
        out = StepSolution(res.status, "", np.concatenate([sol.p, sol.q]),
                           sol.alpha if self.v_keep is None else self.v_keep @ sol.alpha,
                           np.concatenate([sol.gap - pr.g0 - closed, sol.tau]))
        if res.status != "solved":
            out.message = f"Lemke ended with '{res.status}': {sol.message}"
            if self.undetermined:
                out.message += "; the contact cannot resist " + ", ".join(self.undetermined)
            out.message += self._held_friction_note()
            return out
        # pairs without tangential unknowns (frictionless) slip by their whole tangential
        # motion; the others by the LCP's slip (the same, tau - tau_prev, to round-off)
        fric = self.setup.frictional
        self.slip += np.where(fric, sol.slip_plus - sol.slip_minus, sol.tau - tau_prev)
        out.info = self._step_info(step, res, out.alpha)
        out.state, out.debonded_step = res.state, res.debonded_step
        out.tau_prev, out.slip, out.f_scale = tau_prev, self.slip.copy(), self.f_scale
        out.u_scale, out.compliance_diag = self.u_scale, self.c_diag
        out.load_scale = self.load_scale
        out.a, out.c = self.hist.a.copy(), self.hist.c.copy()
        out.closed_overlap = closed
        return out
