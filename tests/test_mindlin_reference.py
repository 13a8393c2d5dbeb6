"""Mindlin-Deresiewicz (app/references/mindlin.py): the 2D closed form under load reversal,
Masing's memory rule, the dissipation, and a run of configs/mindlin_cycle.toml."""

from __future__ import annotations

import math

import h5py
import numpy as np
import pytest

from app.closed_form import cattaneo_traction, hertz_cylinder, hertz_pressure
from app.references import ContactProfile, RunFigures, reference
from app.references.mindlin import (
    cycle_dissipation,
    masing_path,
    masing_traction,
    mindlin_errors,
    virgin_dissipation,
)
from tests.support import CONFIGS, read_summary, run_cli

H = hertz_cylinder(8.63, 1.0, 200e3, 0.3, 200e3, 0.3)
A, P0, ES, MU = H["a"], H["p0"], H["E_star"], 0.2
P = math.pi * A * P0 / 2
MUP = MU * P
X = np.linspace(-A, A, 200001)


def dv(q: float) -> float:
    return float(virgin_dissipation(q, MUP, ES))


@pytest.mark.parametrize("r", [0.2, 0.64, 0.95])
def test_virgin_dissipation_is_the_friction_work_of_the_cattaneo_slip(r):
    """mu p |s| over the slip zone, s from the surface strain of the two elliptic terms."""
    c = A * math.sqrt(1 - r)
    x = np.linspace(c, A, 400001)[1:]
    s = MU * P0 / (ES * A) * (x * np.sqrt(x * x - c * c) - c * c * np.arccosh(x / c))
    work = 2 * np.trapz(MU * hertz_pressure(x, A, P0) * s, x)
    assert dv(r * MUP) == pytest.approx(work, rel=1e-5)
    assert cycle_dissipation(r * MUP, MUP, ES) == pytest.approx(4 * work, rel=1e-5)


@pytest.mark.parametrize("q_now", [0.5, 0.0, -0.3, -0.64])
def test_unloading_traction_is_admissible_and_carries_the_load(q_now):
    """After Q* = 0.64 mu P: |q| <= mu p, q = -mu p in the counter-slip annulus, and the
    resultant is Q."""
    terms, _, _ = masing_path(np.array([0.64, q_now]) * MUP, dv)
    q = masing_traction(X, terms[-1], A, P0, MU, MUP)
    bound = MU * hertz_pressure(X, A, P0)
    assert np.all(np.abs(q) <= bound * (1 + 1e-9) + 1e-12 * MU * P0)
    assert np.trapz(q, X) == pytest.approx(q_now * MUP, abs=1e-6 * MUP)
    c_new = A * math.sqrt(1 - (0.64 - q_now) / 2)
    annulus = (np.abs(X) > c_new * 1.001) & (np.abs(X) < A)
    assert np.allclose(q[annulus], -bound[annulus], atol=1e-9 * MU * P0)


def test_memory_rule_closes_the_loop_and_rejoins_the_virgin_branch():
    qs = 0.64 * MUP
    terms, work, _ = masing_path(np.array([qs, -qs, qs]), dv)
    virgin = cattaneo_traction(X, A, P0, MU, 0.64)
    assert np.allclose(masing_traction(X, terms[1], A, P0, MU, MUP), -virgin, atol=1e-12)
    assert np.allclose(masing_traction(X, terms[2], A, P0, MU, MUP), virgin, atol=1e-12)
    assert work[2] - work[0] == pytest.approx(cycle_dissipation(qs, MUP, ES), rel=1e-12)
    # beyond the first peak after an unload-reload: the virgin branch again
    q1, q2 = 0.3 * MUP, 0.7 * MUP
    terms, work, _ = masing_path(np.array([q1, 0.0, q2]), dv)
    assert terms[-1] == ((1.0, q2),)
    assert work[-1] == pytest.approx(dv(q2) + 4 * dv(q1 / 2), rel=1e-12)
    # the branch each step slid on: the younger one up to where it meets the older
    path = np.array([0.64, 0.128, 0.64, 0.64, 0.7]) * MUP
    terms, _, slip = masing_path(path, dv)
    assert np.allclose(slip / MUP, [0.64, 0.256, 0.256, 0.0, 0.7], atol=1e-12)
    assert terms[2] == ((1.0, 0.64 * MUP),)  # back on the virgin branch, the loop forgotten
    # past -Q* the virgin branch on the other side
    terms, _, _ = masing_path(np.array([qs, -0.8 * MUP]), dv)
    assert terms[-1] == ((-1.0, 0.8 * MUP),)


