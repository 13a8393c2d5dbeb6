"""The `mortar-coarse-slave` discretisation: mortar with the multipliers on the coarser
side (README "Multiplier spaces on a coarse master")."""

from __future__ import annotations

import numpy as np
import pytest
from support import CONFIGS, kkt_violations, read_summary, run_cli
from test_contact_mortar import itf
from test_contact_pairs import stacked

from app.contact.discretisation import DISCRETISATIONS
from app.contact.mortar import mortar_constraints
from app.contact.mortar_coarse_slave import (
    SWAP_RATIO,
    mortar_coarse_slave_constraints,
    size_ratio_probe,
    swapped,
)
from app.contact.resolution import interior_deviation
from app.contact.smoothness import local_fit_deviation
from app.output.read import last_step_file, read_pairs

DISC = "mortar-coarse-slave"


def same_rows(a, b) -> None:
    np.testing.assert_array_equal(a.pairs.slave, b.pairs.slave)
    np.testing.assert_array_equal(a.cols, b.cols)
    np.testing.assert_allclose(a.g_normal, b.g_normal, atol=1e-15)
    np.testing.assert_allclose(a.g_tangent, b.g_tangent, atol=1e-15)
    np.testing.assert_allclose(a.pairs.g0, b.pairs.g0, atol=1e-15)


def test_registered_and_swapped_spec_keeps_the_rest():
    assert DISCRETISATIONS[DISC] is mortar_coarse_slave_constraints
    s = swapped(itf(sd=0.3, penetration_tol=1e-3, interference=True))
    assert (s.slave, s.master, s.search_distance) == ("low_top", "up_bottom", 0.3)
    assert s.penetration_tol == 1e-3 and s.interference and s.name == "t"


@pytest.mark.parametrize("n_low, n_up", [(5, 7), (7, 5), (16, 4)])
def test_a_coarser_or_similar_master_keeps_mortars_rows(n_low, n_up):
    """Master up to SWAP_RATIO x the slave (7/5 = 1.4), or finer (the coarse side is the
    slave already; 4 on 16: the master is 4x finer): the rows are mortar's."""
    mesh = stacked(n_low, n_up, gap=0.01)
    same_rows(mortar_coarse_slave_constraints(mesh, itf(), 0), mortar_constraints(mesh, itf(), 0))
    seen: list[float] = []
    mortar_constraints(mesh, itf(), 0, master_basis=size_ratio_probe(seen))
    assert seen == [pytest.approx(n_up / n_low)] and seen[0] <= SWAP_RATIO


def test_a_fine_slave_on_a_coarse_master_swaps_the_roles():
    """Upper block 16 elements as slave on a lower block of 4 (4x): the pairs are the
    lower block's nodes, with the rows of mortar the other way round."""
    mesh = stacked(4, 16, gap=0.01)
    rows = mortar_coarse_slave_constraints(mesh, itf(), 0)
    same_rows(rows, mortar_constraints(mesh, swapped(itf()), 0))
    assert np.all(mesh.node_body()[rows.pairs.slave] == 0)  # lower block = "low"
    assert rows.n_pairs == 5
    np.testing.assert_allclose(rows.pairs.normal, [[0.0, -1.0]] * 5, atol=1e-14)


@pytest.mark.parametrize("slave, master, fy", [("upper_bottom", "lower_top", 20.0),
                                               ("lower_top", "upper_bottom", -20.0)])
def test_patch_test_with_a_coarse_master_either_way(tmp_path, slave, master, fy):
    """patch.toml with the lower block at 0.5 (2.5x the upper): uniform p to 1e-8 as
    configured and swapped (mortar-smooth: 8.0% as configured, README); and
    steps[k].interfaces.<name>.force is the force on the configured slave (10 x 2 up on the
    upper block) whether or not the roles swapped (it flipped sign with the swap before)."""
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                   "--set", "body.lower.size=0.5",
                   "--set", f'interface.interface.discretisation="{DISC}"',
                   "--set", f'interface.interface.slave="{slave}"',
                   "--set", f'interface.interface.master="{master}"'])
    assert res.returncode == 0, res.stderr
    c = read_pairs(last_step_file(out), 0, ("p", "slave"))
    assert np.abs(c["p"] - 10.0).max() / 10.0 < 1e-8
    assert max(kkt_violations(out, 1).values()) < 1e-7
    force = read_summary(out)["steps"][-1]["interfaces"]["interface"]["force"]
    np.testing.assert_allclose(force, [0.0, fy], atol=1e-8)


def test_fine_bond_on_a_coarse_foundation_stays_bonded(tmp_path):
    """multibody's bond with block1 at 0.0333 on the foundation's 0.2 (6x): mortar
    debonds 41 of 91 pairs (README); with the multipliers on the foundation none of its
    15 debond."""
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "multibody.toml"), "--out", str(out), "--quiet",
                   "--set", "body.block1.size=0.0333",
                   "--set", f'interface.bond.discretisation="{DISC}"'])
    assert res.returncode == 0, res.stderr
    c = read_pairs(last_step_file(out), 0, ("state", "debonded_step"))
    assert c["state"].size == 15
    assert np.all(c["state"] == 0) and np.all(c["debonded_step"] == 0)
    for step in range(1, 5):
        assert max(kkt_violations(out, step).values()) < 1e-6


