"""Uniform refinement by splitting (app/mesh/refine.py) and `run --refine`."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from support import CONFIGS, read_summary, run_cli

from app.discretisation.bulk import check_elements
from app.mesh.build import build_mesh
from app.mesh.model import Mesh, orient_boundary_edges
from app.mesh.refine import refine_mesh, scene_arcs, split_quads
from app.scene import parse_scene


def areas(mesh: Mesh) -> np.ndarray:
    p = mesh.points[mesh.quads]
    x, y = p[..., 0], p[..., 1]
    return 0.5 * np.sum(x * np.roll(y, -1, 1) - np.roll(x, -1, 1) * y, axis=1)


def two_squares() -> Mesh:
    pts = np.array([[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2.5, 1.2]], float)
    return Mesh(pts, np.array([[0, 1, 4, 3], [1, 2, 5, 4]]), np.array([0, 0]), ["b"],
                curves={"bottom": np.array([[0, 1], [1, 2]])},
                point_groups={"corner": np.array([5])})


def test_split_is_nested_conforming_and_keeps_groups():
    m = two_squares()
    r, edges, inverse = split_quads(m)
    assert r.n_elements == 8 and len(edges) == 7 and r.n_nodes == 6 + 7 + 2
    np.testing.assert_array_equal(r.points[:6], m.points)  # old nodes keep their indices
    assert np.all(areas(r) > 0)
    np.testing.assert_allclose(areas(r).sum(), areas(m).sum())
    # conforming: every interior edge is used twice, in opposite directions
    e = np.stack([r.quads, np.roll(r.quads, -1, 1)], -1).reshape(-1, 2)
    directed = {tuple(x) for x in e.tolist()}
    assert len(directed) == len(e)  # no edge twice in the same direction
    undirected, counts = np.unique(np.sort(e, axis=1), axis=0, return_counts=True)
    assert counts.max() == 2 and len(undirected) == 8 * 4 - (counts == 2).sum()
    assert (counts == 2).sum() == 2 * 1 + 4 * 2  # old interior edge halves + inner edges
    assert r.curves["bottom"].shape == (4, 2)
    np.testing.assert_allclose(r.points[r.curves["bottom"]][:, :, 1], 0.0)
    orient_boundary_edges(r, r.curves["bottom"], "bottom")  # still boundary edges
    assert r.point_groups["corner"].tolist() == [5]
    np.testing.assert_array_equal(r.body, np.zeros(8))


@pytest.mark.parametrize("config, levels", [("hertz.toml", (1, 2, 3)),
                                            ("hertz_halfspace.toml", (3,))])
def test_hertz_levels_put_arc_nodes_on_the_circle(config, levels):
    cfg = parse_scene(tomllib.loads((CONFIGS / config).read_text()))
    m0 = build_mesh(cfg)
    prev = None
    for level in levels:
        m = refine_mesh(m0, level, scene_arcs(cfg))
        check_elements(m)
        assert m.n_elements == 4**level * m0.n_elements
        arc = m.curve_nodes("cyl_arc")
        np.testing.assert_allclose(np.hypot(m.points[arc, 0], m.points[arc, 1] - 1.0), 1.0,
                                   atol=1e-12)
        top = m.curve_nodes("block_top")  # the block's flat top touches the arc: kept flat
        np.testing.assert_array_equal(m.points[top, 1], 0.0)
        a = areas(m)
        cyl = a[m.body == m.body_names.index("cylinder")].sum()
        err = abs(cyl - 0.5 * math.pi)
        assert prev is None or err < 0.3 * prev  # area error of the polygon ~ h^2
        prev = err
        np.testing.assert_allclose(a[m.body == m.body_names.index("block")].sum(), 32.0)


def test_run_refine_matches_the_split_mesh(tmp_path):
    out = tmp_path / "r"
    res = run_cli(["run", str(CONFIGS / "hertz.toml"), "--refine", "1", "--out", str(out),
                   "--quiet"])
    assert res.returncode == 0, res.stderr
    s = read_summary(out)
    cfg = tomllib.loads((CONFIGS / "hertz.toml").read_text())
    assert s["n_elements"] == 4 * build_mesh(parse_scene(cfg)).n_elements
    assert s["reference"]["hertz"]["p_max_rel_error"] < 0.02
    res = run_cli(["run", str(CONFIGS / "hertz.toml"), "--refine", "-1", "--out", str(out)])
    assert res.returncode == 2 and "--refine" in res.stderr


def test_halfspace_scenes_converge_to_the_closed_forms(tmp_path):
    """configs/*_halfspace.toml at level 2 (a/20): the closed-form errors are those of a
    converging discretisation, not a model-error plateau (README: "Closed-form scenes")."""
    res = run_cli(["run", str(CONFIGS / "hertz_halfspace.toml"), "--refine", "2", "--out",
                   str(tmp_path / "h"), "--quiet"])
    assert res.returncode == 0, res.stderr
    hz = read_summary(tmp_path / "h")["reference"]["hertz"]
    assert hz["p_max_rel_error"] < 2e-3 and hz["pressure_l2_rel_error"] < 0.012
    assert abs(hz["a_hertz"] - 0.01) < 1e-4
    res = run_cli(["run", str(CONFIGS / "cattaneo_halfspace.toml"), "--refine", "2", "--out",
                   str(tmp_path / "c"), "--quiet"])
    assert res.returncode == 0, res.stderr
    ref = read_summary(tmp_path / "c")["reference"]
    assert ref["hertz"]["p_max_rel_error"] < 2e-3
    assert ref["cattaneo"]["stick_half_width_rel_error"] < 0.03
    assert ref["cattaneo"]["traction_l2_interp_rel_error"] < 0.06  # cattaneo.toml: 23%
    assert abs(ref["cattaneo"]["Q_over_muP"] - 0.5) < 0.02
