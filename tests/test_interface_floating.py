"""Floating bodies (app/interface/floating.py): the pins that make K regular keep the
contact rows independent, so that the compliance C = G K^-1 G^T keeps its rank."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sps
from support import CONFIGS, kkt_violations, read_summary, run_cli

from app.interface.floating import FloatingModes, _pins, held_text

PAIR_KEYS = ("normal", "tangential", "consistency")  # summary steps[k].kkt_pairs


def test_pins_leave_the_contact_rows_independent():
    """Three pairs on one body's DOFs 0-2 share one master DOF (4), as the slave nodes of a
    bond share a coarser master; DOF 3 touches no pair. Every row keeps a DOF off the body,
    so each DOF alone is a safe pin, but the modes' largest entries (DOFs 0 and 1, where QR
    with pivoting pinned them) pinned together leave rows 0 and 1 both -e4: dependent, C
    singular. The pins must keep the rows' rank (3) on the unpinned DOFs."""
    g = sps.csr_matrix(np.array([[1.0, 0.0, 0.0, 0.0, -1.0],
                                 [0.0, 1.0, 0.0, 0.0, -1.0],
                                 [0.0, 0.0, 1.0, 0.0, -1.0]]))
    rb = np.array([[10.0, 0.0], [0.0, 10.0], [1.0, 1.0], [1.0, -1.0]])
    dofs = np.arange(4)
    pins = _pins(rb, dofs, SimpleNamespace(g=g), np.zeros(0, dtype=np.int64))
    assert np.linalg.matrix_rank(rb[pins]) == 2  # they pin both modes
    free = np.setdiff1d(np.arange(5), pins)
    assert np.linalg.matrix_rank(g[:, free].toarray()) == 3  # (2 with pins 0 and 1)


def _run(out, ranks: int):
    res = run_cli(["run", str(CONFIGS / "multibody.toml"), "--sd", "1", "--mesh-size", "0.8",
                   "--out", str(out), "--quiet"], ranks=ranks)
    assert res.returncode == 0, res.stderr
    return read_summary(out)


def test_multibody_1sd_coarse_solves(tmp_path):
    """multibody.toml --sd 1 --mesh-size 0.8: block1 (one element thick, 12 zero-energy
    modes) had its pins on the bond's slave nodes, whose master (the foundation) is twice
    as coarse: two tangential combinations moved no free DOF, C was singular, the
    null-space tie put 1e12 into the modes' block, and Lemke ended 'inaccurate' after 264
    pivots (exit 2). The answer found now also solves the old pins' LCP: the step had a
    solution."""
    s = _run(tmp_path / "r1", 1)
    assert s["status"] == "completed" and len(s["steps"]) == 4
    f_scale = 0.0
    for st in s["steps"]:
        assert st["dependent_tangential_directions"] == 0
        assert st["balance"]["max_relative_residual"] < 1e-12  # measured 1.6e-14
        assert max(st["kkt_pairs"][k] for k in PAIR_KEYS) < 1e-12  # measured 3.3e-15
        f_scale = max(f_scale, st["balance"]["force_scale"])
    for k in range(1, 5):
        v = kkt_violations(tmp_path / "r1", k, f_scale)
        assert max(v.values()) < 1e-9, (k, v)


@pytest.mark.mpi
def test_multibody_1sd_coarse_agrees_on_two_ranks(tmp_path):
    import h5py

    a, b = _run(tmp_path / "r1", 1), _run(tmp_path / "r2", 2)
    assert b["ranks"] == 2 and b["status"] == "completed"
    assert a["strain_energy"] == pytest.approx(b["strain_energy"], rel=1e-12)
    for step in range(1, 5):
        with h5py.File(tmp_path / "r1" / f"step_{step:04d}.h5") as x, \
                h5py.File(tmp_path / "r2" / f"step_{step:04d}.h5") as y:
            for key in ("displacement", "contact/p", "contact/q"):
                u, v = x[key][()], y[key][()]
                assert np.abs(u - v).max() <= 1e-10 * np.abs(u).max(), (step, key)
            assert np.array_equal(x["contact/state"][()], y["contact/state"][()])


def test_multibody_1sd_at_1_2_has_an_equilibrium_that_lemke_missed(tmp_path):
    """multibody.toml --sd 1 --mesh-size 1.2 stopped with `no static equilibrium at step 1`
    (Lemke's secondary ray), yet the step's LCP has a solution: with 22 free hourglass
    amplitudes and friction the LCP is not copositive-plus and the ray proves nothing. The
    mixed-integer search (`app.lcp.mip`) finds its basis and Lemke solves from it; the
    hourglass modes slide the contacts (warned)."""
    out = tmp_path / "out"
    res = run_cli(["run", str(CONFIGS / "multibody.toml"), "--sd", "1", "--mesh-size", "1.2",
                   "--out", str(out)])
    assert res.returncode == 0, res.stderr
    assert "is held only by contact 'stack' and nothing loads it" in res.stderr
    # the slid amplitudes are not unique, the forces are (review8: read 1.0, warned "off by
    # up to 1"; measured 2.4e-12 at most)
    assert "round-off limits the contact answer" not in res.stderr
    s = read_summary(out)
    assert s["status"] == "completed" and len(s["steps"]) == 4
    assert max(st["lcp_accuracy"] for st in s["steps"]) < 1e-10
    f_scale = 0.0
    for st in s["steps"]:
        assert st["balance"]["max_relative_residual"] < 1e-12  # measured 3.3e-13
        assert max(st["kkt_pairs"][k] for k in PAIR_KEYS) < 1e-11  # measured 1.5e-12
        f_scale = max(f_scale, st["balance"]["force_scale"])
    for k in range(1, 5):
        v = kkt_violations(out, k, f_scale)
        assert max(v.values()) < 1e-9, (k, v)


