"""`[[mesh.patch]]`: structured (transfinite) quads inside a box, app/mesh/patch.py."""

from __future__ import annotations

import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest
from support import read_summary, run_cli

from app.closed_form import hertz_pressure
from app.config import parse_config
from app.errors import InputError
from app.mesh.build import build_mesh
from app.mesh.model import Mesh
from app.mesh.quality import mesh_quality
from app.mesh.refine import refine_mesh, scene_arcs
from app.scene import parse_scene

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
BOX = (-0.12, -0.08, 0.12, 0.08)  # configs/hertz_patch.toml


def patch_cfg(box: list[float] | None = None, **extra: object) -> dict:
    cfg = tomllib.loads((CONFIGS / "hertz_patch.toml").read_text())
    if box is not None:
        cfg["mesh"]["patch"][0]["box"] = box
    cfg["mesh"]["patch"][0].update(extra)
    return cfg


def in_box(xy: np.ndarray, box: tuple[float, ...], eps: float) -> np.ndarray:
    return ((xy[..., 0] > box[0] + eps) & (xy[..., 0] < box[2] - eps)
            & (xy[..., 1] > box[1] + eps) & (xy[..., 1] < box[3] - eps))


def check_structured(m: Mesh, h: float, body: int, n_expected: int) -> None:
    """The quads of `body` inside BOX: n_expected of them, 4-valent interior nodes, edges
    of about h (the cylinder's columns follow the arc: 0.7 h to 1.2 h)."""
    sel = (m.body == body) & in_box(m.points[m.quads].mean(axis=1), BOX, 0.0)
    q = m.quads[sel]
    assert len(q) == n_expected
    valence = np.bincount(m.quads.ravel(), minlength=m.n_nodes)
    nodes = np.unique(q)
    body_nodes = np.zeros(m.n_nodes, bool)
    body_nodes[m.quads[m.body == body].ravel()] = True
    boundary = np.zeros(m.n_nodes, bool)
    for e in m.curves.values():
        boundary[e.ravel()] = True
    inner = nodes[in_box(m.points[nodes], BOX, 0.2 * h) & ~boundary[nodes]]
    assert len(inner) > 100 and np.all(valence[inner] == 4)
    xy = m.points[q]
    edges = np.linalg.norm(np.roll(xy, -1, axis=1) - xy, axis=2)
    assert 0.7 * h < edges.min() and edges.max() < 1.2 * h
    horizontal = np.abs(xy[:, 1, 0] - xy[:, 0, 0]) > 0.5 * h
    assert np.allclose(edges[:, 0][horizontal], h, rtol=0.01)


@pytest.mark.parametrize("scale", [1.0, 0.5])
def test_patch_is_structured_and_curves_complete(scale: float) -> None:
    h = 0.01 * scale
    scene = parse_scene(patch_cfg())
    m = build_mesh(scene, scale=scale)
    n = round(0.24 / h)
    check_structured(m, h, 1, n * round(0.08 / h))  # the block: 24 x 8 at a/10
    depth = 0.08 - (1.0 - np.sqrt(1.0 - 0.12**2))  # the cylinder piece's vertical sides
    check_structured(m, h, 0, n * 2 * round(depth / (2 * h)))  # even counts (full-quad)
    assert set(m.curves) == {"cyl_arc", "cyl_top", "base", "block_top", "block_sides"}
    for name, edges in m.curves.items():  # every named curve keeps all its pieces
        length = np.linalg.norm(np.diff(m.points[edges], axis=1), axis=2).sum()
        exact = sum(p.length for b in scene.bodies for p in b.curve_pieces(name))
        assert exact * (1 - 1e-2) < length < exact * (1 + 1e-12), name  # chords
    for name in ("cyl_arc", "block_top"):  # one chain from end to end, no gap
        deg = np.bincount(m.curves[name].ravel())
        assert np.count_nonzero(deg == 1) == 2 and deg.max() == 2, name
        assert len(m.curves[name]) == np.count_nonzero(deg) - 1, name
    top = m.curves["block_top"]
    assert np.ptp(m.points[top][..., 0]) == pytest.approx(8.0)
    on_top = np.flatnonzero((np.abs(m.points[:, 1]) < 1e-12) & (m.node_body() == 1))
    assert set(on_top) == set(np.unique(top))
    q = mesh_quality(m)
    assert q["min_corner_angle_deg"] > 25.0 and q["max_corner_angle_deg"] < 170.0


