"""Mindlin-Deresiewicz: Cattaneo's cylinder under a tangential load that goes up and down.

Plane-strain line contact, equal materials (normal and tangential problems uncouple), the
normal force P held while the tangential force Q varies. Loading from 0 (the virgin
branch) gives Cattaneo's traction, q = sign(Q) q_L(|Q|) with q_L(x; Q) =
`cattaneo_traction` at Q / (mu P). After a reversal at Q_r, where the traction was q_r,

    q(x) = q_r(x) + sign(Q - Q_r) 2 q_L(x; |Q - Q_r| / 2)

(Johnson, Contact Mechanics, 7.2 and 7.3; the 2D superposition holds because an elliptic
shear traction over |x| < b with peak mu p0 b / a moves the stick zone |x| < c <= b
rigidly: the surface strain of q0 sqrt(1 - x^2/b^2) is proportional to q0 x / b, the same
for both terms). A counter-slip zone grows in from the contact edges; the branch meets
the previous one where it started (Masing's memory rule: the two turning points are
forgotten and the older branch continues), the virgin branch at -Q_r.

Dissipation: on the virgin branch the slip in c < |x| < a is
s = (mu p0 / (E* a)) (x sqrt(x^2 - c^2) - c^2 acosh(x / c)), and the work mu p |s| summed
over the slip zone is D_v(Q) = (mu P)^2 / (pi E* t) [(1 - r) ln(1 - r) + r - r^2 / 2],
r = Q / (mu P), t the thickness; a branch from Q_r dissipates 2 D_v(|Q - Q_r| / 2) (its
slip field is twice the virgin one at half the load, at the same friction mu p), so a
closed cycle between -Q* and Q* dissipates 4 D_v(Q*), the area of its hysteresis loop.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from app.closed_form import (
    GROSS_SLIP_TOL,
    INTERPOLATED_L2_RANGE,
    _edges_from_states,
    cattaneo_traction,
    hertz_contact,
    interpolated_l2_rel_error,
    stick_half_width,
)
from app.references.base import Reference, RunFigures
from app.references.hertz import along_contact, pressure_errors, pressure_overlay

Terms = tuple[tuple[float, float], ...]
"""A traction as a sum of Cattaneo terms: q(x) = sum over (k, Q) of k q_L(x; Q)."""


def virgin_dissipation(Q: ArrayLike, mu_P: float, E_star: float,
                       thickness: float = 1.0) -> np.ndarray:
    """D_v: frictional work of loading from 0 to |Q| <= mu P on the virgin branch (force x
    length; P, Q total forces over `thickness`). nan beyond mu P (gross slip)."""
    r = np.abs(np.asarray(Q, dtype=float)) / mu_P
    with np.errstate(divide="ignore", invalid="ignore"):
        log_term = np.where(r < 1.0, (1.0 - r) * np.log(np.where(r < 1.0, 1.0 - r, 1.0)), 0.0)
    out = mu_P**2 / (math.pi * E_star * thickness) * (log_term + r - 0.5 * r**2)
    return np.where(r <= 1.0, out, np.nan)


def cycle_dissipation(Q_amplitude: float, mu_P: float, E_star: float,
                      thickness: float = 1.0) -> float:
    """Work of one closed cycle -Q* -> Q* -> -Q*: the area of the hysteresis loop of Q
    against the relative tangential displacement, 4 D_v(Q*)."""
    return float(4.0 * virgin_dissipation(Q_amplitude, mu_P, E_star, thickness))


class _MasingMemory:
    """The state of Masing's rules along a tangential load path: the turning points
    (Q_r, traction there; oldest first), the load now, its direction of travel and the
    work dissipated so far; dv: the virgin dissipation D_v(|Q|)."""

    def __init__(self, dv: Callable[[float], float], tol: float):
        self.dv, self.tol = dv, tol
        self.turns: list[tuple[float, Terms]] = []
        self.direction, self.q_now, self.work = 0.0, 0.0, 0.0

    def terms_at(self, x: float) -> Terms:
        """The traction at load x on the current branch."""
        if not self.turns:
            return ((math.copysign(1.0, x), abs(x)),) if x != 0.0 else ()
        q_r, t_r = self.turns[-1]
        return t_r + ((2.0 * math.copysign(1.0, x - q_r), abs(x - q_r) / 2.0),)

    def branch_load(self, x: float) -> float:
        """Q' of the current branch at load x (|x| virgin, |x - Q_r| / 2 after Q_r)."""
        return abs(x) if not self.turns else abs(x - self.turns[-1][0]) / 2.0

    def branch_work(self, x0: float, x1: float) -> float:
        """Work dissipated on the current branch from load x0 to x1."""
        if not self.turns:
            return abs(self.dv(abs(x1)) - self.dv(abs(x0)))
        q_r = self.turns[-1][0]
        return 2.0 * abs(self.dv(abs(x1 - q_r) / 2.0) - self.dv(abs(x0 - q_r) / 2.0))

    def _meets(self, target: float, d: float) -> float | None:
        """The load where the current branch meets its origin's branch (the previous
        turning point; -Q_r of the first one, on the virgin branch) when the move to
        target in direction d reaches it; else None."""
        if not self.turns:
            return None
        meet = self.turns[-2][0] if len(self.turns) >= 2 else -self.turns[0][0]
        if (target - meet) * d >= -self.tol and (meet - self.q_now) * d >= -self.tol:
            return meet
        return None

    def move_to(self, target: float) -> float:
        """Load from q_now to target (adding the work); returns the load Q' of the branch
        that slid at the end of the move (0 without change; see `masing_path`)."""
        d = float(np.sign(target - self.q_now))
        if d == 0.0:
            return 0.0
        if self.direction != 0.0 and d != self.direction:
            self.turns.append((self.q_now, self.terms_at(self.q_now)))
        self.direction = d
        slip = 0.0
        # the memory rule: a branch that meets its origin's branch joins it
        while (meet := self._meets(target, d)) is not None:
            self.work += self.branch_work(self.q_now, meet)
            slip = self.branch_load(meet)
            self.q_now = meet
            del self.turns[-2 if len(self.turns) >= 2 else -1:]
        self.work += self.branch_work(self.q_now, target)
        if abs(target - self.q_now) > self.tol:
            slip = self.branch_load(target)
        self.q_now = target
        return slip