def _figures(path: list[float]) -> RunFigures:
    """A profile that is the closed form at the end of `path` (fractions of mu P)."""
    x = np.linspace(-1.5 * A, 1.5 * A, 3001)
    length = np.full_like(x, x[1] - x[0])
    Q = np.array(path) * MUP
    terms, work, _ = masing_path(Q, dv)
    p = hertz_pressure(x, A, P0)
    q = masing_traction(x, terms[-1], A, P0, MU, MUP)
    prof = ContactProfile(x=x, p=p, q=q, length=length, p_force=p * length,
                          q_force=q * length, stick=np.zeros(x.size, bool), mu=MU, E_star=ES,
                          interface="contact")
    steps = [{"interfaces": {"contact": {"tangential_force": float(v), "normal_force": P,
                                         "dissipation": float(d)}}}
             for v, d in zip(Q, np.diff(work, prepend=0.0), strict=True)]
    return RunFigures(E=200e3, nu=0.3, plane="strain", thickness=1.0, strain_energy=1.0,
                      point_values={}, contact=prof, steps=steps)


def test_reference_reads_the_load_path_from_the_steps():
    out = reference("mindlin").compare({"radius": 1.0}, _figures([0.0, 0.32, 0.64, 0.0,
                                                                   -0.08]))["mindlin"]
    assert out["traction_l2_interp_rel_error"] < 0.01 and out["traction_l2_rel_error"] < 0.01
    assert out["dissipation_rel_error"] < 1e-3 and out["turning_points"] == 1
    # the same final load reached monotonically is another traction: a large error
    fig = _figures([0.0, 0.32, 0.64, 0.0, -0.08])
    fig.steps = fig.steps[-1:]
    assert reference("mindlin").compare({"radius": 1.0}, fig)["mindlin"][
        "traction_l2_interp_rel_error"] > 1.0


def test_cycle_run_follows_the_closed_form(tmp_path):
    """configs/mindlin_cycle.toml on its level-0 mesh (a/5 at the contact, 3 s): the
    errors measured there (README "Load reversal"), the loop closing after one cycle
    (step 26 = step 6), and the interface-law audit."""
    out = tmp_path / "out"
    res = run_cli(["run", str(CONFIGS / "mindlin_cycle.toml"), "--out", str(out)])
    assert res.returncode == 0, res.stderr
    m = read_summary(out)["reference"]["mindlin"]
    assert m["turning_points"] == 1  # the loop -Q*, +Q* is closed: only the last +Q* counts
    assert m["traction_l2_interp_rel_error"] < 0.50  # 0.477 (0.21, 0.11, 0.072 refined)
    assert m["dissipation_rel_error"] < 0.08  # 0.071 (0.022, 0.0078, 0.0030 refined)
    q = {}
    for k in (6, 16, 26):
        with h5py.File(out / f"step_{k:04d}.h5") as f:
            q[k] = f["contact"]["q_force"][()]
    scale = np.abs(q[6]).max()
    assert np.abs(q[26] - q[6]).max() < 1e-10 * scale
    assert np.abs(q[16] - q[6]).max() > 0.5 * scale  # reversed, not stuck
    import subprocess
    import sys

    from tests.support import ROOT, mpi_env
    audit = subprocess.run([sys.executable, "scripts/check_interface_law.py", str(out)],
                           cwd=ROOT, env=mpi_env(), capture_output=True, text=True)
    assert audit.returncode == 0, audit.stdout[-2000:]


def test_nested_loop_is_forgotten_by_the_run(tmp_path):
    """Q* -> 0.2 Q* -> Q* (an inner loop) -> 1.2 Q* -> 0.5 Q*: back at Q* the run holds
    the state it had there before (Masing's memory rule), and goes on along the virgin
    branch; the reference follows the same path."""
    out = tmp_path / "out"
    hist = "[0.0, 0.5, 1.0, 0.6, 0.2, 0.6, 1.0, 1.1, 1.2, 0.85, 0.5]"
    res = run_cli(["run", str(CONFIGS / "mindlin_cycle.toml"), "--set", "analysis.steps=11",
                   "--set", f"load.0.history={hist}", "--out", str(out)])
    assert res.returncode == 0, res.stderr
    q = {}
    for k in (3, 7):
        with h5py.File(out / f"step_{k:04d}.h5") as f:
            q[k] = f["contact"]["q_force"][()]
    assert np.abs(q[7] - q[3]).max() < 1e-10 * np.abs(q[3]).max()
    m = read_summary(out)["reference"]["mindlin"]
    assert m["turning_points"] == 1  # the peak at 1.2 Q*; the inner loop is gone
    assert m["traction_l2_interp_rel_error"] < 0.35  # 0.320 (0.048 at level 3)
    assert m["dissipation_rel_error"] < 0.3  # 0.240 (0.0051 at level 3)


