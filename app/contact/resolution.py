"""Stripes: contact tractions that follow the master's element period.

A slave curve much finer than its master makes the tractions oscillate with the master's
element period, with node-to-segment and mortar alike: the slave nodes follow the
master's piecewise-linear surface, kinks included (README "Verification table").
Measured on configs/multibody.toml: `indent` (master elements 4.3x the slave's) 30% of
max p off a local quadratic fit, `bond` (2.0x) 8.8%, and 0.1% with the foundation refined
to the slave's size. A step's check needs both the cause (the size ratio) and the symptom
(the deviation inside the closed zone), so a coarse master that stays straight, or a
sharp but real feature of the tractions, is not reported.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from app.contact.pairs import ContactPairs
from app.contact.smoothness import local_fit_deviation
from app.mesh.model import Mesh

SIZE_RATIO_WARN = 1.5
"""The master's median element length over the slave's above which stripes can appear."""
STRIPE_DEVIATION_WARN = 0.05
"""Largest |p - local quadratic fit| / max p inside the closed zone that is reported."""
MIN_CLOSED_PAIRS = 9
"""Fewer closed pairs than this are not judged (the fit needs 5, the ends are left out)."""
EDGE_PAIRS = 2
"""Closed pairs at each end of the zone left out of the deviation (contact edges)."""
ZONE_GAP = 1.5
"""Consecutive closed pairs (along the zone) farther apart than this times the larger of
their spacings (tributary length, or the master segment they face if longer) lie in
separate contact zones. A hole shorter than a master element is a stripe that lifted
a slave node off (multibody `indent` at step 1), not a second zone."""
CLOSED_REL = 1e-6
"""A pair is closed when its normal force exceeds this times the problem's force scale
(round-off forces of a zone being pulled off are not a traction profile)."""


def median_size_ratio(master_ends: np.ndarray, slave_length: np.ndarray) -> float:
    """Median length of the master segments master_ends (k, 2, 2) over the median slave
    tributary length slave_length (k,) (dimensionless); nan for k = 0."""
    if slave_length.size == 0:
        return float("nan")
    master = np.median(np.linalg.norm(master_ends[:, 1] - master_ends[:, 0], axis=1))
    return float(master / np.median(slave_length))


def master_slave_size_ratio(mesh: Mesh, pairs: ContactPairs, sel: np.ndarray) -> float:
    """`median_size_ratio` over the selected pairs (the segments they project on)."""
    return median_size_ratio(mesh.points[pairs.master[sel]], pairs.length[sel])


def interior_deviation(position: np.ndarray, p: np.ndarray) -> float:
    """Largest local-fit deviation (app/contact/smoothness.py, / max p) of the tractions p
    (k,) at positions (k, 2), ordered along their principal direction, leaving out
    EDGE_PAIRS pairs at each end (0 when nothing is left)."""
    centred = position - position.mean(axis=0)
    axis = np.linalg.svd(centred, full_matrices=False)[2][0]  # principal direction
    s = centred @ axis
    order = np.argsort(s)
    dev = local_fit_deviation(s[order], p[order])
    return float(dev[EDGE_PAIRS:-EDGE_PAIRS].max(initial=0.0))


def closed_zones(position: np.ndarray, spacing: np.ndarray) -> list[np.ndarray]:
    """The closed pairs at positions (k, 2) with spacings (k,) (length) split into
    contact zones: index arrays, each ordered along the pairs' principal direction; a zone
    ends where the next pair lies farther than ZONE_GAP x the larger spacing."""
    if position.shape[0] < 2:
        return [np.arange(position.shape[0])]
    centred = position - position.mean(axis=0)
    axis = np.linalg.svd(centred, full_matrices=False)[2][0]  # principal direction
    order = np.argsort(centred @ axis)
    step = np.linalg.norm(np.diff(position[order], axis=0), axis=1)
    wide = np.maximum(spacing[order][:-1], spacing[order][1:])
    cuts = np.flatnonzero(step > ZONE_GAP * wide) + 1
    return np.split(order, cuts)


def stripe_checks(mesh: Mesh, pairs: ContactPairs, normal_force: np.ndarray,
                  names: Sequence[str], force_scale: float) -> list[dict]:
    """Per interface with at least MIN_CLOSED_PAIRS pairs in compression (normal_force (m,),
    the LCP's normal pair forces, above CLOSED_REL x force_scale), judged zone by zone
    (`closed_zones`, the zones of at least MIN_CLOSED_PAIRS pairs; the inner edges of two
    zones are contact edges, not stripes):
    {interface, closed, size_ratio, deviation, warn}. Nothing is judged when nothing
    loads the problem (force_scale 0): every pair force is then round-off."""
    out = []
    if not force_scale > 0:
        return out
    for i, name in enumerate(names):
        sel = (pairs.interface == i) & (normal_force > CLOSED_REL * force_scale)
        if np.count_nonzero(sel) < MIN_CLOSED_PAIRS:
            continue
        pos, p = pairs.position[sel], normal_force[sel] / pairs.length[sel]
        ends = mesh.points[pairs.master[sel]]
        spacing = np.maximum(pairs.length[sel], np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1))
        zones = [z for z in closed_zones(pos, spacing) if z.size >= MIN_CLOSED_PAIRS]
        if not zones:  # several zones, none long enough to judge
            continue
        ratio = master_slave_size_ratio(mesh, pairs, sel)
        p_max = max(np.abs(p).max(), 1e-300)  # each zone's deviation relative to max p
        dev = float(max(interior_deviation(pos[z], p[z]) * np.abs(p[z]).max() / p_max
                        for z in zones))
        out.append({"interface": name, "closed": int(np.count_nonzero(sel)),
                    "size_ratio": ratio, "deviation": dev,
                    "warn": ratio > SIZE_RATIO_WARN and dev > STRIPE_DEVIATION_WARN})
    return out


def stripe_warning(check: dict, step: int, discretisation: str | None = None) -> str:
    """The one-line warning for a check with warn set, at 1-based `step`; the remedies
    offered depend on the interface's `discretisation` (None: the default)."""
    remedy = ("Make the coarser side the slave or refine the master" if discretisation ==
              "mortar-smooth" else 'Set discretisation = "mortar-smooth" on it, make the '
              "coarser side the slave, or refine the master")
    return (f"interface '{check['interface']}', step {step}: p deviates by "
            f"{100 * check['deviation']:.1f}% of max p from a smooth fit inside the closed "
            f"zone, and the master's elements are {check['size_ratio']:.1f}x the slave's: "
            f"the tractions follow the master's element period. {remedy} to within "
            f"{SIZE_RATIO_WARN}x (README \"Smoothed master\")")
