"""Mesh quality at load, and the ready gmsh mesh in meshes/."""

from __future__ import annotations

import numpy as np
import pytest
from support import ROOT, read_summary, run_cli

from app.errors import InputError
from app.mesh.model import Mesh
from app.mesh.quality import aspect_ratios, corner_angles, mesh_quality, quality_line


def _mesh(points, quads) -> Mesh:
    quads = np.asarray(quads)
    return Mesh(np.asarray(points, dtype=float), quads, np.zeros(len(quads), dtype=np.int64),
                ["plate"])


def test_angles_and_aspect_ratio():
    xe = np.array([[[0, 0], [2, 0], [2, 1], [0, 1]],
                   [[0, 0], [1, 0], [2, 1], [1, 1]]], dtype=float)
    np.testing.assert_allclose(corner_angles(xe), [[90, 90, 90, 90], [45, 135, 45, 135]])
    np.testing.assert_allclose(aspect_ratios(xe), [2.0, np.sqrt(2.0)])
    q = mesh_quality(_mesh(xe.reshape(-1, 2), [[0, 1, 2, 3], [4, 5, 6, 7]]))
    assert q["min_corner_angle_deg"] == pytest.approx(45.0)
    assert q["max_corner_angle_deg"] == pytest.approx(135.0)
    assert q["max_aspect_ratio"] == pytest.approx(2.0)
    assert quality_line(q).startswith("mesh quality: corner angles 45 to 135 deg")


@pytest.mark.parametrize("points", [
    [[0, 0], [1, 0], [1, 0], [0, 1]],          # two nodes on top of each other
    [[0, 0], [1, 0], [2, 0], [0, 1]],          # three nodes on a line (a triangle)
    [[0, 0], [2, 0], [0.5, 0.5], [0, 2]],      # not convex (a dart)
])
def test_degenerate_or_non_convex_quads_are_an_error(points):
    with pytest.raises(InputError, match="body 'plate': 1 element.*degenerate or not convex"):
        mesh_quality(_mesh(points, [[0, 1, 2, 3]]))


def test_the_ready_mesh_in_meshes_runs(tmp_path):
    out = tmp_path / "punch"
    res = run_cli(["run", str(ROOT / "meshes" / "punch.toml"), "--out", str(out)])
    assert res.returncode == 0, res.stderr
    assert "mesh quality: corner angles" in res.stderr
    s = read_summary(out)
    assert s["status"] == "completed" and s["bodies"] == ["block", "punch"]
    assert s["mesh_quality"]["min_corner_angle_deg"] > 30.0
    st = s["steps"][0]
    # pressure 20 on the punch top of width 0.5: 10 through the contact and the base
    assert st["interfaces"]["contact"]["force"][1] == pytest.approx(10.0, rel=1e-9)
    assert st["reactions"]["support:block_base"]["Fy"] == pytest.approx(10.0, rel=1e-9)
    assert st["balance"]["max_relative_residual"] < 1e-10