@pytest.mark.parametrize("over", [-1e-14, 0.0, 1e-14])
def test_gross_slip_is_said_and_does_not_hinge_on_round_off(over):
    """|Q| at mu P (a displacement-driven path slides): the traction is compared with
    q = mu p, the dissipation has no closed form. Before, 1e-14 above mu P gave nan for
    every figure and 1e-14 below a finite, meaningless dissipation error, silently."""
    x = np.linspace(-1.5 * A, 1.5 * A, 3001)
    length = np.full_like(x, x[1] - x[0])
    q = MU * hertz_pressure(x, A, P0)
    m = mindlin_errors(x, q, length, Q_path=np.array([0.5, 1.0 + over, 1.0]) * MUP, P=P,
                       mu=MU, R=1.0, E_star=ES, stick=np.zeros(x.size, bool))
    assert m["gross_slip_step"] == 2 and m["note"].startswith("gross slip")
    assert math.isnan(m["dissipation_exact"]) and m["stick_half_width_exact"] == 0.0
    assert m["traction_l2_rel_error"] < 1e-3


def test_a_path_beyond_mu_p_is_refused_with_a_note():
    x = np.linspace(-A, A, 101)
    m = mindlin_errors(x, 0 * x, np.full_like(x, x[1] - x[0]), Q_path=np.array([1.2 * MUP]),
                       P=P, mu=MU, R=1.0, E_star=ES)
    assert math.isnan(m["traction_l2_rel_error"]) and "not held" in m["note"]
    # just past the gross-slip band: the note shows by how much (it read "= 1 > 1")
    m = mindlin_errors(x, 0 * x, np.full_like(x, x[1] - x[0]),
                       Q_path=np.array([(1.0 + 2e-8) * MUP]), P=P, mu=MU, R=1.0, E_star=ES)
    assert "max |Q| / (mu P) = 1 + 2e-08 with P" in m["note"]


def test_p_variation_counts_the_start_of_a_step_that_applies_q():
    """P and Q applied in one step (not Cattaneo's sequence): P went 0 -> P while Q was on,
    P_variation 1 (it read 0 before, only the ends of the steps were compared)."""
    one = reference("mindlin").compare({"radius": 1.0}, _figures([0.5]))["mindlin"]
    assert one["P_variation"] == pytest.approx(1.0)
    fig = _figures([0.0, 0.5])  # P first, then Q: held
    assert reference("mindlin").compare({"radius": 1.0}, fig)["mindlin"]["P_variation"] < 1e-4


def test_a_frictionless_interface_gets_nan_with_a_note():
    fig = _figures([0.0, 0.5])
    fig.contact.mu = 0.0
    out = reference("mindlin").compare({"radius": 1.0}, fig)["mindlin"]
    assert math.isnan(out["traction_l2_rel_error"]) and "mu = 0" in out["note"]


def test_stick_edges_are_positions_on_the_interface_as_cattaneos():
    """`stick_edges` are absolute x (centre added back), as `cattaneo.stick_edges`; they were
    relative to `center_x`."""
    fig = _figures([0.0, 0.64])
    x0, c = 0.3, A * math.sqrt(1.0 - 0.64)
    fig.contact.stick = np.abs(fig.contact.x) < c
    fig.contact.x = fig.contact.x + x0
    out = reference("mindlin").compare({"radius": 1.0, "center_x": x0}, fig)["mindlin"]
    assert out["stick_half_width_rel_error"] < 1e-3
    left, right = out["stick_edges"]
    assert left == pytest.approx(x0 - c, abs=2e-3 * A)
    assert right == pytest.approx(x0 + c, abs=2e-3 * A)


def test_an_empty_stick_zone_is_a_full_error():
    """No pair sticks where the branch has a stick zone: half-width 0, relative error 1.0
    (NaN before, which reads as 'no reference' in a study's table)."""
    x = np.linspace(-1.5 * A, 1.5 * A, 3001)
    length = np.full_like(x, x[1] - x[0])
    Q_path = np.array([0.25, 0.5]) * MUP
    q = cattaneo_traction(x, A, P0, MU, 0.5)
    m = mindlin_errors(x, q, length, Q_path=Q_path, P=P, mu=MU, R=1.0, E_star=ES,
                       stick=np.zeros(x.size, bool))
    assert m["stick_half_width"] == 0.0 and m["stick_half_width_exact"] > 0
    assert m["stick_half_width_rel_error"] == pytest.approx(1.0)
