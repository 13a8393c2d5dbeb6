"""Contact-held modes that nothing loads, and how far they slid the contact (rank 0).

A floating body's rigid (or hourglass) mode is held only by contact. A combination of its
modes that no interface loads (each interface's net generalized force on it is below
NET_TOL of that interface's gross one; by the body's equilibrium, no applied load acts on
it either) should not move the contact: on the exact geometry such a mode is often free
(a circle turning about its centre), and only the discretisation (facets, linearised
normals) holds it. Its motion at the contact is measured from the contact answer itself:
the least-squares fit of the in-contact pairs' relative tangential displacement tau by the
mode's tangential pattern gives the slide, and the slide over the contact width (the
summed lengths of the pairs that carry a normal force) is the ratio that is reported.
Above SLIDE_WARN the run warns (README, "Input checks": a contact-held mode the mesh moves).

Plain numpy; tau and the gap changes per mode come from app.interface.steps.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.interface.floating import mode_names, split_modes

NET_TOL = 0.05
"""A combination counts as loaded by nothing when every interface's net generalized force
on it is at most NET_TOL of that interface's gross one (sum of |pair force x mode|)."""
SLIDE_WARN = 3e-3
"""Warn when an unloaded contact-held mode slid the contact by more than this fraction of
the contact width. Measured: at most 1.5e-3 on configs/ and meshes/ (hard/nonunique; 4.9e-4
on hertz), at most 1.3e-3 on hertz.toml at --mesh-size 0.3 to 0.8 (p errors <= 3%), and
4.2e-3 to 3.0e-2 at --mesh-size 0.9 to 2 (p_max errors 26% to 99%)."""
FORCE_ROUND_OFF = 1e-10
"""Pair forces (p, q) at most this fraction of the largest are round-off and count as 0
when judging whether a combination is loaded (the LCP's forces agree to 1e-10 of their
scale between solves, e.g. with and without candidate pairs; a q of 1e-15 of p on a
friction-held translation was its whole gross force and made it "loaded" in one solve and
not in the other)."""
PATTERN_RCOND = 1e-8
"""Combinations whose tangential pattern at an interface is below this fraction of the
largest one move that contact by round-off only: the slide fit leaves them out. (With
numpy's default cut-off, eps x size, such round-off directions, 1e-13 of the largest with
CS-FEM-1SD's hourglass modes, entered the fit with amplitudes of 1e12, and the slide, the
warning with it, depended on the round-off: multibody.toml --sd 1 warned on one rank
count and not on the other; tests/test_weak_modes.py.)"""


@dataclass
class HeldModeSlide:
    """One unloaded contact-held combination of a body's modes at one interface.

    group: index of the body's column group; interface: interface index; v: (r_b,) unit
    combination of the group's mode columns (sign: the realised amplitude is positive);
    amplitude: its realised amplitude (units of the mode columns); slide: largest
    |tangential displacement| it causes at an in-contact pair; width: contact width (sum
    of the lengths of the pairs with p != 0); ratio = slide / width.
    """

    group: int
    interface: int
    v: np.ndarray
    amplitude: float
    slide: float
    width: float

    @property
    def ratio(self) -> float:
        return self.slide / self.width if self.width > 0 else 0.0


def unloaded_combinations(forces: np.ndarray, interface: np.ndarray, seen: np.ndarray,
                          net_tol: float = NET_TOL, tangential: np.ndarray | None = None
                          ) -> np.ndarray:
    """Orthonormal basis (r_b, k) of the combinations within `seen` (r_b, w) that no
    interface loads. forces (m2, r_b): per constraint row, its force times the row's
    change per unit mode amplitude (p N or q T); interface (m2,) the row's interface;
    tangential (m2,) bool, the q T rows: an interface's friction that loads a combination
    which its own normal forces hold (net 0 over the interface: a block dragged over a
    foundation tilts by the friction's moment) loads it, so the normal and the tangential
    rows are judged apart as well, each against the interface's gross force."""
    rows = []
    for i in np.unique(interface):
        f = forces[interface == i] @ seen
        gross = np.abs(forces[interface == i]).sum()
        if gross > 0:
            rows.append(f.sum(axis=0) / gross)
            if tangential is not None:
                rows.append(f[tangential[interface == i]].sum(axis=0) / gross)
    if not rows:
        return seen
    _, s, vt = np.linalg.svd(np.array(rows), full_matrices=True)
    s = np.concatenate([s, np.zeros(vt.shape[0] - s.size)])
    return seen @ vt[s <= net_tol].T


