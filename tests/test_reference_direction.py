"""Hertz and Cattaneo measure p and q along the contact's own direction: the same scene
turned by 30 and 90 deg, or mirrored and turned by 90 (scripts/check_invariance.py's
machinery, [reference] kept with its centre moved) gives the reference errors of the
unturned one. Before, a turn of 30
deg read p along x (half-width error 0.50 against 0.42) and one of 90 was refused."""

from __future__ import annotations

import copy
import json
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
from check_invariance import Transform, toml_dumps, transformed_config, write_msh  # noqa: E402

from app.mesh.build import build_mesh  # noqa: E402
from app.scene.parse import parse_scene  # noqa: E402

KEYS = {"hertz": ("p_max_rel_error", "half_width_rel_error", "pressure_l2_rel_error",
                  "pressure_l2_interp_rel_error"),
        "cattaneo": ("stick_half_width_rel_error", "traction_l2_rel_error",
                     "traction_l2_interp_rel_error", "Q_over_muP")}


def _scene(name: str) -> dict:
    """The shipped scene held by displacements on cyl_top (a one-component roller cannot
    be turned by 30 deg): hertz pressed by uy, cattaneo pressed and then pulled by ux."""
    raw = tomllib.loads((ROOT / "configs" / f"{name}.toml").read_text())
    raw["support"] = [s for s in raw["support"] if s["on"] != "cyl_top"]
    raw.pop("load", None)
    top = {"on": "cyl_top", "ux": 0.0, "uy": -0.0188}
    if name == "cattaneo":
        top = {"on": "cyl_top", "ux": 0.0004, "uy": -0.0188}
    raw["support"].append(top)
    raw["analysis"]["steps"] = 2
    return raw


def _run(raw: dict, mesh, angle: float, folder: Path, mirror: bool = False) -> dict:
    tf = Transform(",".join(([f"angle={angle:g}"] if angle else [])
                            + (["mirror=1"] if mirror else [])))
    cfg = transformed_config(raw, tf)
    cfg["reference"] = copy.deepcopy(raw["reference"])
    if angle or mirror:  # the centre (center_x, 0) moved: only its part along t counts
        c = tf.point([raw["reference"].get("center_x", 0.0), 0.0])
        cfg["reference"] |= {"center_x": float(c[0]), "center_y": float(c[1])}
    folder.mkdir(parents=True, exist_ok=True)
    write_msh(mesh, tf, folder / "mesh.msh")
    (folder / "scene.toml").write_text(toml_dumps(cfg) + "\n")
    r = subprocess.run([sys.executable, "-m", "app", "run", str(folder / "scene.toml"),
                        "--out", str(folder / "out"), "--quiet"], cwd=ROOT,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    return json.loads((folder / "out" / "summary.json").read_text())["reference"]


def _plots_along_the_contact(tmp_path: Path, refs: dict) -> None:
    """scripts/plot_results.py draws the turned runs' p against center_x + s along the
    contact, the unturned run's x (before: x or y, and the closed form off the contact)."""
    import h5py
    from plot_results import contact_coordinate

    coords = {}
    for a, ref in refs.items():
        out = tmp_path / f"a{a:g}" / "out"
        last = max(out.glob("step_*.h5"))
        with h5py.File(last) as f:
            c = {k: f["contact"][k][()] for k in f["contact"]}
        coord, label = contact_coordinate(c, c["interface"] == 0, ref, "contact")
        assert label == ("x" if a == 0 else "center_x + distance along the contact")
        coords[a] = np.sort(coord)
    for a in (30.0, 90.0):
        np.testing.assert_allclose(coords[a], coords[0.0], atol=1e-12 * np.ptp(coords[0.0]))


@pytest.mark.parametrize("name", ["hertz", "cattaneo"])
def test_turned_scene_reads_the_unturned_reference_errors(tmp_path: Path, name: str) -> None:
    raw = _scene(name)
    mesh = build_mesh(parse_scene(raw), 2.0, base_dir=ROOT / "configs")
    refs = {a: _run(raw, mesh, a, tmp_path / f"a{a:g}") for a in (0.0, 30.0, 90.0)}
    _plots_along_the_contact(tmp_path, refs)
    refs["mirror"] = _run(raw, mesh, 90.0, tmp_path / "mirror", mirror=True)
    for part in ("hertz",) + (("cattaneo",) if name == "cattaneo" else ()):
        base = np.array([refs[0.0][part][k] for k in KEYS[part]])
        assert np.all(np.isfinite(base)) and np.all(base > 0), base
        for a in (30.0, 90.0, "mirror"):
            got = np.array([refs[a][part][k] for k in KEYS[part]])
            np.testing.assert_allclose(got, base, rtol=1e-9, err_msg=f"{name} {part} {a}")


def _profile(angle: float, bend: float = 0.0, **kw):
    """A Hertz-like contact along x of 41 pairs, turned by `angle` deg about the origin;
    bend: the pairs' tangents turn linearly by +-bend deg along it (a curved contact)."""
    from app.references import ContactProfile

    x = np.linspace(-0.2, 0.2, 41)
    p = 5000.0 * np.sqrt(np.clip(1 - (x / 0.1) ** 2, 0, None))
    q = 0.1 * p
    th = np.radians(angle + bend * x / 0.2)
    tangent = -np.column_stack((np.cos(th), np.sin(th)))  # the master below: -x
    c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))
    X = np.column_stack((x, np.full_like(x, 0.3))) @ np.array([[c, s], [-s, c]])
    length = np.full_like(x, 0.01)
    return ContactProfile(x=X[:, 0], y=X[:, 1], p=p, q=q, length=length,
                          p_force=p * length, q_force=q * length, stick=np.abs(x) < 0.05,
                          mu=0.2, E_star=1.1e5, interface="contact", tangent=tangent, **kw)