def test_indent_on_the_coarse_block_is_smooth_and_close_to_the_fine_answer(tmp_path):
    """indent.toml as shipped (arc 0.018 on block 0.08): the pairs move to the block (6),
    p within 4% of the local fit (mortar: 30%), 2 pairs in from the ends within 2%; max p
    57.8 against 59.1 with the block meshed at the arc's size (mortar: 86.8). The arc's
    nodes are not constrained one by one now, and no crossing warning names them."""
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "indent.toml"), "--out", str(out), "--quiet",
                   "--set", f'interface.indent.discretisation="{DISC}"'])
    assert res.returncode == 0, res.stderr
    c = read_pairs(out / "step_0001.h5", 0, ("x", "p"))
    on = c["p"] > 0
    x, p = c["x"][on], c["p"][on]
    assert on.sum() == 6 and local_fit_deviation(x, p).max() < 0.04
    assert interior_deviation(np.column_stack([x, 0 * x]), p) < 0.02
    s = read_summary(out)["steps"][-1]["interfaces"]["indent"]
    assert s["max_pressure"] == pytest.approx(59.1, rel=0.03)
    assert s["normal_force"] == pytest.approx(20.1, rel=0.03)
    assert not [w for w in read_summary(out).get("warnings", []) if "'indent'" in w]
    assert read_summary(out)["contact_interfaces"]["indent"]["pairs_on"] == "block_top"
    assert max(kkt_violations(out, 1).values()) < 1e-7


def test_paired_sides_follow_the_pairs():
    from app.contact.unpaired import paired_sides

    mesh = stacked(4, 16, gap=0.01)
    rows = mortar_coarse_slave_constraints(mesh, itf(), 0)
    assert paired_sides(mesh, "up_bottom", "low_top", rows.pairs.slave) == ("low_top",
                                                                           "up_bottom")
    plain = mortar_constraints(mesh, itf(), 0)
    assert paired_sides(mesh, "up_bottom", "low_top", plain.pairs.slave) == ("up_bottom",
                                                                            "low_top")


def test_summary_names_the_curve_with_the_pairs(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "indent.toml"), "--out", str(out), "--quiet",
                   "--set", f'interface.indent.discretisation="{DISC}"',
                   "--set", "body.block.size=0.02"])  # the arc's size: no swap
    assert res.returncode == 0, res.stderr
    d = read_summary(out)["contact_interfaces"]["indent"]
    assert d["pairs_on"] == "cyl_arc" and d["discretisation"] == DISC


@pytest.mark.parametrize("n_low, n_up, builds", [(5, 7, 1), (4, 16, 2), (16, 4, 1)])
def test_the_ratio_comes_from_the_geometry_and_the_rows_are_built_once(n_low, n_up, builds,
                                                                        monkeypatch):
    """`size_ratio` is the ratio the rows' master-basis factory sees, and a keeping
    interface integrates its rows once (a swapping one twice: the configured rows for their
    checks, then the swapped ones)."""
    import app.contact.mortar as mortar
    from app.contact.mortar import slave_geometry
    from app.contact.mortar_coarse_slave import size_ratio

    mesh = stacked(n_low, n_up, gap=0.01)
    seen: list[float] = []
    mortar_constraints(mesh, itf(), 0, master_basis=size_ratio_probe(seen))
    assert size_ratio(slave_geometry(mesh, itf())) == seen[0]
    calls = []
    real = mortar._covered_weights
    monkeypatch.setattr(mortar, "_covered_weights",
                        lambda *a, **k: calls.append(1) or real(*a, **k))
    mortar_coarse_slave_constraints(mesh, itf(), 0)
    assert len(calls) == builds


def test_a_swapping_interface_still_refuses_the_configured_slaves_penetration():
    """A fine slave node pushed 0.05 into the coarse master midway between two of its nodes:
    the coarse nodes do not penetrate the fine curve, so the swapped rows alone accepted
    the overlap silently (g0 -0.005); mortar's check of the configured rows refuses it, as
    before the ratio came from the geometry."""
    from app.errors import InputError
    from app.mesh.model import Mesh

    mesh = stacked(4, 16, gap=0.01)
    pts = mesh.points.copy()
    j = np.flatnonzero((mesh.node_body() == 1) & np.isclose(pts[:, 1], 0.01)
                       & np.isclose(pts[:, 0], 0.125))
    assert j.size == 1
    pts[j, 1] = -0.05
    bumped = Mesh(pts, mesh.quads, mesh.body, mesh.body_names, mesh.curves)
    mortar_constraints(bumped, swapped(itf()), 0)  # the swapped rows see no penetration
    with pytest.raises(InputError, match="1 slave nodes penetrate the master"):
        mortar_coarse_slave_constraints(bumped, itf(), 0)
    rows = mortar_coarse_slave_constraints(bumped, itf(interference=True), 0)
    assert rows.n_pairs == 5  # an intended interference fit swaps as before
