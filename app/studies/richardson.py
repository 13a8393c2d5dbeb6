"""Richardson extrapolation of a scalar computed on nested levels (h halves per level).

A quantity with an asymptotic error expansion Q_l = Q* + C h_l^p + ... on levels whose
element sizes shrink by `ratio` (2 for the study's uniform splitting) has
  observed order  p = log(|Q_{l-1} - Q_{l-2}| / |Q_l - Q_{l-1}|) / log(ratio)
                  (three levels; undefined if the two differences change sign or vanish)
  limit           Q* = Q_l + (Q_l - Q_{l-1}) / (ratio^p - 1)   (two levels and an order).

`richardson` takes the values on consecutive levels (coarse to fine) and extrapolates from
the finest ones:
- with the observed order of the last three levels if it lies in ACCEPT x the
  theoretical order (the sequence is in its asymptotic range), else with the theoretical
  order from the last two levels;
- uncertainty: the larger of
  |Q*(observed order, last three levels) - Q*(theoretical order, last two levels)|
  (how much the limit depends on which order is believed; with only two levels or no
  observed order, the size of the correction |Q* - Q_finest| itself) and
  |Q* - Q*_previous|, where `previous` is the same extrapolation from the levels one
  coarser (how far the limit moved when the finest level was added). The second term
  matters on the Hertz scenes, where the energy increments per level wobble (ratios 3.3
  to 4.8) as the contact edge falls differently between the nodes of each level.
Plain numpy/float; no MPI, no files.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

THEORETICAL_ORDER = 2.0
"""Order in h of the study's scalars (strain energy, peak pressure, point displacements)
for linear elements on a solution smooth enough for the energy norm to converge at O(h)."""

ACCEPT = (0.5, 2.0)
"""The observed order is used if it lies within these multiples of the theoretical one."""


def observed_order(q0: float, q1: float, q2: float, ratio: float = 2.0) -> float:
    """Order p from three consecutive levels (coarse to fine, h shrinking by `ratio`);
    nan when the differences q1 - q0 and q2 - q1 are zero or of opposite sign
    (no monotone convergence)."""
    d1, d2 = q1 - q0, q2 - q1
    if d1 == 0 or d2 == 0 or (d1 > 0) != (d2 > 0) or not math.isfinite(d1 + d2):
        return math.nan
    return math.log(d1 / d2) / math.log(ratio)


def extrapolate(q_coarse: float, q_fine: float, order: float, ratio: float = 2.0) -> float:
    """Richardson limit from two consecutive levels and an order p > 0:
    q_fine + (q_fine - q_coarse) / (ratio^p - 1)."""
    if not order > 0:
        return math.nan
    return q_fine + (q_fine - q_coarse) / (ratio**order - 1.0)


def _limit(values: Sequence[float], theoretical: float, ratio: float) -> dict:
    """The limit from the last three (or two) of `values`; see the module docstring."""
    q = [float(v) for v in values]
    th = extrapolate(q[-2], q[-1], theoretical, ratio)
    p = observed_order(q[-3], q[-2], q[-1], ratio) if len(q) >= 3 else math.nan
    obs = extrapolate(q[-2], q[-1], p, ratio) if p > 0 else math.nan
    use = math.isfinite(p) and ACCEPT[0] * theoretical <= p <= ACCEPT[1] * theoretical
    value = obs if use else th
    unc = abs(obs - th) if math.isfinite(obs) else abs(th - q[-1])
    return {"value": value, "order": p, "order_used": p if use else theoretical,
            "order_source": "observed" if use else "theoretical", "value_observed": obs,
            "value_theoretical": th, "uncertainty": unc}


def richardson(values: Sequence[float], theoretical: float = THEORETICAL_ORDER,
               ratio: float = 2.0) -> dict:
    """Extrapolate a scalar from its values on consecutive levels (coarse to fine, at
    least two). Returns value (the limit), order (observed, nan if undefined),
    order_used, order_source ("observed" or "theoretical"), value_observed,
    value_theoretical, uncertainty (absolute, >= 0; see the module docstring),
    uncertainty_rel (relative to |value|), n_levels, previous (the limit without the
    finest level, nan with fewer than three levels) and change_previous."""
    if len(values) < 2:
        raise ValueError("richardson needs values on at least two levels")
    out = _limit(values, theoretical, ratio)
    prev = _limit(values[:-1], theoretical, ratio)["value"] if len(values) >= 3 else math.nan
    change = abs(out["value"] - prev)
    if math.isfinite(change):
        out["uncertainty"] = max(out["uncertainty"], change)
    out |= {"n_levels": len(values), "previous": prev, "change_previous": change,
            "uncertainty_rel": out["uncertainty"] / abs(out["value"])
            if out["value"] else math.nan}
    return out
