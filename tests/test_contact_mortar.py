"""Contact discretisations: the registry, dual mortar rows, and mortar scenes end to end."""

from __future__ import annotations

import json
from types import SimpleNamespace

import h5py
import numpy as np
import pytest
from support import CONFIGS, kkt_violations, read_summary, run_cli
from test_contact_pairs import rotate, stacked

from app.config import parse_config
from app.contact.discretisation import (
    DEFAULT,
    DISCRETISATIONS,
    contact_discretisation,
    node_to_segment,
)
from app.contact.mortar import contact_normal, mortar_constraints, project_onto_segment
from app.contact.pairs import constraint_matrix, contact_pairs
from app.contact.smoothness import local_fit_deviation
from app.errors import InputError


def itf(slave="up_bottom", master="low_top", sd=0.1, **kw):
    return SimpleNamespace(name="t", slave=slave, master=master, search_distance=sd,
                           penetration_tol=kw.get("penetration_tol"),
                           interference=kw.get("interference", False))


def minimal(**interface) -> dict:
    return {"mesh": {"size": 1.0},
            "body": [{"name": "b", "E": 1.0, "nu": 0.3,
                      "shape": {"type": "rectangle", "origin": [0, 0], "width": 1, "height": 1}}],
            "interface": [{"slave": "s", "master": "m", "search_distance": 0.1, **interface}]}


# ---- registry and config ---------------------------------------------------------------

def test_registry_and_config_key():
    assert set(DISCRETISATIONS) == {"node-to-segment", "mortar", "mortar-bisector",
                                 "mortar-smooth", "mortar-standard", "mortar-coarse-slave"}
    unset = parse_config(minimal()).interfaces[0].discretisation
    assert contact_discretisation(unset, "x") is DISCRETISATIONS[DEFAULT]
    cfg = parse_config(minimal(discretisation="mortar"))
    assert cfg.interfaces[0].discretisation == "mortar"
    assert contact_discretisation("mortar", "x") is DISCRETISATIONS["mortar"]
    with pytest.raises(InputError, match="discretisation must be one of"):
        contact_discretisation(parse_config(minimal(discretisation="nts")).interfaces[0]
                               .discretisation, "interface 'x'")


def test_node_to_segment_entry_is_the_pair_code():
    mesh = stacked(5, 7)
    rows = node_to_segment(mesh, itf(), 0)
    pairs = contact_pairs(mesh, "up_bottom", "low_top", 0.1)
    g_old = constraint_matrix(pairs, mesh.n_nodes)
    assert (rows.matrix(mesh.n_nodes) != g_old).nnz == 0
    np.testing.assert_array_equal(rows.pairs.g0, pairs.g0)


# ---- mortar kernels ----------------------------------------------------------------------

def test_projection_along_interpolated_normals():
    x1, x2 = np.array([[0.0, 0.0]]), np.array([[1.0, 0.0]])
    n1, n2 = np.array([[-0.6, 0.8]]), np.array([[0.6, 0.8]])
    # the normal at s = 0.25 is (-0.3, 0.8): the point 0.25 + t (-0.3, 0.8)
    x = np.array([[0.25 - 0.3 * 0.5, 0.8 * 0.5]])
    assert project_onto_segment(x, x1, x2, n1, n2)[0] == pytest.approx(0.25, abs=1e-12)
    same = project_onto_segment(np.array([[0.4, 3.0]]), x1, x2, n1 * 0 + [0, 1], n2 * 0 + [0, 1])
    assert same[0] == pytest.approx(0.4)


