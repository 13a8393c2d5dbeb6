"""The interface law judged pair by pair against each pair's own scale
(app/output/pair_law.py, summary `steps[k].kkt_pairs`).

Synthetic contrast cases: two interfaces whose compliances differ by 1e11, every pair in
stick at p = 1, q = 0.2. A force 1e-3 off on the stiff interface moves it by 1e-3 of its
own motion, 1e-14 of the soft one's: the run-wide KKT check (`kkt_check`, gaps against
the largest displacement) reads round-off; the per-pair check fails it. Before, the run of
hard/tangential_contrast.toml with q 44% off on the stiff interface read KKT 1e-12.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from app.output.contact import kkt_check
from app.output.pair_law import (
    EPS,
    PAIR_WARN,
    ROUNDOFF_ULPS,
    body_scale,
    kinematic_floor,
    kkt_pairs_warning,
    pair_law,
    pair_residuals,
    pair_scales,
    tied_coupling,
)

M = 4  # pairs 0, 1 on the stiff interface, 2, 3 on the soft one
INTERFACE = np.array([0, 0, 1, 1])
NAMES = ["stiff", "soft"]
MU = np.full(M, 0.3)
FRICTIONAL = np.ones(M, dtype=bool)
ZERO = np.zeros(M)


def _compliance(contrast: float) -> np.ndarray:
    """(2m, 2m) SPD compliance, rows (n0..n3, t0..t3): each interface's four rows coupled,
    the stiff interface's block `contrast` times the soft one's, no coupling between
    them (separate bodies)."""
    rng = np.random.default_rng(3)
    a = rng.normal(size=(4, 4))
    block = a @ a.T + 4 * np.eye(4)
    c = np.zeros((2 * M, 2 * M))
    for k, factor in ((0, contrast), (1, 1.0)):
        rows = np.array([2 * k, 2 * k + 1, M + 2 * k, M + 2 * k + 1])
        c[np.ix_(rows, rows)] = factor * block
    return c


def _answer(c: np.ndarray, lam: np.ndarray, lam_true: np.ndarray):
    """(gap, tau) of forces lam when the free motion makes lam_true the answer (every pair
    closed and stuck: gap = tau = 0 at lam_true), and the round-off floor of their terms."""
    kin = c @ (lam - lam_true)
    floor = ROUNDOFF_ULPS * EPS * (np.abs(c) @ np.abs(lam))
    return kin[:M], kin[M:], floor


def _figures(c: np.ndarray, lam: np.ndarray, kin_from=None) -> tuple[dict, dict]:
    """(run-wide kkt, per-pair kkt_pairs) of forces lam on compliance c."""
    lam_true = np.concatenate([np.ones(M), np.full(M, 0.2)])
    gap, tau, floor = _answer(c, lam, lam_true)
    p, q = lam[:M], lam[M:]
    u_scale = float(np.abs(c @ lam_true).max())  # the soft interface's motion
    old = kkt_check(gap, tau, ZERO, p, q, MU, ZERO, ZERO, FRICTIONAL, u_scale=u_scale,
                    f_scale=1.0)
    f, s = pair_scales(np.diagonal(c), INTERFACE, np.stack([p, q, ZERO, ZERO]), 1.0, floor)
    mismatch = np.zeros(2 * M) if kin_from is None else np.concatenate([gap, tau]) - kin_from
    new = pair_law(gap, tau, p, q, MU, ZERO, ZERO, FRICTIONAL, f, s, mismatch, INTERFACE,
                   NAMES)
    return old, new


def _lam(dp: float = 0.0, dq: float = 0.0) -> np.ndarray:
    """p = 1, q = 0.2 on every pair; the stiff interface's p and q times (1 + dp), (1 + dq)."""
    p, q = np.ones(M), np.full(M, 0.2)
    p[INTERFACE == 0] *= 1 + dp
    q[INTERFACE == 0] *= 1 + dq
    return np.concatenate([p, q])


def test_the_right_answer_reads_round_off():
    old, new = _figures(_compliance(1e-11), _lam())
    assert max(old.values()) <= 1e-15
    assert max(new["normal"], new["tangential"], new["consistency"]) <= 1e-12, new


@pytest.mark.parametrize("contrast", [1e-10, 1e-11, 1e-12])
@pytest.mark.parametrize("dp, dq, key", [(0.0, 1e-3, "tangential"), (1e-3, 0.0, "normal"),
                                         (0.0, -0.44, "tangential")])
