"""Unloaded contact-held modes (app/interface/weak_modes.py): the kernel on a synthetic
cylinder-on-flat contact, and the run's warning on hertz.toml (coarse: warns; default: not)."""

from __future__ import annotations

import numpy as np
import pytest

from app.interface.floating import FloatingModes
from app.interface.weak_modes import (
    SLIDE_WARN,
    describe,
    held_mode_entries,
    held_mode_slides,
    slide_warning,
)
from tests.support import CONFIGS, read_summary, run_cli

R = 1.0  # radius: the cylinder's centre is at (0, R), the contact at y = 0


def _cylinder(theta: float, elastic: float = 0.0, m: int = 21, a: float = 0.1):
    """Pairs on y = 0 under a cylinder with modes (rotation about (0, R), translation y),
    Hertzian p, and tau = the rotation's slide R theta + an antisymmetric elastic part."""
    x = np.linspace(-1.5 * a, 1.5 * a, m)
    length = np.full(m, x[1] - x[0])
    p = np.sqrt(np.clip(1 - (x / a) ** 2, 0.0, None)) * length
    n_modes = np.stack([x, np.ones(m)], axis=1)  # gap change per unit theta, unit ty
    t_modes = np.stack([np.full(m, R), np.zeros(m)], axis=1)
    tau = R * theta + elastic * x / a
    return dict(p=p, q=np.zeros(m), tau=tau, interface=np.zeros(m, dtype=np.int64),
                length=length, n_modes=n_modes, t_modes=t_modes,
                frictional=np.zeros(m, dtype=bool))


def test_a_rolled_cylinder_fires_and_names_the_slide():
    case = _cylinder(theta=0.01)
    (h,) = held_mode_slides(**case, groups=[np.array([0, 1])])
    width = case["length"][case["p"] > 0].sum()
    assert h.slide == pytest.approx(0.01 * R, rel=1e-9)
    assert h.width == pytest.approx(width)
    assert h.ratio == pytest.approx(0.01 * R / width, rel=1e-9)
    assert h.ratio > SLIDE_WARN
    assert abs(h.v[0]) == pytest.approx(1.0, abs=1e-9)  # the rotation, not the loaded ty


def test_a_small_roll_and_the_elastic_antisymmetric_slip_stay_silent():
    case = _cylinder(theta=1e-5, elastic=1e-3)  # elastic slip 100 x the roll, odd in x
    (h,) = held_mode_slides(**case, groups=[np.array([0, 1])])
    assert h.slide == pytest.approx(1e-5 * R, rel=1e-6)
    assert h.ratio < SLIDE_WARN


def test_a_mode_the_contact_does_not_slide_leaves_the_fit_alone():
    """A third unloaded mode that opens the contact (odd gap pattern, no net force) but
    whose tangential pattern is round-off (1e-14, as CS-FEM-1SD's hourglass modes give):
    the slide is still the roll's, whatever basis of the modes the eigen-solve returned.
    Before PATTERN_RCOND, the round-off column entered the fit with an amplitude of 1e12
    and the slide took the elastic part of tau: multibody.toml --sd 1 warned on one rank
    count and not on the other."""
    case = _cylinder(theta=1e-4, elastic=1e-3)
    x = np.linspace(-1.5, 1.5, case["p"].size)
    noise = 1e-14 * np.random.default_rng(0).standard_normal(x.size)
    case["n_modes"] = np.column_stack([case["n_modes"], x**3])
    case["t_modes"] = np.column_stack([case["t_modes"], noise])
    slides = []
    for seed in range(4):  # the same modes in four bases (columns mixed by a rotation)
        rot = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))[0]
        mixed = dict(case, n_modes=case["n_modes"] @ rot, t_modes=case["t_modes"] @ rot)
        (h,) = held_mode_slides(**mixed, groups=[np.array([0, 1, 2])])
        slides.append(h.slide)
        assert h.amplitude < 1.0  # no round-off direction blown up
    assert slides == pytest.approx([1e-4 * R] * 4, rel=1e-6)