@pytest.mark.parametrize("name", ["hertz", "cattaneo", "mindlin"])
def test_a_turned_profile_reads_the_unturned_errors(name: str) -> None:
    from app.references import REFERENCES, RunFigures

    def errors(angle: float) -> dict:
        c = np.array([0.0, 0.3]) @ np.array([[np.cos(np.radians(angle)),
                                              np.sin(np.radians(angle))],
                                             [-np.sin(np.radians(angle)),
                                              np.cos(np.radians(angle))]])
        table = {"type": name, "radius": 1.0, "center_x": float(c[0])}
        if angle:
            table["center_y"] = float(c[1])
        steps = [{"interfaces": {"contact": {"tangential_force": 5.0, "normal_force": 60.0,
                                             "dissipation": 0.0}}}]
        run = RunFigures(E=2e5, nu=0.3, plane="strain", thickness=1.0, strain_energy=1.0,
                         point_values={}, contact=_profile(angle), steps=steps)
        return REFERENCES[name].compare(table, run)

    base = errors(0.0)
    for angle in (30.0, 90.0, 150.0):
        got = errors(angle)
        for part in ("hertz", "cattaneo", "mindlin"):
            for k, v in base.get(part, {}).items():
                if k.endswith("rel_error") and np.isfinite(v):
                    assert got[part][k] == pytest.approx(v, rel=1e-10), (angle, part, k)


def test_a_contact_that_is_not_straight_is_refused() -> None:
    from app.errors import InputError
    from app.references import REFERENCES, RunFigures

    run = RunFigures(E=2e5, nu=0.3, plane="strain", thickness=1.0, strain_energy=1.0,
                     point_values={}, contact=_profile(0.0, bend=40.0))  # +-18 deg loaded
    with pytest.raises(InputError, match="not near-straight"):
        REFERENCES["hertz"].compare({"type": "hertz", "radius": 1.0}, run)
    # a Hertz contact on a cylinder, +-0.9 deg and +-7.2 deg loaded (a/R = 0.125 on a
    # curved master): measured
    for bend in (2.0, 16.0):
        run.contact = _profile(0.0, bend=bend)
        assert np.isfinite(REFERENCES["hertz"].compare(
            {"type": "hertz", "radius": 1.0}, run)["hertz"]["p_max_rel_error"])