def test_contact_normal_symmetric_and_flat_side_wins():
    up, tilt = np.array([[0.0, 1.0]]), np.array([[0.6, -0.8]])
    # slave flat (outward -y), master curved: the flat normal (0, 1) master -> slave
    n = contact_normal(-up, np.array([0.0]), -tilt, np.array([2.0]))
    np.testing.assert_allclose(n, [[0.0, 1.0]], atol=1e-15)
    # swapped roles: the same line, opposite direction (master -> slave)
    n2 = contact_normal(-tilt, np.array([2.0]), -up, np.array([0.0]))
    np.testing.assert_allclose(n2, -n, atol=1e-15)
    # equal curvatures: the mean
    n3 = contact_normal(-up, np.array([1.0]), -tilt, np.array([1.0]))
    np.testing.assert_allclose(n3[0], (up[0] - tilt[0]) / np.linalg.norm(up[0] - tilt[0]))


@pytest.mark.parametrize("nx", [(5, 7), (7, 5), (4, 4), (3, 11)])
def test_mortar_rows_reproduce_rigid_motions_and_flat_gaps(nx):
    mesh = stacked(*nx, gap=0.01)
    rows = mortar_constraints(mesh, itf(), 0)
    g = rows.matrix(mesh.n_nodes)
    m = rows.n_pairs
    assert m == nx[1] + 1
    np.testing.assert_allclose(rows.pairs.g0, 0.01, rtol=1e-12)
    np.testing.assert_allclose(rows.pairs.normal, [[0.0, 1.0]] * m, atol=1e-15)
    np.testing.assert_allclose(rows.pairs.length.sum(), 1.0)
    for vec in ([1.0, 0.0], [0.0, 1.0]):  # a rigid translation of both bodies: no motion
        u = np.tile(vec, mesh.n_nodes)
        np.testing.assert_allclose(g @ u, 0.0, atol=1e-14)
    nb = mesh.node_body()
    u = np.zeros((mesh.n_nodes, 2))
    u[nb == 1] = [0.3, -0.002]  # the upper block moves: opening -0.002, slip along t
    gu = g @ u.ravel()
    np.testing.assert_allclose(gu[:m], -0.002, atol=1e-14)
    np.testing.assert_allclose(gu[m:], rows.pairs.tangent[:, 0] * 0.3, atol=1e-14)


def test_mortar_rows_are_frame_independent():
    mesh = stacked(5, 7, gap=0.01)
    rmesh, r = rotate(mesh, 31.0)
    a = mortar_constraints(mesh, itf(), 0)
    b = mortar_constraints(rmesh, itf(), 0)
    np.testing.assert_allclose(b.pairs.g0, a.pairs.g0, atol=1e-13)
    np.testing.assert_allclose(b.pairs.normal, a.pairs.normal @ r.T, atol=1e-13)


def test_mortar_input_errors():
    with pytest.raises(InputError, match="penetrate"):
        mortar_constraints(stacked(5, 7, gap=-0.01), itf(), 0)
    rows = mortar_constraints(stacked(5, 7, gap=-0.01), itf(interference=True), 0)
    np.testing.assert_allclose(rows.pairs.g0, -0.01, rtol=1e-12)
    with pytest.raises(InputError, match="no slave node"):
        mortar_constraints(stacked(5, 7, gap=0.5), itf(), 0)


def test_local_fit_deviation():
    x = np.linspace(-1, 1, 21)
    assert local_fit_deviation(x, 3 - x**2).max() < 1e-12
    striped = 3 - x**2 + 0.3 * (np.arange(21) % 2)
    assert local_fit_deviation(x[::-1], striped[::-1]).max() > 0.03


# ---- scenes ------------------------------------------------------------------------------

def last_contact(out) -> dict:
    steps = sorted(out.glob("step_*.h5"))
    with h5py.File(steps[-1]) as f:
        return {k: f["contact"][k][()] for k in f["contact"]}


SWAP = {"patch": ("interface", "lower_top", "upper_bottom"),
        "hertz": ("contact", "block_top", "cyl_arc"),
        "cattaneo": ("contact", "block_top", "cyl_arc")}


