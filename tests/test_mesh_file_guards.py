"""mesh.file guards. A node on no quadrilateral (app/mesh/read.py): dropped, so it carries
no DOF and leaves the answer unchanged (no singular stiffness); the run says how many it
dropped and where the first one is (mesh_quality in summary.json and the mesh quality
line). A load on an interior line: an error naming where the edge is. `study --remesh`
of a mesh.file: an error. A split mesh.file whose sides look like a curve given by chords
(app/mesh/facets.py): a warning, as the split keeps the chords at every level.

Measured: hertz.toml's level-0 mesh written as a .msh and studied with `study FILE_CONFIG
--levels 3 --methods 4` read peak pressure errors 0.72%, 2.3%, 4.5% and L2(p) 0.78%,
3.2%, 3.2% at levels 0-2 (the gmsh-built config: 0.72%, 0.30%, 0.19% and 0.78%, 1.0%,
0.74%), with no warning."""

from __future__ import annotations

import numpy as np
import pytest
from support import read_summary, run_cli
from test_mesh_folds import CONFIG, QUADS, STRIP, _msh

from app.mesh.facets import faceted_sides, faceted_split_warnings
from app.mesh.model import Mesh, orient_ccw
from app.mesh.quality import mesh_quality, quality_line
from app.mesh.read import read_mesh
from app.mesh.refine import refine_mesh


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


def _sector(n: int = 8) -> Mesh:
    """A quarter annulus (radii 1 and 2) of n quads: its arcs given by chords."""
    t = np.linspace(0.0, np.pi / 2, n + 1)
    pts = np.concatenate([np.c_[np.cos(t), np.sin(t)], 2 * np.c_[np.cos(t), np.sin(t)]])
    quads = np.array([[i, n + 1 + i, n + 2 + i, i + 1] for i in range(n)])
    return Mesh(pts, orient_ccw(pts, quads), np.zeros(n, np.int64), ["ring"])


def test_chords_of_a_curve_are_found_and_polygons_are_not():
    got = faceted_sides(_sector())
    assert list(got) == ["ring"] and got["ring"][0] == 14  # 7 inner and 7 outer nodes
    assert got["ring"][1] == pytest.approx(11.25) and got["ring"][2] == pytest.approx(11.25)
    split = refine_mesh(_sector(), 2)  # the split keeps them: mid nodes turn by 0
    assert faceted_sides(split)["ring"][0] == 14
    strip = Mesh(STRIP, orient_ccw(STRIP, QUADS), np.zeros(3, np.int64), ["sq"])
    assert faceted_sides(strip) == {} and faceted_sides(refine_mesh(strip, 1)) == {}
    assert faceted_split_warnings(_sector(), "ring.msh", 2)[0].startswith(
        "body 'ring': mesh file ring.msh is split 2 time(s), and the split puts its new "
        "boundary nodes on the file's straight edges: 14 of its boundary nodes turn by 11 "
        "to 11 deg")


def test_a_split_mesh_file_of_straight_sides_does_not_warn(tmp_path):
    (tmp_path / "run.toml").write_text(CONFIG)
    (tmp_path / "strip.msh").write_text(_msh(STRIP))
    r = run_cli(["run", str(tmp_path / "run.toml"), "--quiet", "--refine", "1",
                 "--out", str(tmp_path / "o")])
    assert r.returncode == 0 and "warning" not in r.stderr, r.stderr


HERTZ_FILE_CONFIG = """[analysis]
plane = "strain"
method = "cs-fem"
sd = 4
[mesh]
file = "hertz.msh"
[[body]]
name = "cylinder"
E = 200e3
nu = 0.3
[[body]]
name = "block"
E = 200e3
nu = 0.3
[[support]]
on = "base"
ux = 0.0
uy = 0.0
[[support]]
on = "cyl_top"
ux = 0.0
[[load]]
on = "cyl_top"
total_force = [0.0, -863.0]
[[interface]]
name = "contact"
slave = "cyl_arc"
master = "block_top"
search_distance = 0.05
[reference]
type = "hertz"
radius = 1.0
"""


def _hertz_as_msh(path) -> None:
    """configs/hertz.toml's level-0 mesh as MSH 2.2, its bodies and curves named."""
    from support import CONFIGS

    from app.config import load_config
    from app.mesh.build import build_mesh

    m = build_mesh(load_config(CONFIGS / "hertz.toml").scene, 1.0)
    tag = {n: i + 1 for i, n in enumerate([*m.body_names, *m.curves])}
    els = [f"1 2 {tag[n]} {tag[n]} {a + 1} {b + 1}" for n, e in m.curves.items() for a, b in e]
    els += [f"3 2 {tag[m.body_names[b]]} {tag[m.body_names[b]]} "
            + " ".join(str(k + 1) for k in q) for q, b in zip(m.quads, m.body, strict=True)]
    path.write_text("\n".join([
        "$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$PhysicalNames", str(len(tag)),
        *[f'{2 if n in m.body_names else 1} {t} "{n}"' for n, t in tag.items()],
        "$EndPhysicalNames", "$Nodes", str(m.n_nodes),
        *[f"{i + 1} {x!r} {y!r} 0" for i, (x, y) in enumerate(m.points)], "$EndNodes",
        "$Elements", str(len(els)), *[f"{i + 1} {e}" for i, e in enumerate(els)],
        "$EndElements", ""]))


def test_hertz_from_a_file_split_twice_warns_of_its_chords(tmp_path):
    """The figures of README "Running your own .msh": split twice, the file's faceted
    cylinder reads its peak pressure 4.5% off (the gmsh-built scene 0.19%)."""
    from support import CONFIGS

    (tmp_path / "hertz.toml").write_text(HERTZ_FILE_CONFIG)
    _hertz_as_msh(tmp_path / "hertz.msh")
    peaks = []
    for tag, cfg in (("file", tmp_path / "hertz.toml"), ("gmsh", CONFIGS / "hertz.toml")):
        r = run_cli(["run", str(cfg), "--refine", "2", "--quiet", "--out", str(tmp_path / tag)])
        assert r.returncode == 0, r.stderr
        s = read_summary(tmp_path / tag)
        peaks.append(s["reference"]["hertz"]["p_max_rel_error"])
        chords = [w for w in s.get("warnings", []) if "curve given by chords" in w]
        assert len(chords) == (tag == "file"), s.get("warnings")
    print(f"\npeak pressure error, split twice: file {peaks[0]:.4f}, gmsh-built {peaks[1]:.4f}")
    assert peaks[0] > 0.03 and peaks[1] < 0.005