def test_loaded_and_undetermined_modes_are_not_checked():
    case = _cylinder(theta=0.05)
    # only translation y: the load's mode (net force = sum p), nothing unloaded is left
    one = dict(case, n_modes=case["n_modes"][:, 1:], t_modes=case["t_modes"][:, 1:])
    assert held_mode_slides(**one, groups=[np.array([0])]) == []
    # a frictionless sideways translation moves no gap: undetermined, reported elsewhere
    side = dict(case, n_modes=np.zeros((case["p"].size, 1)),
                t_modes=np.ones((case["p"].size, 1)))
    assert held_mode_slides(**side, groups=[np.array([0])]) == []
    # a friction-held translation that carries a tangential load (net q != 0) is loaded
    fric = dict(side, frictional=np.ones(case["p"].size, dtype=bool), q=0.3 * case["p"])
    assert held_mode_slides(**fric, groups=[np.array([0])]) == []


def test_round_off_friction_does_not_decide_whether_a_mode_is_loaded():
    """A friction-held sideways translation whose pairs carry q at round-off (1e-15 of p,
    as the full LCP leaves and the LCP over candidate pairs does not) is as unloaded as with
    q = 0: before FORCE_ROUND_OFF the round-off q was the translation's whole gross force,
    its net 100% of it, and `contact_held_modes` held an entry with candidate pairs and none
    without (cattaneo.toml at 1e-3 of its approach, search_distance 0.5, step 1)."""
    case = _cylinder(theta=0.0)
    m = case["p"].size
    side = dict(case, n_modes=np.zeros((m, 1)), t_modes=np.ones((m, 1)),
                frictional=np.ones(m, dtype=bool))
    exact = held_mode_slides(**side, groups=[np.array([0])])
    noisy = held_mode_slides(**dict(side, q=1e-15 * case["p"].max() * np.linspace(1, 2, m)),
                             groups=[np.array([0])])
    assert len(exact) == len(noisy) == 1


def test_entries_name_the_rotation_centre_and_warn_once_above_the_threshold():
    case = _cylinder(theta=0.01)
    centroid = np.array([0.0, 0.5])
    # rotation about (0, R) = rotation about the centroid + translation x of 0.5 R
    rigid = np.array([[R - centroid[1], 0.0], [0.0, 1.0], [1.0, 0.0]])
    modes = FloatingModes(np.zeros((4, 2)), np.zeros(2, dtype=np.int64),
                          ["cyl: rotation about (x=0, y=1)", "cyl: translation y"],
                          ["cyl", "cyl"], rigid, np.array([centroid, centroid]))
    (e,) = held_mode_entries(**case, floating=modes, interface_names=["contact"])
    assert e["body"] == "cyl" and e["interface"] == "contact"
    assert e["mode"] == "rotation about (x=0, y=1)"
    assert e["warn"] and e["slide_ratio"] > SLIDE_WARN
    text = slide_warning(e, 3)
    assert "body 'cyl'" in text and "contact 'contact'" in text and "step 3" in text
    assert "support" in text and "refine" in text
    assert describe(np.array([0.0, 1.0]), rigid, centroid, ["r", "ty"]) == "translation y"
    assert describe(np.array([1.0, 0.0]), None, None, ["r", "ty"]) == "r"


def test_a_rotation_centre_within_the_fits_resolution_of_zero_reads_zero():
    """multibody.toml's cylinder read 'x=-1.42e-09' (round-off of the pattern fit, whose
    resolution is PATTERN_RCOND = 1e-8) where the centre is x = 0."""
    centroid = np.array([0.0, 1.0])
    off = np.array([[0.0], [-5e-9], [1.0]])  # tx, ty, th: centre x = 0 - ty / th = 5e-9
    assert describe(np.array([1.0]), off, centroid, ["r"]) == "rotation about (x=0, y=1)"
    real = np.array([[0.0], [-5e-7], [1.0]])  # 5e-7: above the resolution, shown
    assert describe(np.array([1.0]), real, centroid, ["r"]) == "rotation about (x=5e-07, y=1)"


def _run(tmp_path, name: str, *args: str, ranks: int = 1):
    out = tmp_path / name
    r = run_cli(["run", str(CONFIGS / "hertz.toml"), "--out", str(out), "--quiet", *args],
                ranks=ranks)
    assert r.returncode == 0, r.stderr
    return r, read_summary(out)


def _held(summary: dict) -> dict:
    (entry,) = summary["steps"][-1]["contact_held_modes"]
    assert entry["body"] == "cylinder" and entry["interface"] == "contact"
    assert entry["mode"] == "rotation about (x=0, y=1)"
    return entry