def test_a_wrong_force_on_the_stiff_interface_fails(contrast, dp, dq, key):
    """q (or p) of the stiff interface 1e-3 off (and 44% off, the old run's error): the
    run-wide check reads round-off (it passed the old run at 1e-12); the per-pair one
    fails, at the stiff interface."""
    old, new = _figures(_compliance(contrast), _lam(dp, dq))
    assert max(old.values()) < 1e-9, old  # blind: measured against the soft motion
    assert new[key] > 1e-5, new  # q 1e-3 off is 2e-4 of the interface's force scale p
    assert new["interface"] == "stiff" and new["pair"] in (0, 1)
    assert new["by_interface"]["soft"][key] <= 1e-12
    text = kkt_pairs_warning(new, 1)
    assert text is not None and "interface 'stiff'" in text and key in text


def test_sensitivity_reaches_round_off():
    """An error of 1e-5 of q on the stiff interface (2e-6 of its force scale) still
    fails: the check sees what is above PAIR_WARN of the pair's own scale."""
    _, new = _figures(_compliance(1e-11), _lam(dq=1e-5))
    assert new["tangential"] > PAIR_WARN


def test_consistency_per_pair():
    """The LCP's kinematics off by 1e-3 of the stiff pairs' own motion: invisible against
    the largest displacement (1e-14 of it), a failing `consistency` per pair."""
    c = _compliance(1e-11)
    lam = _lam()
    kin = np.zeros(2 * M)
    kin[M:M + 2] = 1e-3 * np.diagonal(c)[M:M + 2]  # LCP says the stiff pairs moved
    _, new = _figures(c, lam, kin_from=kin)
    assert new["consistency"] == pytest.approx(1e-3, rel=1e-6)
    assert new["by_interface"]["soft"]["consistency"] == 0.0


def test_slip_direction_and_bound():
    """A slipping pair must carry q = -sign(slip) F; a stuck one stay within F."""
    f, s = np.ones(1), np.ones(2)
    one = np.ones(1)
    args = (one * 0.3, np.zeros(1), np.zeros(1), np.ones(1, dtype=bool), f, s)
    # slipping +1 with q = -0.3 (right), +0.3 (wrong sense), 0.1 (inside the cone)
    assert pair_residuals(one * 0, one, one, -0.3 * one, *args)[1][0] == pytest.approx(0.0)
    assert pair_residuals(one * 0, one, one, 0.3 * one, *args)[1][0] == pytest.approx(0.6)
    assert pair_residuals(one * 0, one, one, 0.1 * one, *args)[1][0] == pytest.approx(0.4)
    # stuck beyond the bound; open but pressed; penetrating
    assert pair_residuals(one * 0, one * 0, one, 0.5 * one, *args)[1][0] == pytest.approx(0.2)
    assert pair_residuals(one * 0.5, one * 0, one, 0 * one, *args)[0][0] == pytest.approx(0.5)
    assert pair_residuals(-0.1 * one, one * 0, one, 0 * one, *args)[0][0] == pytest.approx(0.1)


def test_round_off_of_a_body_reads_below_the_warning():
    """hard/shear_off.toml: the bond's end pair moves 1e-13 as much as its block under the
    interface's forces, and round-off of the block's solve (eps x its max |u|) moved it by
    2e-19: 1.7e-3 of its own scale. With the body's displacement in the round-off floor
    it reads below PAIR_WARN; a real error above that floor still fails."""
    node_body = np.array([0, 0, 1, 1])  # nodes 0, 1 (pair's slave side and far node)
    u = np.array([0.0, 1e-19, 1e-3, 0.0, 0.0, 0.0, 0.0, 0.0])  # body 0's far node moves
    ub = body_scale(u, node_body)
    assert ub.tolist() == [1e-3] * 4 + [0.0] * 4
    g = sp.csr_matrix(([1.0, -1.0, 1.0, -1.0], ([0, 0, 1, 1], [1, 5, 0, 4])), shape=(2, 8))
    floor = kinematic_floor(abs(g), ub, np.zeros(1), np.zeros(1))
    c_diag = np.array([1e-16, 1e-16])
    f, s = pair_scales(c_diag, np.zeros(1, dtype=int), np.ones((1, 1)), 1.0, floor)
    r_n, _ = pair_residuals(np.array([-2e-19]), np.zeros(1), np.ones(1), np.zeros(1),
                            MU[:1], np.zeros(1), np.zeros(1), np.ones(1, bool), f, s)
    assert r_n[0] <= PAIR_WARN
    _, s0 = pair_scales(c_diag, np.zeros(1, dtype=int), np.ones((1, 1)), 1.0, 0.0 * floor)
    assert 2e-19 / s0[0] > PAIR_WARN  # without the body's round-off: a false alarm
    r_bad, _ = pair_residuals(np.array([-1e-12]), np.zeros(1), np.ones(1), np.zeros(1),
                              MU[:1], np.zeros(1), np.zeros(1), np.ones(1, bool), f, s)
    assert r_bad[0] > PAIR_WARN