def test_multibody_1sd_at_1_2_in_other_units_completes_alike(tmp_path):
    """The same scene with its moduli, loads and bond strengths x 1e6 (the same
    displacements, forces x 1e6, the unit-diagonal LCP's q x 1e3). Before, the search's
    bound applied to the scaled unknowns as they came: none below 1e3, `no static
    equilibrium` at step 1. With q scaled to its largest entry (`app.lcp.mip`) it is the
    same search: the shipped units' answer (strain energy 0.47031060728530827) x 1e6."""
    f = 1e6
    sets = [f"body.{b}.E={e * f}" for b, e in (("foundation", 1000), ("block1", 2000),
                                               ("block2", 500), ("side", 1500),
                                               ("cylinder", 3000))]
    sets += [f"interface.bond.a={2 * f}", f"interface.bond.c={3 * f}",
             f"load.0.total_force=[0.0, {-20 * f}]", f"load.1.total_force=[{0.8 * f}, 0.0]"]
    out = tmp_path / "out"
    res = run_cli(["run", str(CONFIGS / "multibody.toml"), "--sd", "1", "--mesh-size", "1.2",
                   "--out", str(out), "--quiet", *(x for s in sets for x in ("--set", s))])
    assert res.returncode == 0, res.stderr
    s = read_summary(out)
    assert s["status"] == "completed" and len(s["steps"]) == 4
    assert s["strain_energy"] == pytest.approx(0.47031060728530827 * f, rel=1e-9)
    for st in s["steps"]:
        assert st["balance"]["max_relative_residual"] < 1e-12  # measured 4.2e-13
        assert max(st["kkt_pairs"][k] for k in PAIR_KEYS) < 1e-11  # measured 1.8e-12


def test_multibody_1sd_at_1_0_stops_naming_the_search(tmp_path):
    """multibody.toml --sd 1 --mesh-size 1.0: the step's LCP has solutions only with
    hourglass amplitudes in the thousands (Lemke on the unscaled matrix: a mode amplitude
    of 6.3e3 in a scene 6 wide, its basis accepted by Lemke's check on the scaled LCP in
    0 pivots), none with the scaled unknowns below 1e3: the run stops, its line saying
    that the search found none, that such an equilibrium may need amplitudes far beyond
    small displacements (before: only `may have no equilibrium`), and suggesting --sd 2."""
    out = tmp_path / "out"
    res = run_cli(["run", str(CONFIGS / "multibody.toml"), "--sd", "1", "--mesh-size", "1.0",
                   "--out", str(out), "--quiet"])
    assert res.returncode == 2
    (line,) = res.stderr.strip().splitlines()
    assert line.startswith("error: the contact problem could not be solved at step 1")
    assert "a mixed-integer search found no solution with the scaled unknowns below" in line
    assert "or one only with hourglass amplitudes far beyond small displacements" in line
    assert "--sd 2 or more" in line
    assert read_summary(out)["status"] == "failed"


def test_held_text_counts_zero_energy_modes_and_names_rigid_ones():
    """A failed step's line names rigid modes held only by contact one by one and counts a
    body's zero-energy (hourglass) modes: multibody --sd 1 at 0.8 listed 21 of them."""
    nan = np.full((3, 3), np.nan)
    rigid = np.eye(3)[:, :1]
    names = ["b1: translation x", "blk: zero-energy mode 1", "blk: zero-energy mode 2",
             "cyl: zero-energy mode 1"]
    fm = FloatingModes(np.zeros((4, 4)), np.arange(4), names, ["b1", "blk", "blk", "cyl"],
                       np.hstack([rigid, nan]))
    assert held_text(fm) == ("b1: translation x, blk: 2 zero-energy modes, "
                             "cyl: 1 zero-energy mode")


def test_no_equilibrium_of_hourglass_modes_suggests_hourglass_free_smoothing(tmp_path):
    """multibody --sd 1 --mesh-size 1.6: the modes' equilibrium with the forces in their
    friction cones is infeasible (no static equilibrium). The line counts the zero-energy
    modes per body and points to --sd 2 (which completes there), fem-q4 or a finer mesh."""
    out = tmp_path / "out"
    res = run_cli(["run", str(CONFIGS / "multibody.toml"), "--sd", "1", "--mesh-size", "1.6",
                   "--out", str(out), "--quiet"])
    assert res.returncode == 2
    (line,) = res.stderr.strip().splitlines()
    assert line.startswith("error: no static equilibrium at step 1")
    assert "held only by contact: block1: 8 zero-energy modes" in line
    assert "zero-energy mode 1," not in line and "--sd 2 or more" in line
    s = read_summary(out)
    assert s["status"] == "failed" and "--sd 2 or more" in s["error"]
