"""Reactions per support, the balance per body, interface force vectors, loads on
prescribed DOFs, provenance and progress lines."""

from __future__ import annotations

import datetime

import numpy as np
import pytest
from support import CONFIGS, read_summary, run_cli

from app.assembly.loads import unique_names
from app.output.reactions import (
    body_balance,
    interface_resultants,
    support_owner,
    support_reactions,
)

CANTILEVER = (CONFIGS / "cantilever.toml").read_text()


def test_support_reactions_forces_and_moments():
    pts = np.array([[0.0, 0.0], [0.0, 2.0], [3.0, 0.0]])
    # support 0 holds node 0 (x, y) and node 1 (x); support 1 holds node 1 (x again), 2 (y)
    owner = support_owner([np.array([0, 1, 2]), np.array([2, 5])], 6)
    assert owner.tolist() == [0, 0, 0, -1, -1, 1]  # a shared DOF counts for the first
    r = np.array([1.0, 2.0, -3.0, 0.0, 0.0, 4.0])
    out = support_reactions(["a", "b"], owner, r, pts)
    assert out["a"]["Fx"] == -2.0 and out["a"]["Fy"] == 2.0
    assert out["a"]["Mz"] == pytest.approx(-(2.0 * -3.0))  # x Fy - y Fx about the origin
    assert out["a"]["centroid"] == [0.0, 1.0]
    assert out["a"]["Mz_centroid"] == pytest.approx(-(-1.0 * 1.0) - (1.0 * -3.0))
    assert out["b"] == {"Fx": 0.0, "Fy": 4.0, "Mz": 12.0, "Mz_centroid": 0.0,
                        "centroid": [3.0, 0.0]}


def test_body_balance_flags_a_missing_force():
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [5.0, 5.0]])
    nb = np.array([0, 0, 1])
    loads = np.array([0.0, -1.0, 0.0, -1.0, 0.0, 0.0])
    reactions = np.array([0.0, 1.0, 0.0, 1.0, 0.0, 0.0])
    ok = body_balance(pts, nb, ["a", "b"], {"loads": loads, "reactions": reactions})
    assert ok["max_relative_residual"] == 0.0
    assert ok["bodies"]["a"]["loads"] == [0.0, -2.0, -1.0]
    bad = body_balance(pts, nb, ["a", "b"], {"loads": loads, "reactions": 0.5 * reactions})
    assert bad["max_relative_residual"] == pytest.approx(1 / 3)
    assert bad["bodies"]["a"]["residual"][1] == -1.0
    # forces that are all round-off are judged against the run's earlier force scale
    noise = {"loads": 1e-14 * loads, "reactions": -0.5e-14 * reactions}
    assert body_balance(pts, nb, ["a", "b"], noise)["max_relative_residual"] > 0.1
    assert body_balance(pts, nb, ["a", "b"], noise, floor=2.0)["max_relative_residual"] < 1e-13


def test_interface_resultants_are_vectors_in_global_axes():
    c = {"p_force": np.array([1.0, 2.0, 5.0]), "q_force": np.array([0.5, 0.0, 0.0]),
         "normal": np.array([[0.0, 1.0], [0.0, 1.0], [1.0, 0.0]]),
         "tangent": np.array([[1.0, 0.0], [1.0, 0.0], [0.0, -1.0]]),
         "interface": np.array([0, 0, 1])}
    out = interface_resultants(c, ["top", "side"])
    assert out == {"top": {"force": [0.5, 3.0]}, "side": {"force": [5.0, 0.0]}}


def test_unique_names():
    assert unique_names(["a", "b", "a", "a"]) == ["a", "b", "a#2", "a#3"]


def test_cantilever_clamp_reaction_balances_the_tip_load(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "cantilever.toml"), "--out", str(out), "--mesh-size",
                   "0.25"])
    assert res.returncode == 0, res.stderr
    st = read_summary(out)["steps"][0]
    clamp = st["reactions"]["support:clamp"]
    # tip load: -P = -1 in y at x = L = 10; the clamp (x = 0) holds it
    assert clamp["Fy"] == pytest.approx(1.0, rel=1e-9)
    assert abs(clamp["Fx"]) < 1e-9
    assert clamp["Mz"] == pytest.approx(10.0, rel=1e-9)
    assert clamp["Mz_centroid"] == pytest.approx(10.0, rel=1e-9)  # centroid (0, 0)
    assert st["balance"]["max_relative_residual"] < 1e-10
    assert st["balance"]["bodies"]["beam"]["loads"][1] == pytest.approx(-1.0)
    # progress: one line per step and one closing line
    assert "step 1/1; energy" in res.stderr and "balance" in res.stderr
    assert "completed, 1/1 steps" in res.stderr.splitlines()[-1]
    assert "tip_deflection" in res.stderr.splitlines()[-1]