def test_iterative_solves_raise_the_floor_of_the_displacements_only():
    """With iterative linear solves at a relative residual of 1e-12, |G| ub carries that
    (not eps): hard/shear_off.toml with cg + gamg read 2.9e-6 on its end pairs before.
    The initial gap and the previous slip are data: their round-off stays eps."""
    g_abs = sp.csr_matrix(np.array([[1.0, 1.0], [1.0, 0.0]]))
    ub = np.array([1e-3, 1e-3])
    direct = kinematic_floor(g_abs, ub, np.array([1.0]), np.array([0.0]))
    iterative = kinematic_floor(g_abs, ub, np.array([1.0]), np.array([0.0]), 1e-12)
    eps64 = ROUNDOFF_ULPS * EPS
    np.testing.assert_allclose(direct, [eps64 * (2e-3 + 1.0), eps64 * 1e-3])
    np.testing.assert_allclose(iterative, [1e-12 * 2e-3 + eps64, 1e-12 * 1e-3])


def test_round_off_forces_and_fixed_pairs_read_below_the_warning():
    """hard/pull_off.toml pulled off: open pairs carry q = 4e-16 beside loads of 4.5;
    two_blocks.toml's end pairs (both sides prescribed) have a compliance of 1e-35 and
    move by 1e-34: both round-off, both below PAIR_WARN."""
    interface = np.zeros(2, dtype=int)
    forces = np.stack([np.zeros(2), np.array([4e-16, 0.0])])
    f, s = pair_scales(np.array([1e-3, 1e-3, 1e-3, 1e-3]), interface, forces, 4.5,
                       np.zeros(4))
    _, r_t = pair_residuals(np.full(2, 1e-3), np.zeros(2), np.zeros(2), forces[1],
                            np.full(2, 0.3), np.zeros(2), np.zeros(2), np.ones(2, bool), f, s)
    assert r_t.max() <= PAIR_WARN
    f, s = pair_scales(np.array([1.0, 1.0, 1e-35, 1.0]), interface, np.ones((1, 2)), 1.0,
                       np.zeros(4))
    assert s[2] == pytest.approx(1e-12)  # the LCP's stiff tie, not the round-off 1e-35
    _, r_t = pair_residuals(np.zeros(2), np.array([1.8e-34, 0.0]), np.ones(2), np.zeros(2),
                            np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2, bool), f, s)
    assert r_t.max() == 0.0


def test_forces_at_the_iterative_solves_accuracy_read_below_the_warning():
    """bonded.toml at --mesh-size 0.8 with -ksp_type cg -pc_type gamg -ksp_atol 1e-12,
    pulled off: the open, sliding pairs carry q = 8.8e-12 (MUMPS: 1.8e-15) beside the run's
    largest force, here 235. With the solves' relative residual 1e-12 in the force floor
    it is round-off of those solves; against eps alone it warned (2.7e-6)."""
    interface = np.zeros(2, dtype=int)
    q = np.array([-8.8e-12, 3.9e-12])
    forces = np.stack([np.zeros(2), q])
    args = (np.array([1e-3, 1e-3, 1e-3, 1e-3]), interface, forces, 235.0, np.zeros(4))

    def tangential(solve_rel: float) -> float:
        f, s = pair_scales(*args, solve_rel=solve_rel)
        return pair_residuals(np.full(2, 1e-3), np.full(2, -0.03), np.zeros(2), q,
                              np.full(2, 0.3), np.zeros(2), np.zeros(2), np.ones(2, bool),
                              f, s)[1].max()

    assert tangential(0.0) > PAIR_WARN  # direct solves: 8.8e-12 is not round-off of 235
    assert tangential(1e-12) <= 0.1 * PAIR_WARN


def test_warning_text_and_nan():
    ok = {"normal": 1e-9, "tangential": 0.0, "consistency": 1e-7, "interface": "a", "pair": 0}
    assert kkt_pairs_warning(ok, 2) is None
    bad = ok | {"tangential": float("nan")}
    assert "tangential nan" in kkt_pairs_warning(bad, 2)
    empty = pair_law(*(np.zeros(0),) * 7, np.zeros(0, bool), np.zeros(0), np.zeros(0),
                     np.zeros(0), np.zeros(0, int), [])
    assert empty == {"normal": 0.0, "tangential": 0.0, "consistency": 0.0, "by_interface": {}}
    assert kkt_pairs_warning(empty, 1) is None