def held_mode_slides(p: np.ndarray, q: np.ndarray, tau: np.ndarray, interface: np.ndarray,
                     length: np.ndarray, n_modes: np.ndarray, t_modes: np.ndarray,
                     frictional: np.ndarray, groups: list[np.ndarray],
                     net_tol: float = NET_TOL) -> list[HeldModeSlide]:
    """The slide of every unloaded contact-held mode combination, per body and interface.

    p, q (m,): pair normal (compression positive) and tangential forces (those at most
    FORCE_ROUND_OFF of the largest count as 0); tau (m,): the
    relative tangential displacement (slave minus master, along t) at this step; interface
    (m,) int; length (m,) pair lengths; n_modes, t_modes (m, r): gap and tau change per unit
    mode amplitude; frictional (m,) bool; groups: the mode columns of each body. Modes no
    pair sees (undetermined, reported elsewhere) are left out.
    """
    out = []
    floor = FORCE_ROUND_OFF * max(np.abs(p).max(initial=0.0), np.abs(q).max(initial=0.0))
    p = np.where(np.abs(p) > floor, p, 0.0)
    q = np.where(np.abs(q) > floor, q, 0.0)
    carries = p != 0
    for g, cols in enumerate(groups):
        nb, tb = n_modes[:, cols], t_modes[:, cols]
        seen, _ = split_modes(nb, tb[frictional])
        if seen.shape[1] == 0:
            continue
        forces = np.vstack([p[:, None] * nb, q[:, None] * tb])
        free = unloaded_combinations(forces, np.concatenate([interface, interface]), seen,
                                     net_tol, np.repeat([False, True], p.size))
        if free.shape[1] == 0:
            continue
        for i in np.unique(interface[carries]):
            act = carries & (interface == i)
            x = tb[act] @ free  # (n_act, k) tangential pattern of each combination
            if np.abs(x).max(initial=0.0) == 0.0:
                continue
            c = np.linalg.lstsq(x, tau[act], rcond=PATTERN_RCOND)[0]
            v = free @ c
            amp = float(np.linalg.norm(v))
            v = v / amp if amp > 0 else free[:, 0]
            out.append(HeldModeSlide(g, int(i), v, amp, float(np.abs(x @ c).max()),
                                     float(length[act].sum())))
    return out


def describe(v: np.ndarray, coefficients: np.ndarray | None, centroid: np.ndarray | None,
             names: list[str]) -> str:
    """Words for a combination v (r_b,) of a body's modes: the rigid motion it is ('rotation
    about (x=.., y=..)', coordinates below PATTERN_RCOND of the centroid's size, the fit's
    own resolution, shown as 0) when the
    modes' rigid coefficients (3, r_b) about the body `centroid` are known, else the name of
    its dominant mode."""
    if coefficients is None or centroid is None or not np.isfinite(coefficients).all():
        return names[int(np.argmax(np.abs(v)))]
    tx, ty, th = coefficients @ v
    if abs(th) <= 1e-6 * max(abs(tx), abs(ty), 1e-300):
        return mode_names(np.array([[tx], [ty], [th]]), centroid)[0]
    x0, y0 = centroid[0] - ty / th, centroid[1] + tx / th
    tiny = PATTERN_RCOND * max(np.abs(centroid).max(), 1.0)
    x0, y0 = (0.0 if abs(c) < tiny else float(c) for c in (x0, y0))
    return f"rotation about (x={x0:.4g}, y={y0:.4g})"


NTS_ADVICE = ("; with node-to-segment the master's segment normals hold it only through "
              "its kinks, and refining does not stop the slide: set discretisation = "
              "\"mortar\" on that interface")
"""Added where the interface is node-to-segment: two curved half cylinders (README "Hard
cases", cylinder on cylinder) with the smaller one as master slide by 24% of the contact
width at a/20 and a/40 alike (mortar: below the threshold, p_max within 0.1%)."""


def slide_warning(entry: dict, step: int, discretisation: str | None = None) -> str:
    """The one-line warning for a summary entry of `contact_held_modes` above SLIDE_WARN;
    `discretisation`, the interface's, adds NTS_ADVICE for node-to-segment."""
    extra = NTS_ADVICE if discretisation == "node-to-segment" else ""
    return (f"body '{entry['body']}': its {entry['mode']} is held only by contact "
            f"'{entry['interface']}' and nothing loads it, yet at step {step} it slid the "
            f"contact by {entry['slide']:.2e}, {100 * entry['slide_ratio']:.3g}% of the contact "
            f"width {entry['contact_width']:.3g} (warning above {100 * SLIDE_WARN:g}%): the "
            "discretisation, not the load, moves it, and the contact pressure may be "
            f"lopsided; refine the mesh of '{entry['body']}' and of the contact, or hold this "
            f"mode with a support{extra}")


def held_mode_entries(p: np.ndarray, q: np.ndarray, tau: np.ndarray, interface: np.ndarray,
                      length: np.ndarray, n_modes: np.ndarray, t_modes: np.ndarray,
                      frictional: np.ndarray, floating, interface_names: list[str]
                      ) -> list[dict]:
    """summary.json entries (`steps[k].contact_held_modes`) of `held_mode_slides` for the
    floating modes `floating` (app.interface.floating.FloatingModes): body, mode (words),
    interface, slide, contact_width, slide_ratio, warn (ratio > SLIDE_WARN)."""
    bodies = floating.bodies or [n.split(":")[0] for n in floating.names]
    order = list(dict.fromkeys(bodies))
    groups = [np.flatnonzero(np.array(bodies) == b) for b in order]
    out = []
    for h in held_mode_slides(p, q, tau, interface, length, n_modes, t_modes, frictional,
                              groups):
        cols = groups[h.group]
        coef = None if floating.rigid is None else floating.rigid[:, cols]
        centre = None if floating.centroids is None else floating.centroids[cols[0]]
        names = [floating.names[k].split(": ", 1)[-1] for k in cols]
        out.append({"body": order[h.group], "mode": describe(h.v, coef, centre, names),
                    "interface": interface_names[h.interface], "slide": h.slide,
                    "contact_width": h.width, "slide_ratio": h.ratio,
                    "warn": bool(h.ratio > SLIDE_WARN)})
    return out
