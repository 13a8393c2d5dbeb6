"""The interface law judged pair by pair, each pair against its own scale (summary
`steps[k].kkt_pairs`).

The run-wide KKT figures (`app.output.contact.kkt_check`) measure gaps against the largest
displacement of the run and forces against its largest force. An interface whose
compliance is 1e-11 of another's moves 1e-11 as much under the same forces, so a wrong
force there moves it by round-off of the run's scale: q 44% off on the stiff interface of
`configs/hard/tangential_contrast.toml` (before its fix) read KKT 1e-12. Here each pair's
motion is measured in the motion its own interface's forces make at that pair (its
compliance diagonal C_ii x the interface's largest force) and each force against its own
interface's largest force, with floors at the round-off of the arithmetic that formed them.

Residuals per pair (natural residuals of the complementarity conditions, 0 exactly when
the law holds):
- normal: |min(gap / s_n, (p + a) / F)|: penetration, tension beyond the adhesion, or an
  open pair that carries a force;
- tangential: max((|q| - B)+ / F, min(|dtau| / s_t, |q + sign(dtau) B| / F)), B = mu p + c:
  beyond the friction bound, or a pair that moved without carrying q = -sign(dtau) B;
- consistency: |G u - LCP kinematics| / s, the displacement field against the compliance
  the LCP used.
"""

from __future__ import annotations

import numpy as np

from app.lcp.coulomb_matrix import FIXED_COMPLIANCE_REL, fixed_rows

EPS = float(np.finfo(float).eps)
ROUNDOFF_ULPS = 64.0
"""Round-off of a pair's kinematics: ROUNDOFF_ULPS x eps x the size of the terms that
formed them (`kinematic_floor`)."""
PAIR_WARN = 1e-6
"""Largest per-pair figure that passes without a warning (`kkt_pairs_warning`)."""
FORCE_FLOOR = ROUNDOFF_ULPS * EPS / PAIR_WARN
"""An interface's force scale is at least this fraction (1.4e-8) of the run's largest
force: round-off of the forces (ROUNDOFF_ULPS eps of the largest) reads at most PAIR_WARN.
On hard/pull_off.toml, once pulled off, the open pairs carry q = 4e-16 beside loads of
4.5: judged against 1e-10 of those (the run's `contact_length` threshold) they read 9e-7."""


def body_scale(u: np.ndarray, node_body: np.ndarray) -> np.ndarray:
    """(2n,) per DOF, the largest |u| of its node's body (u (2n,), node_body (n,) body
    index, -1 for a node of no body: its own |u|). The linear solve's round-off in a body
    is relative to that body's displacements (bodies are coupled only by contact): on
    hard/shear_off.toml the bond's end pairs, whose own motion is 1e-13 of the block's,
    move by 2e-19, eps x the block's max |u|."""
    a = np.maximum(np.abs(u[0::2]), np.abs(u[1::2]))  # (max(axis=1) of (n, 2): 10x slower)
    n_body = int(node_body.max(initial=-1)) + 1
    top = np.zeros(n_body + 1)  # (last entry: nodes of no body, unused)
    for b in range(n_body):  # (a loop over bodies: np.maximum.at took 2.8 ms at 15k nodes)
        top[b] = a[node_body == b].max(initial=0.0)
    per_node = np.where(node_body >= 0, top[node_body], a)
    return np.repeat(per_node, 2)


def kinematic_floor(g_abs, ub: np.ndarray, g0: np.ndarray, tau_prev: np.ndarray,
                    solve_rel: float = 0.0) -> np.ndarray:
    """(2m,) the round-off of (gap, tau - tau_prev) formed from u: ROUNDOFF_ULPS eps x the
    size of their terms, |G| ub (ub: `body_scale`) plus |g0| or |tau_prev|; the |G| ub part
    times solve_rel instead where that is larger (the relative residual of iterative
    linear solves: on hard/shear_off.toml with -ksp_type cg -pc_type gamg, 1e-12, the end
    pairs read 2.9e-6 against round-off alone and the refinement re-solved 14 times).
    g_abs: |G| (2m, 2n) sparse; g0, tau_prev (m,)."""
    m = g0.size
    size = max(ROUNDOFF_ULPS * EPS, solve_rel) * (g_abs @ ub)
    size[:m] += ROUNDOFF_ULPS * EPS * np.abs(g0)
    size[m:] += ROUNDOFF_ULPS * EPS * np.abs(tau_prev)
    return size


