"""mesh.file guards. A node on no quadrilateral (app/mesh/read.py): dropped, so it carries
no DOF and leaves the answer unchanged (no singular stiffness); the run says how many it
dropped and where the first one is (mesh_quality in summary.json and the mesh quality
line). A load on an interior line: an error naming where the edge is."""

from __future__ import annotations

import numpy as np
import pytest
from support import read_summary, run_cli
from test_mesh_folds import CONFIG, STRIP, _msh

from app.mesh.quality import mesh_quality, quality_line
from app.mesh.read import read_mesh


def _with_nodes(extra: list[list[float]]) -> str:
    """The strip's MSH 2.2 with nodes that no element uses appended."""
    lines = _msh(STRIP).split("\n")
    i, n = lines.index("$Nodes"), len(STRIP)
    lines[i + 1] = str(n + len(extra))
    j = lines.index("$EndNodes")
    lines[j:j] = [f"{n + 1 + k} {x!r} {y!r} 0" for k, (x, y) in enumerate(extra)]
    return "\n".join(lines)


def test_the_reader_drops_and_records_unused_nodes(tmp_path):
    (tmp_path / "a.msh").write_text(_with_nodes([[0.5, 0.0], [50.0, 50.0]]))
    mesh = read_mesh(tmp_path / "a.msh", ["sq"])
    assert mesh.n_nodes == len(STRIP)
    np.testing.assert_array_equal(mesh.dropped_nodes, [[0.5, 0.0], [50.0, 50.0]])
    q = mesh_quality(mesh)
    assert q["unused_nodes"] == 2 and q["unused_node_at"] == [0.5, 0.0]
    assert "2 node(s) of the mesh file on no quadrilateral dropped (first at x=0.5, y=0)" \
        in quality_line(q)
    (tmp_path / "b.msh").write_text(_msh(STRIP))
    plain = mesh_quality(read_mesh(tmp_path / "b.msh", ["sq"]))
    assert "unused_nodes" not in plain and "dropped" not in quality_line(plain)


@pytest.mark.parametrize("where", [[0.5, 0.0], [1.5, 0.5], [50.0, 50.0]],
                         ids=["on_an_edge", "inside", "far"])
def test_an_unused_node_changes_nothing_and_is_reported(tmp_path, where):
    """Measured: the strip's strain energy 0.0013387872107998447 and 16 DOFs with or
    without the node, on an edge, inside an element or far away."""
    energies = []
    for tag, text in (("plain", _msh(STRIP)), ("extra", _with_nodes([where]))):
        d = tmp_path / tag
        d.mkdir()
        (d / "run.toml").write_text(CONFIG)
        (d / "strip.msh").write_text(text)
        r = run_cli(["run", str(d / "run.toml"), "--out", str(d / "o")])
        assert r.returncode == 0, r.stderr
        s = read_summary(d / "o")
        assert s["n_dofs"] == 16
        energies.append(s["steps"][-1]["strain_energy"])
        if tag == "extra":
            assert s["mesh_quality"]["unused_nodes"] == 1
            assert "1 node(s) of the mesh file on no quadrilateral dropped" in r.stderr
            assert not any("node" in w for w in s.get("warnings", []))
    assert energies[0] == energies[1]


def test_a_load_on_an_interior_line_names_the_place_not_node_numbers(tmp_path):
    """Before: `(first: nodes 1-5)`, the reader's own 0-based numbers, which are neither
    the file's node tags (2 and 6 here) nor anything else a user can find."""
    (tmp_path / "run.toml").write_text(CONFIG)
    (tmp_path / "strip.msh").write_text(_msh(STRIP).replace("1 2 3 3 4 8", "1 2 3 3 2 6"))
    r = run_cli(["run", str(tmp_path / "run.toml"), "--quiet", "--out", str(tmp_path / "o")])
    assert r.returncode == 2
    assert r.stderr.strip().splitlines()[-1] == (
        "error: load on 'right': 1 edges are interior edges shared by two elements "
        "(first: the edge from (1, 0) to (1, 1))")


def test_a_remeshed_study_of_a_mesh_file_is_an_error(tmp_path):
    """Before: `study meshes/punch.toml --remesh` ran the file's mesh at every level
    (levels 0 and 1: 2924 DOFs and strain energy 0.0509100 both), exit 0, orders of 0."""
    from support import ROOT

    out = tmp_path / "o"
    r = run_cli(["study", str(ROOT / "meshes" / "punch.toml"), "--set",
                 'reference.type="hertz"', "--set", "reference.radius=1.0", "--levels", "2",
                 "--methods", "4", "--remesh", "--quiet", "--out", str(out)])
    assert r.returncode == 2
    line = r.stderr.strip().splitlines()[-1]
    assert line.startswith("error: --remesh does not apply to a mesh read from mesh.file "
                           "(punch.msh)") and "leave --remesh out" in line
    s = read_summary(out)
    assert s["status"] == "failed" and s["error"] == line[len("error: "):]
    assert not (out / "study.csv").exists()
