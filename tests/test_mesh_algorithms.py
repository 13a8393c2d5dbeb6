"""`[mesh] algorithm`: the gmsh recipes of app/scene/mesh_algorithms.py."""

from __future__ import annotations

import tomllib
from pathlib import Path

import gmsh
import numpy as np
import pytest

from app.config import parse_config
from app.errors import InputError
from app.mesh.build import build_mesh
from app.mesh.model import Mesh
from app.mesh.quality import mesh_quality
from app.mesh.refine import refine_mesh, scene_arcs
from app.scene import parse_scene
from app.scene.mesh_algorithms import DEFAULT_MESH_ALGORITHM, MESH_ALGORITHMS, gmsh_options

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def hertz_cfg(algorithm: str | None = None) -> dict:
    cfg = tomllib.loads((CONFIGS / "hertz.toml").read_text())
    if algorithm is not None:
        cfg["mesh"]["algorithm"] = algorithm
    return cfg


def regular_fraction(m: Mesh) -> float:
    """Share of the nodes under the contact (|x| < 0.1, -0.05 < y < 0, inside the block)
    that have four quads around them."""
    valence = np.bincount(m.quads.ravel(), minlength=m.n_nodes)
    p = m.points
    zone = (np.abs(p[:, 0]) < 0.1) & (p[:, 1] < -1e-9) & (p[:, 1] > -0.05)
    return float(np.mean(valence[zone] == 4))


def test_default_and_choices() -> None:
    assert parse_scene(hertz_cfg()).algorithm == DEFAULT_MESH_ALGORITHM
    assert parse_scene(hertz_cfg("frontal-quad")).algorithm == "frontal-quad"
    # every recipe sets the same options, so none leaks into a later mesh
    keys = {frozenset(gmsh_options(name)) for name in MESH_ALGORITHMS}
    assert len(keys) == 1


@pytest.mark.parametrize(("value", "message"), [
    ("frontal", r"mesh.algorithm must be one of .*\(did you mean frontal-quad\?\)"),
    (8, "mesh.algorithm must be one of delaunay, frontal-delaunay, frontal-quad"),
])
def test_bad_algorithm(value: object, message: str) -> None:
    with pytest.raises(InputError, match=message):
        parse_scene(hertz_cfg(value))  # type: ignore[arg-type]
    with pytest.raises(InputError, match=message):
        parse_config(hertz_cfg(value))  # type: ignore[arg-type]


@pytest.mark.parametrize(("algorithm", "scale"), [("frontal-delaunay", 0.5),
                                                 ("frontal-quad", 0.25)])
def test_frontal_recipes_are_regular_under_the_contact(algorithm: str, scale: float) -> None:
    """Where the README measures them smooth (frontal-delaunay at a/20, frontal-quad at
    a/40) the recipes put nearly only 4-valent nodes under the contact, where the default
    leaves irregular ones; both are all-quad and keep angles in 40-140 deg."""
    default = build_mesh(parse_scene(hertz_cfg()), scale=scale)
    frontal = build_mesh(parse_scene(hertz_cfg(algorithm)), scale=scale)
    assert regular_fraction(frontal) > 0.98
    assert regular_fraction(default) < 0.95
    for m in (default, frontal):
        q = mesh_quality(m)
        assert q["min_corner_angle_deg"] > 40.0 and q["max_corner_angle_deg"] < 140.0
    # the same contact element size on both sides
    for curve in ("cyl_arc", "block_top"):
        p = frontal.points[frontal.curves[curve]]
        mid, length = p.mean(axis=1), np.linalg.norm(p[:, 1] - p[:, 0], axis=1)
        near = length[np.abs(mid[:, 0]) < 0.1]
        assert np.all(np.abs(near - 0.01 * scale) < 0.1 * 0.01 * scale), curve
    # nested refinement splits it like any quad mesh
    split = refine_mesh(frontal, 1, scene_arcs(parse_scene(hertz_cfg(algorithm))))
    assert split.n_elements == 4 * frontal.n_elements
    assert mesh_quality(split)["min_corner_angle_deg"] > 40.0


def test_recipe_in_cache_key_and_no_leak(tmp_path: Path) -> None:
    default = build_mesh(parse_scene(hertz_cfg()), cache_dir=tmp_path)
    build_mesh(parse_scene(hertz_cfg("frontal-quad")), cache_dir=tmp_path)
    assert len(list(tmp_path.glob("*.npz"))) == 2  # another recipe is a cache miss
    gmsh.initialize([], readConfigFiles=False, run=False, interruptible=False)
    try:  # one gmsh session for both: the second mesh must not inherit the first's options
        build_mesh(parse_scene(hertz_cfg("frontal-quad")))
        again = build_mesh(parse_scene(hertz_cfg()))
    finally:
        gmsh.finalize()
    assert np.array_equal(again.quads, default.quads)
    np.testing.assert_array_equal(again.points, default.points)