def test_force_round_off_of_a_long_slide_reads_below_the_warning():
    """bonded.toml pulled off, then the lifted block slid 27 (ux history extended to
    1000): the open pairs' q is recovered from a tangential motion of 27 through
    H ~ 1 / C_tt, so it carries round-off eps x 27 / C_tt (6.8e-12 at C_tt = 5.8e-3), far
    above FORCE_FLOOR of the run's forces (380: 5.3e-6), and read 1.26e-6 with a
    warning. The force a pair's kinematic round-off makes through its own compliance
    (floor / C_ii) is round-off of its forces too. A real force there (1e-3 of the run's)
    still fails."""
    interface = np.zeros(1, dtype=int)
    c_diag = np.array([5.8e-3, 5.8e-3])
    g_abs = sp.csr_matrix(np.array([[1.0, 1.0], [1.0, 1.0]]))
    floor = kinematic_floor(g_abs, np.array([30.0, 30.0]), np.array([0.016]), np.zeros(1))

    def tangential(q: float) -> float:
        forces = np.stack([np.zeros(1), np.array([q])])
        f, s = pair_scales(c_diag, interface, forces, 380.0, floor)
        return pair_residuals(np.full(1, 0.016), np.full(1, 27.0), np.zeros(1),
                              np.array([q]), np.full(1, 0.3), np.zeros(1), np.zeros(1),
                              np.ones(1, bool), f, s)[1][0]

    assert tangential(6.8e-12) <= 0.1 * PAIR_WARN
    assert tangential(0.38) > 1e3 * PAIR_WARN


def test_a_strong_bond_does_not_set_the_motion_scale():
    """bonded.toml with a = c = 1e12 (forces of 1 to 380): with the bond's a and c in the
    motion's scale, s = C_ii 1e12 and p or q 1e-3 off read 7e-14 per pair (the run-wide
    KKT read 1.0). The motion is judged against the pairs' own forces and the loads
    (`motion`); the force residuals (p + a, |q| - mu p - c) keep a and c in their scale."""
    c = _compliance(1.0)
    lam_true = np.concatenate([np.ones(M), np.full(M, 0.2)])
    bond = np.full(M, 1e12)
    floor = ROUNDOFF_ULPS * EPS * (np.abs(c) @ np.abs(lam_true))

    def worst(lam: np.ndarray, motion) -> float:
        gap, tau, _ = _answer(c, lam, lam_true)
        forces = np.stack([lam[:M], lam[M:], bond, bond])
        f, s = pair_scales(np.diagonal(c), INTERFACE, forces, 1e12, floor, 0.0,
                           None if motion is None else (forces[:2], 1.0))
        out = pair_law(gap, tau, lam[:M], lam[M:], MU, bond, bond, FRICTIONAL, f, s,
                       np.zeros(2 * M), INTERFACE, NAMES)
        return max(out["normal"], out["tangential"])

    wrong = lam_true * np.concatenate([np.full(M, 1 + 1e-3), np.ones(M)])
    assert worst(wrong, None) < 1e-12  # blind with the bond in the scale
    assert worst(wrong, "pq") > 1e-4
    assert worst(lam_true, "pq") <= 1e-12


def test_a_fixed_tangential_row_does_not_blind_the_normal_check():
    """A pair whose tangential motion the supports fix (C_tt round-off, 1e-35: the LCP
    ties it) and whose normal compliance is 1e-3: the force its tangential round-off
    makes through the tie is no scale for its gap (judged so, a gap error of 1e-3 of its
    own motion read 1e-7); the normal check keeps C_nn F."""
    interface = np.zeros(2, dtype=int)
    c_diag = np.array([1e-3, 1e-3, 1e-35, 1e-3])
    g_abs = sp.csr_matrix(np.eye(4))
    floor = kinematic_floor(g_abs, np.full(4, 1e-3), np.zeros(2), np.zeros(2))
    forces = np.stack([np.ones(2), np.zeros(2)])
    f, s = pair_scales(c_diag, interface, forces, 1.0, floor)
    r_n, _ = pair_residuals(np.array([-1e-6, 0.0]), np.zeros(2), np.ones(2), np.zeros(2),
                            np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2, bool), f, s)
    assert r_n[0] > 1e-4


