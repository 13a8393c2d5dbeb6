"""A mesh that folds over itself (app/mesh/folds.py): an inverted element among its
neighbours, which the reader turns counter-clockwise like any clockwise quad."""

from __future__ import annotations

import numpy as np
import pytest
from support import read_summary, run_cli

from app.errors import InputError
from app.mesh.checks import check_scene
from app.mesh.folds import check_no_folds
from app.mesh.model import Mesh, orient_ccw

# A strip of three unit quads along x; FOLD moves the nodes at x = 2 to x = 3.5, so the
# third quad (x from 3.5 back to 3) is inverted and lies inside the second.
STRIP = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [0, 1], [1, 1], [2, 1], [3, 1]], float)
QUADS = np.array([[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6]])


def _mesh(points: np.ndarray, quads: np.ndarray = QUADS) -> Mesh:
    return Mesh(points, orient_ccw(points, quads), np.zeros(len(quads), np.int64), ["sq"])


def _folded() -> np.ndarray:
    p = STRIP.copy()
    p[p[:, 0] == 2.0, 0] = 3.5
    return p


def test_a_folded_mesh_is_an_error():
    with pytest.raises(InputError, match="body 'sq': the mesh folds over itself: 1 element"):
        check_scene(_mesh(_folded()), [])


def test_unfolded_meshes_pass_in_either_orientation():
    check_no_folds(_mesh(STRIP))
    check_no_folds(_mesh(STRIP, QUADS[:, ::-1]))  # all clockwise: all turned, no fold
    check_no_folds(_mesh(STRIP, np.array([QUADS[0], QUADS[1, ::-1], QUADS[2]])))


def _msh(points: np.ndarray) -> str:
    """MSH 2.2 of the strip: surface 'sq', curves 'left' and 'right'."""
    nodes = [f"{i + 1} {x!r} {y!r} 0" for i, (x, y) in enumerate(points)]
    els = ["1 2 2 2 1 5", "1 2 3 3 4 8"] + [
        "3 2 1 1 " + " ".join(str(k + 1) for k in q) for q in QUADS]
    return "\n".join(["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$PhysicalNames", "3",
                      '2 1 "sq"', '1 2 "left"', '1 3 "right"', "$EndPhysicalNames",
                      "$Nodes", str(len(nodes)), *nodes, "$EndNodes", "$Elements",
                      str(len(els)), *(f"{i + 1} {e}" for i, e in enumerate(els)),
                      "$EndElements", ""])


CONFIG = """[analysis]
plane = "strain"
[mesh]
file = "strip.msh"
[[body]]
name = "sq"
E = 1000.0
nu = 0.3
[[support]]
on = "left"
ux = 0.0
uy = 0.0
[[load]]
on = "right"
traction = [1.0, 0.0]
"""


def test_a_folded_msh_stops_the_run(tmp_path):
    """Before: the run completed (strain energy 1.3x the unfolded strip's), no word."""
    (tmp_path / "run.toml").write_text(CONFIG)
    (tmp_path / "strip.msh").write_text(_msh(_folded()))
    r = run_cli(["run", str(tmp_path / "run.toml"), "--quiet", "--out", str(tmp_path / "o")])
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().splitlines()[-1].startswith(
        "error: body 'sq': the mesh folds over itself")
    assert read_summary(tmp_path / "o")["status"] == "failed"
    (tmp_path / "strip.msh").write_text(_msh(STRIP))
    r = run_cli(["run", str(tmp_path / "run.toml"), "--quiet", "--out", str(tmp_path / "o")])
    assert r.returncode == 0, r.stderr