def test_coarse_hertz_warns_in_the_summary_and_on_stderr(tmp_path):
    r, s = _run(tmp_path, "coarse", "--mesh-size", "1.0")
    entry = _held(s)
    assert entry["warn"] and entry["slide_ratio"] > 5 * SLIDE_WARN  # measured 2.0e-2
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("warning: body 'cylinder'")]
    assert len(lines) == 1 and "rotation about (x=0, y=1)" in lines[0]
    assert [w for w in s["warnings"] if w.startswith("body 'cylinder'")] == [lines[0][9:]]


def test_default_hertz_is_silent(tmp_path):
    r, s = _run(tmp_path, "default")
    entry = _held(s)
    assert not entry["warn"] and entry["slide_ratio"] < SLIDE_WARN / 3  # measured 4.9e-4
    assert "warning" not in r.stderr and "warnings" not in s


@pytest.mark.mpi
def test_coarse_hertz_warns_once_on_two_ranks(tmp_path):
    r, s = _run(tmp_path, "coarse2", "--mesh-size", "1.0", ranks=2)
    assert s["ranks"] == 2
    assert _held(s)["warn"]
    assert sum(ln.startswith("warning: body 'cylinder'") for ln in r.stderr.splitlines()) == 1
    assert len(s["warnings"]) == 1


def _slides(summary: dict) -> list[tuple]:
    return [(k, e["body"], e["interface"], e["slide"]) for k, s in enumerate(summary["steps"])
            for e in s.get("contact_held_modes", [])]


@pytest.mark.mpi
def test_hourglass_mode_slides_agree_on_one_and_two_ranks(tmp_path):
    """multibody.toml with CS-FEM-1SD: three floating bodies with hourglass modes. The
    slides are the same on 1 and 2 ranks (they were round-off: 5.97e-3 against 6.10e-3 for
    block2 on 'stack', and 'stack' warned for both blocks at 0.42-0.46%); measured now at
    most 0.19% of the contact width, no slide warning."""
    runs = []
    for ranks in (1, 2):
        out = tmp_path / f"n{ranks}"
        r = run_cli(["run", str(CONFIGS / "multibody.toml"), "--out", str(out), "--quiet",
                     "--sd", "1"], ranks=ranks)
        assert r.returncode == 0, r.stderr
        runs.append(read_summary(out))
    a, b = (_slides(s) for s in runs)
    assert [x[:3] for x in a] == [x[:3] for x in b]
    width = max(e["contact_width"] for s in runs[0]["steps"] for e in s["contact_held_modes"])
    for x, y in zip(a, b, strict=True):
        assert abs(x[3] - y[3]) <= 1e-9 * width, (x, y)
    for s in runs:
        assert not any(w.startswith("body ") for w in s.get("warnings", []))


def test_a_block_dragged_into_gross_slip_is_loaded_by_its_friction():
    """A block dragged over a foundation by a roller on its top (ux prescribed) is free to
    tilt about its top's centre, 1 above the contact: a uniform slide and a linear gap.
    Its friction's moment (q uniform, every pair slipping) is balanced by a lopsided
    pressure, so the interface's net force on the tilt is 0, and the tilt was taken for an
    unloaded mode: the drag's slide (0.06 over a width 2.2) read as the mode sliding the
    contact, with the warning that the discretisation moves it (hunt: /tmp config, README
    "Input checks"). The friction alone loads it: no unloaded combination is left."""
    x = np.linspace(-1.0, 1.0, 11)
    length = np.full(x.size, 0.2)
    mu = 0.3
    p = 1.0 + mu * x.size / (x**2).sum() * x  # sum(p x) + sum(q) = 0
    q = -mu * p
    case = dict(p=p, q=q, tau=np.full(x.size, 0.06), interface=np.zeros(x.size, np.int64),
                length=length, n_modes=x[:, None], t_modes=np.ones((x.size, 1)),
                frictional=np.ones(x.size, dtype=bool))
    assert abs((p * x).sum() + q.sum()) < 1e-12
    assert held_mode_slides(**case, groups=[np.array([0])]) == []
    # the same tilt with no friction force (a frictionless roll) is still checked
    still = dict(case, q=np.zeros(x.size), p=np.ones(x.size))
    (h,) = held_mode_slides(**still, groups=[np.array([0])])
    assert h.ratio == pytest.approx(0.06 / 2.2) and h.ratio > SLIDE_WARN