def test_nested_refinement_and_cache(tmp_path: Path) -> None:
    scene = parse_scene(patch_cfg())
    m = build_mesh(scene, cache_dir=tmp_path)
    split = refine_mesh(m, 1, scene_arcs(scene))
    check_structured(split, 0.005, 1, 48 * 16)
    arc = split.points[np.unique(split.curves["cyl_arc"])]
    assert np.allclose(np.hypot(arc[:, 0], arc[:, 1] - 1.0), 1.0, atol=1e-12)
    plain = build_mesh(parse_scene(tomllib.loads((CONFIGS / "hertz.toml").read_text())),
                       cache_dir=tmp_path)
    assert len(list(tmp_path.glob("*.npz"))) == 2  # the patches are in the cache key
    assert plain.n_elements != m.n_elements
    other = build_mesh(parse_scene(patch_cfg(size=0.02)), cache_dir=tmp_path)
    assert len(list(tmp_path.glob("*.npz"))) == 3 and other.n_elements < m.n_elements


@pytest.mark.parametrize(("cfg", "message"), [
    (patch_cfg([-0.12, -0.08, 0.12, 0.005]),
     r"body 'cylinder': the part of mesh.patch\[0\] inside it has 2 corners, not 4"),
    (patch_cfg([0.12, -0.08, -0.12, 0.08]), r"mesh.patch\[0\].box .* needs xmin < xmax"),
    (patch_cfg([0.0, 1.0]), r"mesh.patch\[0\].box must be \[xmin, ymin, xmax, ymax\]"),
    (patch_cfg(size=-1.0), r"mesh.patch\[0\].size must be a number > 0"),
])
def test_bad_patch(cfg: dict, message: str) -> None:
    with pytest.raises(InputError, match=message):
        build_mesh(parse_scene(cfg))


def test_overlap_and_unknown_key() -> None:
    cfg = patch_cfg()
    cfg["mesh"]["patch"].append({"box": [0.0, -0.05, 0.2, 0.05], "size": 0.01})
    with pytest.raises(InputError, match=r"mesh.patch\[0\] and mesh.patch\[1\] overlap"):
        build_mesh(parse_scene(cfg))
    with pytest.raises(InputError, match=r"unknown key mesh.patch\[0\].sise"):
        parse_config(patch_cfg(sise=0.01))


def test_hertz_patch_run_smooth_and_swap_invariant(tmp_path: Path) -> None:
    """configs/hertz_patch.toml at a/10 with mortar: p - p_Hertz has no jump above 0.2% p0
    over |x| < 0.8 a (hertz.toml: 8 of 17 inner pairs, README "Hertz and the mesh") and
    swapping slave and master changes L2(p) by under 0.1 points."""
    l2 = []
    for swap in (False, True):
        out = tmp_path / f"run{int(swap)}"
        sides = ["--set", 'interface.contact.slave="block_top"', "--set",
                 'interface.contact.master="cyl_arc"'] if swap else []
        res = run_cli(["run", str(CONFIGS / "hertz_patch.toml"), *sides, "--out", str(out),
                       "--quiet"])
        assert res.returncode == 0, res.stderr
        h = read_summary(out)["reference"]["hertz"]
        l2.append(h["pressure_l2_interp_rel_error"])
        with h5py.File(out / "step_0001.h5") as f:
            x, p = f["contact"]["x"][()], f["contact"]["p"][()]
        o = np.argsort(x)
        e = (p[o] - hertz_pressure(x[o], h["a_hertz"], h["p0_hertz"])) / h["p0_hertz"]
        inner = np.abs(x[o][1:-1]) < 0.8 * h["a_hertz"]
        assert inner.sum() >= 13
        assert np.abs(e[2:] - 2 * e[1:-1] + e[:-2])[inner].max() < 0.002
    assert abs(l2[1] - l2[0]) < 1e-3