def masing_path(Q: np.ndarray, dv: Callable[[float], float]
                ) -> tuple[list[Terms], np.ndarray, np.ndarray]:
    """Tractions and cumulative dissipation along a tangential load path (Masing's rules).

    Q: (n,) tangential forces at the steps (the path starts at 0 before Q[0] and is linear
    between the entries); dv: the virgin dissipation D_v(|Q|). Returns per entry the
    traction as `Terms`, (n,) the dissipation from the start up to that entry, and (n,) the
    load Q' of the branch that slid at the end of the step into it (|Q| on the virgin
    branch, |Q - Q_r| / 2 after a reversal at Q_r; 0 for a step without change): its pairs
    in |x| > a sqrt(1 - Q' / (mu P)) slip. A step that ends where a branch meets its
    origin's branch slid on the younger one, though the traction is the older one's.
    """
    tol = 1e-9 * float(np.abs(Q).max(initial=0.0))  # a load back at a turning point meets it
    memory = _MasingMemory(dv, tol)
    out_terms: list[Terms] = []
    out_work, out_slip = np.zeros(len(Q)), np.zeros(len(Q))
    for k, target in enumerate(map(float, Q)):
        out_slip[k] = memory.move_to(target)
        out_terms.append(memory.terms_at(memory.q_now))
        out_work[k] = memory.work
    return out_terms, out_work, out_slip


def masing_traction(x: ArrayLike, terms: Terms, a: float, p0: float, mu: float,
                    mu_P: float) -> np.ndarray:
    """q(x) of a traction given as Cattaneo terms (signed, along the interface's t)."""
    x = np.asarray(x, dtype=float)
    out = np.zeros_like(x)
    for k, load in terms:
        out += k * cattaneo_traction(x, a, p0, mu, min(load / mu_P, 1.0))
    return out


