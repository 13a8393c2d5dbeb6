"""Mortar with standard multipliers (app/contact/mortar_standard.py): its slave integrals,
its rows, the patch test both ways and the contact-edge oscillation that keeps it opt-in."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
from support import CONFIGS, run_cli
from test_contact_mortar_smooth import closed_profile, dense
from test_contact_pairs import rotate, stacked
from test_contact_scenes import assert_law_holds

from app.contact.discretisation import DISCRETISATIONS
from app.contact.mortar import DUAL, linear_master, mortar_constraints, segment_integrals
from app.contact.mortar_standard import STANDARD, mortar_standard_constraints
from app.contact.smoothness import local_fit_deviation


def itf(slave="up_bottom", master="low_top", sd=0.1):
    return SimpleNamespace(name="t", slave=slave, master=master, search_distance=sd,
                           penetration_tol=None, interference=False)


def one_segment(multipliers, x_master=(0.0, 1.0)):
    """Integrals of the slave segment [0, 1] x {0} against one master segment below it."""
    xs1, xs2 = np.array([[0.0, 0.0]]), np.array([[1.0, 0.0]])
    n = np.array([[0.0, 1.0]])
    xa, xb = np.array([[x_master[0], -0.1]]), np.array([[x_master[1], -0.1]])
    basis = linear_master(None, np.array([[0, 1]]), None, None)
    zero = np.array([0])
    return segment_integrals(xs1, xs2, n, n, xa, xb, zero, zero, basis, multipliers)


def test_slave_integrals_are_the_mass_matrix_and_the_dual_ones_are_biorthogonal():
    *_, (_, standard) = one_segment(STANDARD)
    np.testing.assert_allclose(standard[0], np.array([[2.0, 1.0], [1.0, 2.0]]) / 6, atol=1e-15)
    *_, (_, dual) = one_segment(DUAL)
    np.testing.assert_allclose(dual[0], 0.5 * np.eye(2), atol=1e-15)
    # a half-covered segment: the slave integrals cover the same piece as the master ones
    _, _, _, val, (_, half) = one_segment(STANDARD, x_master=(0.0, 0.5))
    np.testing.assert_allclose(half[0].sum(axis=1), val.reshape(2, 2).sum(axis=1), atol=1e-15)
    np.testing.assert_allclose(half[0].sum(), 0.5, atol=1e-15)


@pytest.mark.parametrize("deg", [0.0, 23.0])
def test_rows_couple_slave_neighbours_and_hold_rigid_motions(deg):
    """Non-matching blocks (5 below, 7 above): each standard row reaches the slave node's
    neighbours, the rows sum to one, and rigid motions open and slip nothing."""
    mesh, _ = rotate(stacked(5, 7), deg)
    rows = mortar_standard_constraints(mesh, itf(), 0)
    g = dense(rows, mesh.n_nodes)
    plain = dense(mortar_constraints(mesh, itf(), 0), mesh.n_nodes)
    m = rows.n_pairs
    up = mesh.node_body() == 1

    def slave_nodes_per_row(a: np.ndarray) -> np.ndarray:
        return np.count_nonzero(np.abs(a[:m].reshape(m, -1, 2)).sum(axis=2)[:, up], axis=1)

    touched = slave_nodes_per_row(g)
    assert touched.min() == 2 and touched.max() == 3  # ends: one neighbour, else two
    assert (slave_nodes_per_row(plain) == 1).all()  # dual: the node itself
    c = np.radians(deg)
    for u in (np.tile([np.cos(c), np.sin(c)], mesh.n_nodes),
              np.column_stack([-mesh.points[:, 1], mesh.points[:, 0]]).ravel()):
        np.testing.assert_allclose(g @ u, 0.0, atol=1e-12)
    np.testing.assert_allclose(rows.pairs.g0, 0.0, atol=1e-12)
    assert DISCRETISATIONS["mortar-standard"] is mortar_standard_constraints


def standard_run(tmp_path, config: str, *args: str):
    out = tmp_path / config
    itf_name = {"patch": "interface", "hertz": "contact"}[config]
    res = run_cli(["run", str(CONFIGS / f"{config}.toml"), "--out", str(out), "--quiet",
                   "--set", f'interface.{itf_name}.discretisation="mortar-standard"', *args])
    assert res.returncode == 0, res.stderr
    return out


@pytest.mark.parametrize("swapped", [False, True])
def test_patch_test_passes_with_either_block_as_slave(tmp_path, swapped):
    sides = ["--set", "interface.interface.slave=lower_top",
             "--set", "interface.interface.master=upper_bottom"] if swapped else []
    out = standard_run(tmp_path, "patch", *sides)
    _, p = closed_profile(out, 1, 0)
    assert p.size >= 5
    assert np.abs(p - 10.0).max() / 10.0 < 1e-8
    assert_law_holds(out, 1)


def test_hertz_and_a_fine_indent_are_worse_than_with_dual_multipliers(tmp_path):
    """Why it is opt-in (README "Contact discretisations"): Hertz a/40 L2(p) 1.10%
    against the dual rows' 0.89%, and multibody `indent` on a block2 meshed at the arc's
    size 11.8% of max p off a local fit inside the zone (dual: 0.9%). The law holds."""
    std = standard_run(tmp_path, "hertz", "--mesh-size", "0.125")
    dual = tmp_path / "dual"
    res = run_cli(["run", str(CONFIGS / "hertz.toml"), "--out", str(dual), "--quiet",
                   "--mesh-size", "0.125"])
    assert res.returncode == 0, res.stderr
    err = {name: json.loads((out / "summary.json").read_text())["reference"]["hertz"]
           ["pressure_l2_interp_rel_error"] for name, out in (("std", std), ("dual", dual))}
    assert err["std"] > err["dual"] + 0.001, err
    assert_law_holds(std, 1)
    out = tmp_path / "indent"
    res = run_cli(["run", str(CONFIGS / "multibody.toml"), "--out", str(out), "--quiet",
                   "--set", 'interface.indent.discretisation="mortar-standard"',
                   "--set", "body.block2.size=0.02"])
    assert res.returncode == 0, res.stderr
    n_steps = json.loads((out / "summary.json").read_text())["n_steps"]
    x, p = closed_profile(out, n_steps, 2)
    assert x.size >= 15
    assert local_fit_deviation(x, p).max() > 0.05
    assert_law_holds(out, n_steps)