def test_a_hertz_contact_on_a_curved_master_is_measured(tmp_path: Path) -> None:
    """hertz.toml swapped (the arc the master) with node-to-segment, whose pairs carry the
    master's tangents, at P = 1000 (a/R = 0.108): the loaded pairs' tangents turn by 6.2
    deg, the arc's own at the contact edge. Before, refused above 5.7 deg (asin 0.1, the
    shipped a/R): `error: ... not near-straight`, exit 2; before session 30 measured."""
    r = subprocess.run(
        [sys.executable, "-m", "app", "run", "configs/hertz.toml", "--quiet",
         "--set", 'interface.0.slave="block_top"', "--set", 'interface.0.master="cyl_arc"',
         "--set", 'interface.0.discretisation="node-to-segment"',
         "--set", "load.0.total_force=[0.0,-1000.0]", "--out", str(tmp_path / "out")],
        cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    h = json.loads((tmp_path / "out" / "summary.json").read_text())["reference"]["hertz"]
    assert h["half_width_rel_error"] < 0.1 and h["pressure_l2_rel_error"] < 0.2


def test_a_contact_along_y_needs_center_y() -> None:
    from app.errors import InputError
    from app.references import REFERENCES, RunFigures

    run = RunFigures(E=2e5, nu=0.3, plane="strain", thickness=1.0, strain_energy=1.0,
                     point_values={}, contact=_profile(90.0))
    with pytest.raises(InputError, match="center_y"):
        REFERENCES["hertz"].compare({"type": "hertz", "radius": 1.0}, run)


def test_the_study_compares_p_along_the_contact() -> None:
    """Two runs' p turned by 30 deg: the study's ref_pressure_l2 is the unturned one
    (before, p was interpolated along x, the turned positions' x)."""
    from app.references.hertz import line_direction
    from app.studies.reference_errors import add_reference_errors

    def profiles(angle: float) -> dict:
        out = {}
        for level, shift in ((1, 0.003), (2, 0.0)):
            c = _profile(angle)
            c.p = 5000.0 * np.sqrt(np.clip(1 - ((np.linspace(-0.2, 0.2, 41) + shift) / 0.1)
                                           ** 2, 0, None))
            t, turn = line_direction(c.tangent, c.length, c.p)
            out[(level, "4SD")] = {"energy": 1.0, "n_dofs": 10 * level, "points": {},
                                   "X": np.column_stack((c.x, c.y)), "x": c.x, "p": c.p,
                                   "q": c.q, "p_max": float(c.p.max()), "t": t,
                                   "turn": turn}
        return out

    got = {}
    for angle in (0.0, 30.0):
        rows = [{"level": lv, "method": "4SD", "n_dofs": 10 * lv, "t_total": 0.0}
                for lv in (1, 2)]
        add_reference_errors(rows, profiles(angle), "4SD")
        got[angle] = rows[0]["ref_pressure_l2"]
    assert got[0.0] > 0.01
    assert got[30.0] == pytest.approx(got[0.0], rel=1e-10)


def test_edges_read_along_x_whichever_side_the_master_is() -> None:
    """Pair tangents along -x (master below) or +x (master above): the same contact
    edges in x (the closed forms are even in s; t points towards +x either way)."""
    from app.references import REFERENCES, RunFigures

    edges = []
    for sign in (1.0, -1.0):
        c = _profile(0.0)
        c.tangent = sign * c.tangent
        c.p = c.p * (c.x > -0.05)  # an uneven contact: its edges tell a mirrored s
        run = RunFigures(E=2e5, nu=0.3, plane="strain", thickness=1.0, strain_energy=1.0,
                         point_values={}, contact=c)
        edges.append(REFERENCES["hertz"].compare({"type": "hertz", "radius": 1.0,
                                                  "center_x": 0.01}, run)
                     ["hertz"]["contact_edges"])
    assert edges[0] == edges[1]
    assert edges[0][0] == pytest.approx(-0.045) and edges[0][1] == pytest.approx(0.105)


def test_an_unloaded_contact_on_a_curved_master_reads_no_errors(tmp_path: Path) -> None:
    """hertz.toml swapped (the arc the master, node-to-segment: the pairs carry its
    tangents) held where it touches, no load: no pair loaded, NaN errors, completed as
    before session 30. Before, every pair's tangent was judged: the arc's within the
    search distance turn by 17 deg, and the run failed `... not near-straight where it is
    loaded`."""
    r = subprocess.run(
        [sys.executable, "-m", "app", "run", "configs/hertz.toml", "--quiet",
         "--set", 'interface.0.slave="block_top"', "--set", 'interface.0.master="cyl_arc"',
         "--set", 'interface.0.discretisation="node-to-segment"', "--set", "support.1.uy=0.0",
         "--set", "load.0.total_force=[0.0,0.0]", "--out", str(tmp_path / "out")],
        cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    h = json.loads((tmp_path / "out" / "summary.json").read_text())["reference"]["hertz"]
    assert h["P"] == 0.0 and np.isnan(h["p_max_rel_error"])
    # the same along a bent profile without load: measured (NaN), not refused
    from app.references import REFERENCES, RunFigures

    c = _profile(0.0, bend=60.0)
    c.p, c.p_force = 0.0 * c.p, 0.0 * c.p_force
    run = RunFigures(E=2e5, nu=0.3, plane="strain", thickness=1.0, strain_energy=1.0,
                     point_values={}, contact=c)
    assert np.isnan(REFERENCES["hertz"].compare({"type": "hertz", "radius": 1.0},
                                                run)["hertz"]["p_max_rel_error"])


def test_an_untilted_contact_whose_mean_tangent_is_off_by_round_off_is_drawn_along_x() -> None:
    """hard/cylinder_on_cylinder.toml (two arcs) reads t = (1, 2.2e-13): its contact plot
    is drawn against x, labelled x, as before session 30 (before: `center_x + distance
    along the contact`, the coordinate 6e-15 off x); a contact turned by 1 deg is not."""
    from plot_results import contact_coordinate

    for tilt, label in ((1e-13, "x"), (1.0, "center_x + distance along the contact")):
        pc = _profile(0.0, bend=2.0)
        th = np.radians(tilt)
        rot = np.array([[np.cos(th), np.sin(th)], [-np.sin(th), np.cos(th)]])
        X = np.column_stack((pc.x, pc.y)) @ rot
        c = {"x": X[:, 0], "y": X[:, 1], "p": pc.p, "q": pc.q, "length": pc.length,
             "p_force": pc.p_force, "q_force": pc.q_force, "tangent": pc.tangent @ rot}
        coord, got = contact_coordinate(c, np.ones(pc.x.size, bool),
                                        {"type": "hertz", "radius": 1.0, "center_x": 0.0},
                                        "contact")
        assert got == label
        if label == "x":
            assert np.array_equal(coord, c["x"])