def _path(run: RunFigures, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The interface's tangential force, normal force and dissipation per step (round-off
    tangential forces, below 1e-9 of the largest, read as 0)."""
    q, p, d = (np.array([float(s.get("interfaces", {}).get(name, {}).get(key, 0.0))
                         for s in run.steps])
               for key in ("tangential_force", "normal_force", "dissipation"))
    q[np.abs(q) <= 1e-9 * np.abs(q).max(initial=0.0)] = 0.0
    return q, p, d


def mindlin_errors(x: ArrayLike, q: ArrayLike, length: ArrayLike, *, Q_path: np.ndarray,
                   P: float, mu: float, R: float, E_star: float, thickness: float = 1.0,
                   stick: ArrayLike | None = None, x0: float = 0.0) -> dict:
    """q(x) at the last entry of Q_path against Masing's traction (x relative to the centre,
    sorted, q signed along t), the closed-form dissipation along the path and, with
    `stick` ((m,) bool: pairs in contact that did not slip in the last step), the stick
    zone against that of the branch the last step slid on: |x| < a sqrt(1 - Q' / (mu P)),
    Q' = |Q| on the virgin branch, |Q - Q_r| / 2 after a reversal at Q_r. x0: the centre,
    added back to `stick_edges` (absolute positions, as `cattaneo_errors`' ones)."""
    a, p0 = hertz_contact(P / thickness, R, E_star)
    mu_P = mu * P
    nan = float("nan")
    r_max = float(np.abs(Q_path).max(initial=0.0) / mu_P)
    if r_max > 1.0 + GROSS_SLIP_TOL:
        return {"Q_over_muP": r_max, "traction_l2_rel_error": nan,
                "traction_l2_interp_rel_error": nan, "stick_half_width_rel_error": nan,
                "dissipation_exact": nan,
                "note": f"max |Q| / (mu P) = 1 + {r_max - 1.0:.3g} with P of the last step: "
                "P was not held, no closed form"}
    gross = np.flatnonzero(np.abs(Q_path) >= mu_P * (1.0 - GROSS_SLIP_TOL))
    Q_path = np.clip(Q_path, -mu_P, mu_P)  # round-off above mu P is mu P
    terms, work, slip = masing_path(Q_path, lambda s: float(
        virgin_dissipation(s, mu_P, E_star, thickness)))
    note = {}
    if gross.size:  # sliding at |Q| = mu P: its work depends on how far, not on Q
        work = np.full_like(work, nan)
        if gross[-1] == len(Q_path) - 1:  # the last step slid at mu P: no stick zone
            slip[-1] = mu_P
        note = {"gross_slip_step": int(gross[0]) + 1, "note": "gross slip: |Q| = mu P from "
                f"step {int(gross[0]) + 1}: the whole contact slides, the "
                "dissipation has no closed form (the traction is compared with Q = mu P)"}
    exact = lambda s: masing_traction(s, terms[-1], a, p0, mu, mu_P)  # noqa: E731
    zone = np.abs(x) < a
    qc = exact(x)
    den = np.sum(length[zone] * qc[zone] ** 2)
    l2 = np.sqrt(np.sum(length[zone] * (q[zone] - qc[zone]) ** 2) / den) if den > 0 else nan
    out = {}
    if stick is not None and terms[-1]:
        c_exact = stick_half_width(a, min(slip[-1] / mu_P, 1.0))
        left, right = _edges_from_states(x, np.asarray(stick))
        half = 0.5 * (right - left) if np.any(stick) else 0.0  # no pair sticks: width 0
        out = {"stick_half_width": half, "stick_half_width_exact": c_exact,
               "stick_edges": [left + x0, right + x0],
               "stick_half_width_rel_error": abs(half - c_exact) / c_exact if c_exact > 0
               else nan}
    return out | note | {
            "Q": float(Q_path[-1]), "Q_over_muP": float(Q_path[-1] / mu_P), "a_hertz": a,
            "terms": [list(t) for t in terms[-1]], "traction_l2_rel_error": float(l2),
            "traction_l2_interp_rel_error": interpolated_l2_rel_error(
                x, q, exact, INTERPOLATED_L2_RANGE * a),
            "dissipation_exact": float(work[-1])}


def p_variation(Q_path: np.ndarray, P_path: np.ndarray, P: float) -> float:
    """max |P' - P| / P over the normal forces P' at the start and end of every step with a
    tangential force at either end (the path starts at Q = P = 0): the closed form holds P
    while Q is on. The start counts: a single step that applies P and Q together has 1."""
    q0, p0 = (np.concatenate(([0.0], v[:-1])) for v in (Q_path, P_path))
    loaded = (Q_path != 0.0) | (q0 != 0.0)
    ends = np.concatenate((P_path[loaded], p0[loaded]))
    return float(np.abs(ends - P).max(initial=0.0) / P)


def _errors(params: dict, run: RunFigures) -> dict:
    out = pressure_errors(params, run)
    c = run.contact
    Q_path, P_path, diss = _path(run, c.interface)
    P = float(c.p_force.sum())
    if c.mu <= 0.0 or P <= 0.0 or Q_path.size == 0:
        out["mindlin"] = {"P": P, "traction_l2_rel_error": math.nan,
                          "traction_l2_interp_rel_error": math.nan,
                          "stick_half_width_rel_error": math.nan,
                          "dissipation_rel_error": math.nan,
                          "note": f"no tangential closed form: mu = {c.mu:g}, P = {P:.6g}, "
                          f"{Q_path.size} steps"}
        return out
    s = along_contact(params, c)  # along the contact's own direction, as p
    o = np.argsort(s)
    m = mindlin_errors(s[o], c.q[o], c.length[o], Q_path=Q_path, P=P,
                       mu=c.mu, R=params["radius"], E_star=c.E_star,
                       thickness=run.thickness, stick=c.stick[o], x0=params["center_x"])
    d_run = float(diss.sum())
    d_ex = m["dissipation_exact"]
    out["mindlin"] = m | {
        "P": P, "Q_max": float(np.abs(Q_path).max(initial=0.0)),
        # the closed form holds P; how far it moved while Q was applied
        "P_variation": p_variation(Q_path, P_path, P),
        # the reversals the traction remembers (each branch adds one term)
        "turning_points": max(len(m.get("terms", ())) - 1, 0),
        "dissipation": d_run,
        "dissipation_rel_error": abs(d_run - d_ex) / d_ex if d_ex > 0 else math.nan}
    return out


def _overlay(ref: dict, mu: float) -> dict:
    curves = pressure_overlay(ref, mu)
    h, mi = ref["hertz"], ref["mindlin"]
    if "terms" in mi and math.isfinite(h["a_hertz"]):
        x0, terms = ref.get("center_x", 0.0), tuple(map(tuple, mi["terms"]))
        mu_P = mu * h["P"]
        curves["q"] = ("Mindlin-Deresiewicz", lambda x: masing_traction(
            x - x0, terms, h["a_hertz"], h["p0_hertz"], mu, mu_P))
    return curves


REFERENCE = Reference(
    name="mindlin",
    keys={"radius": None, "center_x": 0.0, "center_y": None},
    positive=("radius",),
    optional=("center_y",),
    errors=_errors,
    columns=((("hertz", "p_max_rel_error"), "peak_pressure"),
             (("hertz", "pressure_l2_interp_rel_error"), "pressure_l2_interp"),
             (("mindlin", "stick_half_width_rel_error"), "stick_zone"),
             (("mindlin", "traction_l2_rel_error"), "traction_l2"),
             (("mindlin", "traction_l2_interp_rel_error"), "traction_l2_interp"),
             (("mindlin", "dissipation_rel_error"), "dissipation")),
    overlay=_overlay,
    needs_contact=True,
)