def test_a_tied_rows_dropped_coupling_is_bounded_and_read_below_the_warning():
    """A pair both of whose sides are prescribed but whose G row keeps coefficients of
    1e-13 on free nodes (mortar-smooth's end pair on hard/shear_off.toml: C_ii = 5e-29):
    the LCP ties the row and drops its coupling (C lam)_i, which u keeps. That motion is at
    most sqrt(C_ii lam . C lam) (Cauchy-Schwarz in the K^-1 inner product), so judged on
    that bound it reads at most PAIR_WARN; the other rows are not touched, and a mismatch
    far above the bound still fails."""
    rng = np.random.default_rng(5)
    a = rng.standard_normal((6, 6))
    k_inv = a @ a.T + 6 * np.eye(6)  # SPD, 6 free DOFs
    g = np.zeros((4, 6))  # rows n0, n1, t0, t1 of two pairs
    g[0, :2] = [1e-13, -2e-13]  # pair 0 normal: fixed but for round-off coefficients
    g[1] = rng.standard_normal(6)
    g[2, 2:4] = [3e-13, 1e-13]  # pair 0 tangential
    g[3] = rng.standard_normal(6)
    c = g @ k_inv @ g.T
    lam = np.array([0.0, 0.13, 0.0, 0.02])
    work = float(lam @ c @ lam)
    bound = tied_coupling(np.diagonal(c), work)
    assert bound[1] == 0.0 and bound[3] == 0.0  # real compliance: not tied
    dropped = c @ lam  # what u carries on the tied rows and the LCP leaves out
    assert abs(dropped[0]) <= bound[0] and abs(dropped[2]) <= bound[2]
    assert abs(dropped[0]) > 1e-3 * bound[0]  # and the bound is not loose by far
    mismatch = np.array([dropped[0], 0.0, dropped[2], 0.0])
    tied = [0, 2]
    # the scales the consistency check reads (`consistency_scales`), over a round-off s
    from types import SimpleNamespace

    from app.output.contact import consistency_scales
    res = SimpleNamespace(compliance_diag=np.diagonal(c), contact_work=work)
    sc = consistency_scales(res, np.full(4, 1e-30))
    assert sc[1] == sc[3] == 1e-30  # the untied rows keep their own scale
    assert (np.abs(mismatch) / sc)[tied].max() <= PAIR_WARN
    assert (1e3 * np.abs(mismatch) / sc)[tied].max() > PAIR_WARN  # far above still fails


def test_a_prescribed_overlap_read_as_closed_is_allowed_and_no_more():
    """hard/shear_off.toml's end pair (both sides prescribed: C_nn round-off, the LCP's
    stiff tie) with the block's sides 1e-13 lower than the base's: the step reads that
    overlap as closed (`StepSolution.closed_overlap`) and the field writes gap = -1e-13.
    Before, judged as a gap, it read 0.023 against the pair's own round-off scale (a false
    warning); judged with the overlap allowed it reads round-off, while a written gap
    2e-13 deep with 1e-13 allowed, or 1e-13 deep with none, still fails."""
    interface = np.zeros(2, dtype=int)
    c_diag = np.array([1e-35, 1e-3, 1e-35, 1e-3])  # pair 0 fixed on both sides
    g_abs = sp.csr_matrix(np.eye(4))
    floor = kinematic_floor(g_abs, np.array([1e-4, 1e-4, 1e-4, 1e-4]), np.zeros(2),
                            np.zeros(2))
    forces = np.stack([np.array([0.0, 0.13]), np.zeros(2)])
    f, s = pair_scales(c_diag, interface, forces, 0.13, floor)
    closed = np.array([1e-13, 0.0])
    args = (np.zeros(2), np.zeros(2), np.full(2, 0.3), np.zeros(2), np.zeros(2),
            np.ones(2, bool), f, s)

    def normal(gap, overlap):
        return pair_residuals(np.array([gap, 0.0]), args[0], np.array([0.0, 0.13]),
                              *args[1:], overlap)[0][0]

    assert normal(-1e-13, None) > 1e-3  # the false warning before (0.023 in the run)
    assert normal(-1e-13 - 1e-19, closed) <= PAIR_WARN  # its own round-off (1.4e-18)
    assert normal(-2e-13, closed) > 1e-3  # deeper than the overlap read as closed
    assert normal(-1e-13, np.zeros(2)) > 1e-3  # no overlap read as closed: a violation
    law = pair_law(np.array([-1e-13, 0.0]), np.zeros(2), np.array([0.0, 0.13]),
                   np.zeros(2), np.full(2, 0.3), np.zeros(2), np.zeros(2),
                   np.ones(2, bool), f, s, np.zeros(4), interface, ["bond"],
                   overlap=closed)
    assert law["normal"] <= PAIR_WARN
