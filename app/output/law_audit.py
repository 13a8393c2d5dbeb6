"""The interface law audited from a run's written output, step by step (plain numpy).

What the KKT check of summary.json (app/output/contact.py) does not cover: that each
pair's reported `state` agrees with its forces and motion, that debonding is for good,
that `slip` accumulates the slip increments, and that the step's `dissipation` is the
sum of -q (slip increment) and not negative. Used by scripts/check_interface_law.py.

Arrays per step are the /contact datasets of step_NNNN.h5 (m pairs): p_force, q_force,
a_force, c_force, mu, state (0 bonded, 1 stick, 2 slip+, 3 slip-, 4 open), debonded_step,
slip_increment, slip. Forces are relative to `f_scale`, lengths to `u_scale` (the run's
largest pair force and displacement), works to their product.
"""

from __future__ import annotations

import numpy as np

from app.interface.steps import BONDED, OPEN, SLIP_MINUS, SLIP_PLUS, STICK

LAW_TOL = 1e-7
"""Largest relative violation accepted by `failed`."""


def _max(x: np.ndarray) -> float:
    return float(np.max(x, initial=0.0))


def audit_step(c: dict, prev: dict | None, dissipation: float, f_scale: float,
               u_scale: float) -> dict:
    """Violations of one step: relative figures, and counts (`bonded_but_debonded`,
    `moved_yet_bonded`, `rebonded`); `prev` is the previous step's arrays (None at step
    1)."""
    fs, us = max(f_scale, 1e-300), max(u_scale, 1e-300)
    p, q, state = c["p_force"], c["q_force"], c["state"]
    bound = c["mu"] * p + c["c_force"]
    dslip = c["slip_increment"]
    sp, sm, op = state == SLIP_PLUS, state == SLIP_MINUS, state == OPEN
    work = -np.sum(q * dslip)
    out = {
        # slipping: q = -F along +t, +F along -t, and the slip has that sense
        "slip_force": max(_max(np.abs(q + bound)[sp]), _max(np.abs(q - bound)[sm])) / fs,
        "slip_sense": max(_max(-dslip[sp]), _max(dslip[sm])) / us,
        # stuck or bonded: within the friction bound
        "stick_bound": _max((np.abs(q) - bound)[(state == STICK) | (state == BONDED)]) / fs,
        # open: no force beyond the adhesion (none once debonded)
        "open_force": max(_max(np.abs(p + c["a_force"])[op]), _max(np.abs(q)[op])) / fs,
        "bonded_but_debonded": int(np.sum((state == BONDED) & (c["debonded_step"] > 0))),
        # a pair that slips or opens debonds: it keeps no adhesion or strength
        "moved_yet_bonded": int(np.sum((sp | sm | op)
                                       & ((c["a_force"] > 0) | (c["c_force"] > 0)))),
        "dissipation_vs_pairs": abs(dissipation - work) / (fs * us),
        "dissipation_negative": max(0.0, -dissipation) / (fs * us),
    }
    if prev is None:
        out["slip_sum"] = _max(np.abs(c["slip"] - dslip)) / us
        out["rebonded"] = 0
    else:
        out["slip_sum"] = _max(np.abs(c["slip"] - prev["slip"] - dslip)) / us
        was = prev["debonded_step"] > 0
        out["rebonded"] = int(np.sum(was & (c["debonded_step"] != prev["debonded_step"])))
    return out


def failed(figures: dict, tol: float = LAW_TOL) -> list[str]:
    """Names of the figures of `audit_step` beyond tol (counts: beyond 0)."""
    bad = []
    for k, v in figures.items():
        limit = 0 if isinstance(v, int) else tol
        if v > limit:
            bad.append(k)
    return bad