def tied_coupling(c_diag: np.ndarray, work: float) -> np.ndarray:
    """(2m,) on the rows that the LCP ties (`fixed_rows`: both sides prescribed, the
    compliance round-off), the largest motion their dropped compliance row can make,
    sqrt(C_ii work) with work = lam . C lam (C = G K^-1 G^T, a Gram matrix in the K^-1
    inner product, so |(C lam)_i| <= sqrt(C_ii) sqrt(lam . C lam)); 0 on the other rows.
    The LCP's kinematics of a tied row leave that coupling out (its tie), the displacement
    field keeps it: on hard/shear_off.toml with mortar-smooth, an end pair (C_ii = 5e-29,
    G coefficients of 1e-13 on free nodes) moved 1.4e-18 in u and not in the LCP, and its
    `consistency` read 6.8e-7 against the u side's round-off alone. c_diag (2m,)."""
    m = c_diag.size // 2
    comp = np.abs(c_diag)
    out = np.zeros(2 * m)
    for block in (slice(0, m), slice(m, 2 * m)):
        rows, _ = fixed_rows(comp[block])
        out[block][rows] = np.sqrt(comp[block][rows] * max(work, 0.0))
    return out


def pair_scales(c_diag: np.ndarray, interface: np.ndarray, forces: np.ndarray,
                f_run: float, floor: np.ndarray, solve_rel: float = 0.0,
                motion: tuple[np.ndarray, float] | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """(F (m,), s (2m,)): each pair's force scale, its interface's largest |force| (at
    least FORCE_FLOOR f_run, or solve_rel / PAIR_WARN f_run where the linear solves'
    relative residual solve_rel (iterative, else 0) is larger than ROUNDOFF_ULPS eps: the
    forces carry it as the displacements do; bonded.toml at --mesh-size 0.8 with -ksp_type
    cg -pc_type gamg -ksp_atol 1e-12, pulled off, leaves q = 8.8e-12 on open pairs, which
    read 2.7e-6 against FORCE_FLOOR), and its kinematic scales (normal rows, then tangential):
    C_ii F, the motion its interface's forces make at it, or floor / PAIR_WARN where the
    round-off `floor` (2m,) is above PAIR_WARN of that, so that a residual at round-off
    reads at most PAIR_WARN. c_diag (2m,) the compliance diagonal; interface (m,) int;
    forces (k, m) the force arrays that set the scale (p, q, a, c). A pair whose
    compliance is round-off (`fixed_rows`: the supports fix its motion; 1e-35 on
    two_blocks.toml's end pairs) is judged with the stiff tie the LCP gives it.
    motion: (forces (k, m), f_run) that set the kinematic scale in place of `forces` and
    `f_run` (the pairs' own p and q and the loads, not the bond's a and c: a bond of
    a = c = 1e12 on bonded.toml, forces of 1 to 380, made s = C_ii 1e12 and hid p or q
    1e-3 off (read 7e-14; the run-wide KKT read 1.0))."""
    m = interface.size
    comp = np.abs(c_diag).copy()
    tied = np.zeros(2 * m, dtype=bool)
    for block in (slice(0, m), slice(m, 2 * m)):
        rows, _ = fixed_rows(comp[block])
        top = float(comp[block].max(initial=0.0))
        comp[block][rows] = np.maximum(comp[block][rows], FIXED_COMPLIANCE_REL * top)
        tied[block][rows] = True
    force_floor = max(FORCE_FLOOR, solve_rel / PAIR_WARN)
    # the force its kinematic round-off makes through its own compliance: the LCP's
    # forces come from its kinematics (q = H (...), H ~ 1 / C_tt), so they carry it (not
    # through a tied row's stiff tie: its force is the tie's, no scale of the pair's)
    with np.errstate(divide="ignore", invalid="ignore"):
        own = np.where((comp > 0) & ~tied, floor / (PAIR_WARN * comp), 0.0)
    f_itf = _interface_max(forces, interface, force_floor * f_run)
    f = np.maximum(f_itf, np.maximum(own[:m], own[m:]))
    # the motion: C_ii x the forces (floor / PAIR_WARN is the own floor of its row)
    fk = f_itf if motion is None else \
        _interface_max(motion[0], interface, force_floor * motion[1])
    s = np.maximum(comp * np.concatenate([fk, fk]), floor / PAIR_WARN)
    return f, s


def _interface_max(forces: np.ndarray, interface: np.ndarray, least: float) -> np.ndarray:
    """(m,) each pair's interface's largest |force| over forces (k, m), at least least."""
    n_itf = int(interface.max(initial=-1)) + 1
    size = np.abs(forces).max(axis=0, initial=0.0)
    biggest = np.array([size[interface == k].max(initial=0.0) for k in range(n_itf)])
    return np.maximum(biggest[interface] if interface.size else np.zeros(0), least)


def pair_residuals(gap: np.ndarray, dtau: np.ndarray, p: np.ndarray, q: np.ndarray,
                   mu: np.ndarray, a: np.ndarray, c: np.ndarray, frictional: np.ndarray,
                   f: np.ndarray, s: np.ndarray, overlap: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(r_n, r_t) (m,) each: the normal and tangential residuals of the law (module doc)
    per pair. gap, dtau (slip increment tau - tau_prev) in length; p, q, a, c forces
    (p compression positive, q along the pair's tangent); f (m,), s (2m,) `pair_scales`.
    overlap (m,): the overlap (> 0; < 0 a gap) the step read as closed
    (`StepSolution.closed_overlap`: prescribed by the supports at a pair fixed on both
    sides, within the state tolerance), judged as gap 0: the gap is judged as gap +
    overlap, so a pair that overlaps by more than that (or by any amount where it is 0)
    still reads. On hard/shear_off.toml with the block's sides 1e-13 lower than the
    base's, the written gap of -1e-13 read 0.023 against the end pair's own round-off scale."""
    m = p.size
    tiny = 1e-300
    s_n, s_t = np.maximum(s[:m], tiny), np.maximum(s[m:], tiny)
    f = np.maximum(f, tiny)
    if overlap is not None:
        gap = gap + overlap
    r_n = np.abs(np.minimum(gap / s_n, (p + a) / f))
    bound = mu * p + c
    dtau = np.where(frictional, dtau, 0.0)
    over = np.maximum(np.abs(q) - bound, 0.0) / f
    moved = np.minimum(np.abs(dtau) / s_t, np.abs(q + np.sign(dtau) * bound) / f)
    return r_n, np.maximum(over, moved)


def pair_law(gap: np.ndarray, dtau: np.ndarray, p: np.ndarray, q: np.ndarray,
             mu: np.ndarray, a: np.ndarray, c: np.ndarray, frictional: np.ndarray,
             f: np.ndarray, s: np.ndarray, mismatch: np.ndarray, interface: np.ndarray,
             names: list[str], s_consistency: np.ndarray | None = None,
             overlap: np.ndarray | None = None) -> dict:
    """summary `steps[k].kkt_pairs`: the largest per-pair `normal`, `tangential` and
    `consistency` residuals (mismatch (2m,): G u - the LCP's kinematics, over
    s_consistency, s if None), where the worst one is (`interface`, `pair` its 0-based
    index in the step file's /contact), and the same three per interface
    (`by_interface`). overlap: see `pair_residuals`."""
    r_n, r_t = pair_residuals(gap, dtau, p, q, mu, a, c, frictional, f, s, overlap)
    m = p.size
    sc = s if s_consistency is None else s_consistency
    miss = np.abs(mismatch) / np.maximum(sc, 1e-300)
    r_c = np.maximum(miss[:m], miss[m:])
    worst = np.maximum(np.maximum(r_n, r_t), r_c)
    out = {"normal": _max(r_n), "tangential": _max(r_t), "consistency": _max(r_c)}
    if m:
        i = int(np.argmax(np.where(np.isnan(worst), np.inf, worst)))
        out["interface"], out["pair"] = names[int(interface[i])], i
    out["by_interface"] = {
        name: {"normal": _max(r_n[sel]), "tangential": _max(r_t[sel]),
               "consistency": _max(r_c[sel])}
        for k, name in enumerate(names) if (sel := interface == k).any()}
    return out


def _max(x: np.ndarray) -> float:
    """Largest entry (NaN if any is NaN: a NaN residual must warn), 0 for none."""
    return float(np.max(x, initial=0.0)) if not np.isnan(x).any() else float("nan")


def kkt_pairs_warning(kkt_pairs: dict, step: int) -> str | None:
    """The warning text for a step's `kkt_pairs` figures (step 1-based), or None when each
    is at most PAIR_WARN."""
    bad = {k: kkt_pairs[k] for k in ("normal", "tangential", "consistency")
           if not kkt_pairs[k] <= PAIR_WARN}  # (NaN warns too)
    if not bad:
        return None
    worst = ", ".join(f"{k} {v:.3g}" for k, v in bad.items())
    where = f"interface '{kkt_pairs['interface']}', pair {kkt_pairs['pair']}"
    return (f"step {step}: the contact answer breaks the interface law on its own scale "
            f"({worst}, relative to each pair's own forces and compliance; at most "
            f"{PAIR_WARN:g} expected; worst at {where}): the forces and displacements written "
            "there do not solve the contact problem; report it")
