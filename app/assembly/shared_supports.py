"""DOFs that two supports prescribe (a corner on two supported curves, a point support on
a supported curve).

Every support with a non-zero value is a load case of its own, and the cases are
superposed; a DOF in two cases took the sum of both values (a corner held at uy = -0.01
by its curve and at -0.02 by a point support moved by -0.03, the same -0.01 twice by
-0.02). Now two supports must give a shared DOF the same value at every step (else a
one-line error), and that DOF counts in the first support's case only (the one its
reaction is reported under, app/output/reactions.py).
"""

from __future__ import annotations

import numpy as np

from app.errors import InputError

COMPONENT = ("ux", "uy")


def first_support_values(dofs: list[np.ndarray], vals: list[np.ndarray],
                         histories: list[np.ndarray], names: list[str],
                         points: np.ndarray) -> list[np.ndarray]:
    """The values (factor 1) each support keeps: 0 where an earlier support holds the DOF.

    dofs, vals: per support its prescribed DOFs and their values at factor 1; histories:
    per support its factors per step; names: for messages ("support #2 (corner)");
    points (n, 2) for the place. InputError when two supports give a DOF different values
    at some step.
    """
    n2 = 2 * len(points)
    first = np.full(n2, -1, dtype=np.int64)  # earliest support of each DOF
    value = np.zeros(n2)  # its value at factor 1
    kept = []
    for s, (d, v) in enumerate(zip(dofs, vals, strict=True)):
        shared = first[d] >= 0
        for t in np.unique(first[d][shared]):
            on = shared & (first[d] == t)
            _check_agree(d[on], value[d[on]], v[on], histories[t], histories[s],
                         (names[t], names[s]), points)
        kept.append(np.where(shared, 0.0, v))
        first[d[~shared]] = s
        value[d[~shared]] = v[~shared]
    return kept


def _check_agree(d: np.ndarray, a: np.ndarray, b: np.ndarray, ha: np.ndarray,
                 hb: np.ndarray, names: tuple[str, str], points: np.ndarray) -> None:
    """InputError unless a * ha[k] == b * hb[k] (to round-off) for every DOF and step."""
    na, nb = np.abs(ha).max(initial=0.0), np.abs(hb).max(initial=0.0)
    c = float(ha @ hb) / max(float(ha @ ha), 1e-300)  # hb = c ha when proportional
    if not na:  # a ha = 0 everywhere: b hb must vanish too
        bad = (b != 0) & bool(nb)
    elif not nb:
        bad = a != 0
    elif np.abs(hb - c * ha).max() <= 1e-12 * max(na, nb):  # a ha = b c ha: a = c b
        bad = np.abs(a - c * b) > 1e-12 * np.maximum(np.abs(a), np.abs(c * b)) + 1e-300
    else:  # independent histories agree only where both values vanish
        bad = (a != 0) | (b != 0)
    if not bad.any():
        return
    i = int(np.argmax(bad))
    k = int(np.argmax(np.abs(a[i] * ha - b[i] * hb)))
    x, y = points[d[i] // 2]
    raise InputError(
        f"{names[0]} and {names[1]} both prescribe {COMPONENT[d[i] % 2]} at x={x:.4g}, "
        f"y={y:.4g}, as {a[i] * ha[k]:.4g} and {b[i] * hb[k]:.4g} at step {k + 1} "
        f"({int(bad.sum())} such DOF(s)): give each DOF one value (before, the run added "
        "the two)")