def test_patch_reactions_and_interface_force(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet"])
    assert res.returncode == 0, res.stderr
    st = read_summary(out)["steps"][0]
    # pressure 10 on a top edge of width 2: 20 down, carried by the base
    assert st["reactions"]["support:lower_base"]["Fy"] == pytest.approx(20.0, rel=1e-9)
    assert st["interfaces"]["interface"]["force"] == pytest.approx([0.0, 20.0], abs=1e-9)
    bodies = st["balance"]["bodies"]
    assert bodies["upper"]["contact"][1] == pytest.approx(20.0)
    assert bodies["lower"]["contact"][1] == pytest.approx(-20.0)
    assert st["balance"]["max_relative_residual"] < 1e-10


def test_a_load_on_prescribed_dofs_is_reported(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text(CANTILEVER.replace("[points]", '[[load]]\non = "clamp"\n'
                                      'traction = [2.0, 0.0]\n\n[points]'))
    out = tmp_path / "o"
    res = run_cli(["run", str(cfg), "--out", str(out), "--mesh-size", "0.5", "--quiet"])
    assert res.returncode == 0, res.stderr
    assert "warning: load:clamp:" in res.stderr and "prescribed DOFs" in res.stderr
    s = read_summary(out)
    assert any("load:clamp" in w for w in s["warnings"])
    st = s["steps"][0]
    # the supports take it: the clamp's Fx is minus the load (2 x height 1)
    assert st["reactions"]["support:clamp"]["Fx"] == pytest.approx(-2.0, rel=1e-9)
    assert st["balance"]["max_relative_residual"] < 1e-10


def test_two_supports_on_one_curve_have_one_load_factor_each(tmp_path):
    """(At --mesh-size 0.25: at 0.5 the clamp's nodes sit at y = -0.5, 0, 0.5, where its ux
    is 0, and a support prescribing only zeros has no load case; it had one while the node
    at y = 0 read y = 1e-17, before coordinates within round-off of 0 were taken as 0.)"""
    text = CANTILEVER.replace('uy = "-P/(6', '\n[[support]]\non = "clamp"\nuy = "-P/(6')
    cfg = tmp_path / "c.toml"
    cfg.write_text(text)
    out = tmp_path / "o"
    res = run_cli(["run", str(cfg), "--out", str(out), "--mesh-size", "0.25", "--quiet"])
    assert res.returncode == 0, res.stderr
    st = read_summary(out)["steps"][0]
    assert set(st["load_factor"]) == {"load:tip_edge", "support:clamp", "support:clamp#2"}
    assert set(st["reactions"]) == {"support:clamp", "support:clamp#2"}
    assert st["reactions"]["support:clamp#2"]["Fy"] == pytest.approx(1.0, rel=1e-9)


def test_provenance(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                   "--set", "load.0.pressure=12.5", "-ksp_type", "preonly"])
    assert res.returncode == 0, res.stderr
    p = read_summary(out)["provenance"]
    assert p["overrides"] == ["load.0.pressure=12.5"]
    assert p["config_resolved"]["load"][0]["pressure"] == 12.5
    assert p["petsc_options"]["ksp_type"] == "preonly"
    assert p["petsc_options"]["pc_factor_mat_solver_type"] == "mumps"
    assert p["ranks"] == 1
    start = datetime.datetime.fromisoformat(p["start_time"])
    assert abs((datetime.datetime.now(datetime.UTC) - start).total_seconds()) < 600
    git = p["version"]["git"]
    assert git is None or len(git["commit"]) == 40


def test_reactions_on_two_ranks_match_one_rank(tmp_path):
    runs = {}
    for ranks in (1, 2):
        out = tmp_path / f"o{ranks}"
        res = run_cli(["run", str(CONFIGS / "multibody.toml"), "--out", str(out), "--quiet"],
                      ranks=ranks)
        assert res.returncode == 0, res.stderr
        runs[ranks] = read_summary(out)["steps"]
    for s1, s2 in zip(runs[1], runs[2], strict=True):
        assert s2["balance"]["max_relative_residual"] < 1e-10
        for name, r in s1["reactions"].items():
            for key in ("Fx", "Fy", "Mz"):
                assert s2["reactions"][name][key] == pytest.approx(r[key], rel=1e-7, abs=1e-9)


DISK = """[analysis]
plane = "strain"
[mesh]
size = 0.3
[points]
c = [0.0, 0.0]
e = [1.0, 0.0]
[[body]]
name = "d"
E = 1000.0
nu = 0.3
[body.shape]
type = "disk"
center = [0.0, 0.0]
radius = 1.0
[body.curves]
arc = "rim"
[[support]]
on = "c"
ux = 0.0
uy = 0.0
[[support]]
on = "e"
uy = 0.0
[[load]]
on = "rim"
pressure = 5.0
"""


def test_a_pressure_normal_to_a_prescribed_dof_is_not_reported(tmp_path):
    """The rim pressure at e = (1, 0) pushes along x; its y force there is 2e-10 (3e-10 of
    the largest nodal force), which warned `load:rim: 1 of its nodal forces act on
    prescribed DOFs (sum 9.045e-10)`."""
    cfg = tmp_path / "d.toml"
    cfg.write_text(DISK)
    res = run_cli(["run", str(cfg), "--out", str(tmp_path / "o"), "--quiet"])
    assert res.returncode == 0, res.stderr
    assert "prescribed DOFs" not in res.stderr
    assert "warnings" not in read_summary(tmp_path / "o")


def test_interface_resultants_of_a_swapped_interface_are_the_configured_slaves():
    c = {"p_force": np.array([1.0, 2.0]), "q_force": np.array([0.5, 0.0]),
         "normal": np.array([[0.0, 1.0], [0.0, 1.0]]),
         "tangent": np.array([[1.0, 0.0], [1.0, 0.0]]), "interface": np.array([0, 1])}
    out = interface_resultants(c, ["a", "b"], swapped={"b"})
    assert out == {"a": {"force": [0.5, 1.0]}, "b": {"force": [-0.0, -2.0]}}


def test_a_load_on_a_point_group_names_what_to_do_instead():
    """Before: `load on 'tip': unknown curve 'tip' (mesh curves: [...])`, though [points]
    named 'tip': a point load is not a load kind, and the message did not say so."""
    import numpy as np
    import pytest

    from app.assembly.loads import load_vector
    from app.config import Load
    from app.errors import InputError
    from app.mesh.model import Mesh

    mesh = Mesh(points=np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
                quads=np.array([[0, 1, 2, 3]]), body=np.array([0]), body_names=["b"],
                curves={"top": np.array([[2, 3]])}, point_groups={"tip": np.array([2])})
    load = Load(on="tip", kind="total_force", value=[0.0, -5.0], history=None)
    with pytest.raises(InputError, match="'tip' is a point group, and a \\[\\[load\\]\\] "
                                         "acts on a curve .*name a curve \\(\\['top'\\]\\)"):
        load_vector(mesh, None, load)


def test_an_unknown_groups_line_lists_a_dozen_names_of_many():
    """Before: every curve's name; 5000 bodies' 10,000 curves made a 111 kB error line."""
    from types import SimpleNamespace

    from app.assembly.loads import group_nodes
    from app.errors import InputError

    mesh = SimpleNamespace(curves={f"c{k:05d}": [0] for k in range(10_000)},
                           point_groups={"p": [0]})
    with pytest.raises(InputError) as got:
        group_nodes(mesh, "nope", "support on 'nope'")
    assert str(got.value) == ("support on 'nope': unknown group 'nope' (curves: ['c00000', "
                              "'c00001', 'c00002', 'c00003', 'c00004', 'c00005', 'c00006', "
                              "'c00007', 'c00008', 'c00009', ... (10000 in all), 'c09999'], "
                              "points: ['p'])")


@pytest.mark.parametrize("key, line", [
    ("support.0.on", "support on 'nope': unknown group 'nope' (curves: ['lower_base', "
                     "'lower_sides', 'lower_top', 'upper_bottom', 'upper_sides', 'upper_top'],"
                     " points: [])"),
    ("load.0.on", "load on 'nope': unknown curve 'nope' (mesh curves: ['lower_base', "
                  "'lower_sides', 'lower_top', 'upper_bottom', 'upper_sides', 'upper_top'])"),
])
def test_an_unknown_group_is_found_before_meshing(tmp_path, key, line):
    """Before: after meshing and set-up (1000 bodies: 7.3 s, now 3.0 s), the same line;
    now with the command line's checks (summary.json of bad input: n_steps null)."""
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--set", f'{key}="nope"', "--out",
                   str(out), "--quiet"], timeout=120)
    assert res.returncode == 2
    assert res.stderr.strip() == f"error: {line}"
    summary = read_summary(out)
    assert summary["error"] == line and summary["n_steps"] is None
    assert "timings" not in summary or "mesh" not in summary["timings"]
