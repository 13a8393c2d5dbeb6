"""Per-pair contact output of a step (the /contact group of step_NNNN.h5 and
contact.xdmf) and the interface-law check recomputed from the displacement field."""

from __future__ import annotations

import numpy as np

from app.interface.steps import StepSolution
from app.output.pair_law import (
    PAIR_WARN,
    body_scale,
    kinematic_floor,
    pair_law,
    pair_scales,
    tied_coupling,
)


def contact_arrays(setup, result: StepSolution, u: np.ndarray,
                   thickness: float) -> tuple[dict, dict]:
    """Per-pair arrays for the step file, and the KKT check (`kkt_check`).

    setup: the run's ContactSetup (pairs, G, rows, mu, frictional); result: the step's
    LCP result (lam, state, tau_prev, slip, debonded_step, a, c, f_scale); u: (2n,).
    """
    pr = setup.pairs
    m = pr.n_pairs
    gu = setup.g @ u
    gap_u = pr.g0 + gu[:m]
    tau_u = gu[m:]
    p, q = result.lam[:m], result.lam[m:]
    scale_len = pr.length * thickness
    data = {
        "position": pr.position,
        "x": pr.position[:, 0],
        "y": pr.position[:, 1],
        "interface": pr.interface.astype(np.int64),
        "slave": pr.slave.astype(np.int64),
        "master": pr.master.astype(np.int64),
        "xi": pr.xi,
        "normal": pr.normal,
        "tangent": pr.tangent,
        "g0": pr.g0,
        "length": pr.length,
        "p": p / scale_len,
        "q": q / scale_len,
        "p_force": p,
        "q_force": q,
        "gap": gap_u,
        "tau": tau_u,
        "tau_prev": result.tau_prev,
        "slip_increment": tau_u - result.tau_prev,
        "slip": result.slip,
        "state": result.state.astype(np.int64),
        "debonded_step": result.debonded_step.astype(np.int64),
        "mu": setup.mu,
        "a_force": result.a,
        "c_force": result.c,
    }
    if setup.rows is not None:  # the rows of G (the KKT check of tests/support.py)
        data |= {"g_cols": setup.rows.cols, "g_normal": setup.rows.g_normal,
                 "g_tangent": setup.rows.g_tangent}
    kkt = kkt_check(gap_u, tau_u, result.tau_prev, p, q, setup.mu, result.a, result.c,
                    setup.frictional,
                    u_scale=max(float(np.abs(u).max(initial=0.0)), result.u_scale),
                    f_scale=result.f_scale)
    return data, kkt


def pair_scales_of(setup, result: StepSolution, u: np.ndarray, node_body: np.ndarray,
                   solve_rel: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(G u (2m,), F (m,), s (2m,)): the step's kinematics from u (2n,) and each pair's
    own force and kinematic scales (`app.output.pair_law.pair_scales`) from the LCP
    result (lam, compliance_diag, a, c, tau_prev, f_scale, load_scale); node_body (n,) body index of
    each node; solve_rel the linear solves' relative residual if iterative (else 0). No
    solve: O(nnz(G) + n + m)."""
    pr = setup.pairs
    m = pr.n_pairs
    floor = kinematic_floor(abs(setup.g), body_scale(u, node_body), pr.g0, result.tau_prev,
                            solve_rel)
    forces = np.stack([result.lam[:m], result.lam[m:], result.a, result.c])
    f_run = max(float(np.abs(forces).max(initial=0.0)), result.f_scale)
    # the motion's scale from the pairs' own forces and the loads, not the bond's a, c
    lam_run = max(float(np.abs(result.lam).max(initial=0.0)), result.load_scale)
    f, s = pair_scales(result.compliance_diag, pr.interface, forces, f_run, floor,
                       solve_rel, (forces[:2], lam_run))
    return setup.g @ u, f, s


def consistency_scales(result: StepSolution, s: np.ndarray) -> np.ndarray:
    """(2m,) the scales of the `consistency` residual G u - LCP kinematics: s
    (`pair_scales_of`), and on a tied row at least the motion its dropped compliance row
    can make over PAIR_WARN (`app.output.pair_law.tied_coupling`)."""
    if result.compliance_diag is None:
        return s
    return np.maximum(s, tied_coupling(result.compliance_diag, result.contact_work)
                      / PAIR_WARN)


def kkt_pairs_check(setup, result: StepSolution, u: np.ndarray, node_body: np.ndarray,
                    names: list[str], solve_rel: float = 0.0) -> dict:
    """summary `steps[k].kkt_pairs`: the law and the consistency with the LCP judged on
    each pair against its own scales (`app.output.pair_law`), from the displacement field
    u (2n,) and the step's LCP result (lam, kinematics, ...); node_body (n,); names: the
    interfaces' names in config order; solve_rel: see `pair_scales_of`."""
    pr = setup.pairs
    m = pr.n_pairs
    gu, f, s = pair_scales_of(setup, result, u, node_body, solve_rel)
    p, q = result.lam[:m], result.lam[m:]
    return pair_law(pr.g0 + gu[:m], gu[m:] - result.tau_prev, p, q, setup.mu, result.a,
                    result.c, setup.frictional, f, s, gu - result.kinematics, pr.interface,
                    names, consistency_scales(result, s), result.closed_overlap)


def kkt_check(gap: np.ndarray, tau: np.ndarray, tau_prev: np.ndarray, p: np.ndarray,
              q: np.ndarray, mu: np.ndarray, a: np.ndarray, c: np.ndarray,
              frictional: np.ndarray, *, u_scale: float = 0.0,
              f_scale: float = 0.0) -> dict:
    """Largest violations of METHOD section 4, relative to the data's scales.

    u_scale / f_scale: displacement and force scales of the problem (the largest
    displacement of the step's field and the largest load), floors for the normalisation.
    """
    fs = max(np.abs(p).max(initial=0.0), np.abs(q).max(initial=0.0), np.abs(a).max(initial=0),
             np.abs(c).max(initial=0.0), f_scale, 1e-300)
    us = max(np.abs(gap).max(initial=0.0), np.abs(tau).max(initial=0.0), u_scale, 1e-300)
    bound = mu * p + c
    dtau = np.where(frictional, tau - tau_prev, 0.0)
    slipping = np.abs(dtau) > 1e-6 * us
    direction = np.where(slipping, np.abs(q + np.sign(dtau) * bound), 0.0)
    return {
        "gap": float(max(0.0, -gap.min(initial=0.0)) / us),
        "normal_force": float(max(0.0, -(p + a).min(initial=0.0)) / fs),
        # each factor scaled first: us * fs underflows to 0 when both are at their floor
        # (a step with no load and no motion), and the figure was NaN (0 / 0)
        "complementarity": float(np.abs(gap / us * ((p + a) / fs)).max(initial=0.0)),
        "friction_bound": float(max(0.0, (np.abs(q) - bound).max(initial=0.0)) / fs),
        "slip_direction": float(direction.max(initial=0.0) / fs),
    }