def mortar_run(tmp_path, config: str, swapped: bool, *extra: str):
    name = SWAP[config][0]
    args = ["run", str(CONFIGS / f"{config}.toml"), "--out", str(tmp_path / "o"), "--quiet",
            "--set", f'interface.{name}.discretisation="mortar"', *extra]
    if swapped:
        args += ["--set", f'interface.{name}.slave="{SWAP[config][1]}"',
                 "--set", f'interface.{name}.master="{SWAP[config][2]}"']
    return run_cli(args)


@pytest.mark.parametrize("swapped", [False, True])
def test_mortar_patch_test(tmp_path, swapped):
    res = mortar_run(tmp_path, "patch", swapped)
    assert res.returncode == 0, res.stderr
    c = last_contact(tmp_path / "o")
    assert np.abs(c["p"] - 10.0).max() / 10.0 < 1e-8
    assert c["p"].size >= 9
    v = kkt_violations(tmp_path / "o", 1)
    assert max(v.values()) < 1e-7, v


@pytest.mark.parametrize("swapped", [False, True])
def test_mortar_frictionless_never_holds_a_tangential_load(tmp_path, swapped):
    res = mortar_run(tmp_path, "cattaneo", swapped, "--set", "interface.contact.mu=0.0")
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr
    assert "no static equilibrium at step 6" in res.stderr
    s = read_summary(tmp_path / "o")
    assert len(s["steps"]) == 5 and s["failed_step"] == 6
    assert len(list((tmp_path / "o").glob("step_*.h5"))) == 5


def test_mortar_multibody_indent_smooth_on_non_matching_meshes(tmp_path):
    """The fine arc (0.018) on block2 meshed at 0.02: node-to-segment stripes (12% off a
    local fit, README), mortar is smooth. (With the default block2 mesh, 4x coarser than
    the arc, both follow the coarse master's segments: see the README.)"""
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "multibody.toml"), "--out", str(out), "--quiet",
                   "--set", 'interface.indent.discretisation="mortar"',
                   "--set", "body.block2.size=0.02"])
    assert res.returncode == 0, res.stderr
    c = last_contact(out)
    on = (c["interface"] == 2) & (c["p"] > 0)
    assert on.sum() >= 15
    assert local_fit_deviation(c["x"][on], c["p"][on]).max() < 0.03
    warnings = json.loads((out / "summary.json").read_text()).get("warnings", [])
    assert not [w for w in warnings if "'indent'" in w]  # no stripes: no stripe warning
    for step in range(1, 5):
        v = kkt_violations(out, step)
        assert max(v.values()) < 1e-6, (step, v)


@pytest.mark.slow
def test_mortar_hertz_swap(tmp_path):
    """At a/40 (README table: 0.89% and 0.94%; at a/10 the two meshes put their last
    contact node at different places: 2.1% and 3.2%)."""
    errs = []
    for swapped in (False, True):
        res = mortar_run(tmp_path / str(swapped), "hertz", swapped, "--mesh-size", "0.125")
        assert res.returncode == 0, res.stderr
        s = json.loads((tmp_path / str(swapped) / "o" / "summary.json").read_text())
        errs.append(s["reference"]["hertz"]["pressure_l2_interp_rel_error"])
    assert abs(errs[0] - errs[1]) <= 0.005, errs


def test_split_modes_separates_what_no_pair_sees():
    from app.interface.floating import split_modes, undetermined_modes

    n_modes = np.array([[1.0, 0.0, 1.0], [2.0, 0.0, 2.0]])  # mode 1 moves nothing; 0 = 2
    t_modes = np.zeros((0, 3))
    keep, null = split_modes(n_modes, t_modes)
    assert keep.shape == (3, 1) and null.shape == (3, 2)
    np.testing.assert_allclose(n_modes @ null, 0.0, atol=1e-14)
    np.testing.assert_allclose(keep.T @ null, 0.0, atol=1e-14)
    assert len(undetermined_modes(n_modes, t_modes, ["a", "b", "c"])) == 2
    keep, null = split_modes(np.eye(3), t_modes)
    assert keep.shape == (3, 3) and null.shape == (3, 0)
