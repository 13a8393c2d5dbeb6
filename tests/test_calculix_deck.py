"""scripts/calculix_deck.py: the CalculiX deck writer, the .dat/.frd readers and the
traction recovery on tiny meshes; one CalculiX run when `ccx` is installed."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from tests.support import ROOT

sys.path.insert(0, str(ROOT / "scripts"))
from calculix_deck import (  # noqa: E402
    ContactDeck,
    Step,
    chain_nodes,
    edge_faces,
    internal_forces,
    nodal_table,
    parse_dat,
    parse_frd_contact,
    recovered_tractions,
    surface_tractions,
    write_deck,
)

E, NU = 200e3, 0.3


def two_blocks(gap: float = 0.0) -> ContactDeck:
    """Unit square (nodes 0-3) under a unit square (nodes 4-7, slave = its bottom face),
    the lower base fixed, the upper top pressed down by 1e-3."""
    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1],
                    [0, 1 + gap], [1, 1 + gap], [1, 2 + gap], [0, 2 + gap]], dtype=float)
    quads = np.array([[4, 5, 6, 7], [0, 1, 2, 3]])
    return ContactDeck(
        points=pts, quads=quads, body=np.array([0, 1]),
        node_sets={"base": np.array([0, 1]), "top": np.array([6, 7])},
        slave_faces=edge_faces(quads, np.array([[4, 5]])),
        master_faces=edge_faces(quads, np.array([[2, 3]])), E=[E, E], nu=[NU, NU],
        thickness=1.0, penalty=1e9, mu=0.2, stick=1e9, fixed={"base": (1, 2)},
        steps=[Step({"top": {1: 0.0, 2: -1e-3}}, 2)], print_sets=["top"])


def test_edge_faces_finds_element_and_local_face():
    quads = np.array([[0, 1, 2, 3], [1, 4, 5, 2]])
    faces = edge_faces(quads, np.array([[2, 3], [4, 5], [0, 1]]))
    assert faces.tolist() == [[0, 2], [1, 1], [0, 0]]
    with pytest.raises(ValueError, match="not an element edge"):
        edge_faces(quads, np.array([[3, 2]]))  # reversed: the element is on the right


def test_deck_has_the_scene():
    text = write_deck(two_blocks())
    lines = text.splitlines()
    assert lines[lines.index("*NODE, NSET=NALL") + 1] == "1, 0, 0, 0"
    assert "*ELEMENT, TYPE=CPE4, ELSET=BODY0" in lines and "1, 5, 6, 7, 8" in lines
    # upper element's face 0 (nodes 5-6) is the slave, the lower's face 2 (3-4) the master
    assert lines[lines.index("*SURFACE, NAME=SLAVE, TYPE=ELEMENT") + 1] == "1, S1"
    assert lines[lines.index("*SURFACE, NAME=MASTER, TYPE=ELEMENT") + 1] == "2, S3"
    assert lines[lines.index("*FRICTION") + 1] == "0.2, 1000000000"
    assert "*CONTACT PAIR, INTERACTION=SI, TYPE=SURFACE TO SURFACE" in lines
    assert "BASE, 2, 2, 0." in lines and "TOP, 2, 2, -0.001" in lines
    assert lines[lines.index("*STATIC") + 1] == "0.5, 1., 5e-05, 0.5"
    assert "*CHANGE FRICTION, INTERACTION=SI" not in lines


def test_deck_frictionless_step_writes_positive_mu():
    deck = two_blocks()
    deck.steps[0].mu = 0.0
    lines = write_deck(deck).splitlines()
    i = lines.index("*CHANGE FRICTION, INTERACTION=SI")
    assert lines[i + 2].startswith("1e-06,")


CONTACT_HEAD = (" contact stress (slave element+face,press,tang1,tang2) for all contact elements"
                " and time 0.1000000E+01")
DAT = f"""
 displacements (vx,vy,vz) for set NALL and time  0.1000000E+01

         1  1.000000E-03 -2.000000E-03  0.000000E+00
         3 -1.500000E-05  4.000000E-06  0.000000E+00

 forces (fx,fy,fz) for set TOP and time  0.1000000E+01

         7  1.000000E+00 -5.000000E+01  0.000000E+00
         8 -1.000000E+00 -5.000000E+01  0.000000E+00

 total force (fx,fy,fz) for set TOP and time  0.1000000E+01

        0.000000E+00 -1.000000E+02  0.000000E+00

{CONTACT_HEAD}

         1          3  1.108084E+02  2.507218E-13  0.000000E+00
"""


def test_parse_dat_tables():
    tables = parse_dat(DAT)
    assert [t["title"] for t in tables] == ["displacements (vx,vy,vz)", "forces (fx,fy,fz)",
                                            "total force (fx,fy,fz)",
                                            "contact stress (slave element+face,press,tang1,tang2)"]
    assert tables[2]["set"] == "TOP" and tables[2]["rows"].tolist() == [[0.0, -100.0, 0.0]]
    assert tables[3]["set"] is None and tables[3]["rows"][0, 2] == pytest.approx(110.8084)
    t, u = nodal_table(tables, "displacements", "nall", 4)
    assert t == 1.0 and u[0].tolist() == [1e-3, -2e-3, 0.0] and np.isnan(u[1]).all()
    assert u[2, 0] == -1.5e-5
    with pytest.raises(KeyError):
        nodal_table(tables, "displacements", "NALL", 4, time=2.0)


def test_parse_frd_contact_block():
    head = "    1PSTEP                         1           1           1          \n"
    blk = ("  100CL  101 1.000000000           3                     0    1           1\n"
           " -4  CONTACT     6    1\n"
           + "".join(f" -5  {n:<8}1    4    1    1\n" for n in
                     ("COPEN", "CSLIP1", "CSLIP2", "CPRESS", "CSHEAR1", "CSHEAR2"))
           + " -1         2-1.38320E-05-3.97513E-09 0.00000E+00 5.60272E+03-1.61015E+00"
             " 0.00000E+00\n -3\n")
    out = parse_frd_contact(head + blk, 3)
    assert len(out) == 1 and out[0][0] == 1.0
    assert out[0][1][1, 3] == pytest.approx(5602.72) and out[0][1][1, 4] == -1.61015
    assert not out[0][1][[0, 2]].any()


def square_patch():
    pts = np.array([[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1]], dtype=float)
    quads = np.array([[0, 1, 4, 3], [1, 2, 5, 4]])
    return pts, quads


def test_internal_forces_uniform_stress():
    """u_y = -e y (plane strain, thickness 2): sigma_yy = -(lambda + 2 mu) e on the bottom
    and top edges, shared by their nodes as 1/4, 1/2, 1/4; sigma_xx = -lambda e on the
    sides, half to each of their nodes."""
    pts, quads = square_patch()
    e = 1e-3
    u = np.column_stack([np.zeros(6), -e * pts[:, 1]])
    f = internal_forces(pts, quads, u, E, NU, 2.0)
    syy = -E * (1 - NU) / ((1 + NU) * (1 - 2 * NU)) * e
    assert np.allclose(f[3:, 1], 2.0 * syy * np.array([0.5, 1.0, 0.5]))
    assert np.allclose(f[:3, 1], -f[3:, 1])
    lam_e = E * NU / ((1 + NU) * (1 - 2 * NU)) * e
    assert np.allclose(f[:, 0], lam_e * np.array([1, 0, -1, 1, 0, -1]))


def test_internal_forces_nonlinear_rigid_rotation_is_force_free():
    pts, quads = square_patch()
    c, s = np.cos(0.3), np.sin(0.3)
    u = pts @ np.array([[c, s], [-s, c]]) - pts  # rotated by 0.3 rad
    assert np.abs(internal_forces(pts, quads, u, E, NU, 1.0, nonlinear=True)).max() < 1e-8
    assert np.abs(internal_forces(pts, quads, u, E, NU, 1.0)).max() > 1e3  # linear: not


def test_surface_tractions_on_a_straight_bottom_edge():
    pts, quads = square_patch()
    edges = np.array([[0, 1], [1, 2]])  # bottom, the patch on the left (outward -y)
    assert chain_nodes(edges).tolist() == [0, 1, 2]
    force = np.zeros((6, 2))
    force[[0, 1, 2]] = [[3.0, 5.0], [6.0, 10.0], [3.0, 5.0]]  # 10 per length up, 6 along +x
    tr = surface_tractions(pts, edges, force, u=np.zeros((6, 2)))
    assert tr["length"].tolist() == [0.5, 1.0, 0.5]
    assert np.allclose(tr["pn"], 10.0) and np.allclose(tr["qt"], 6.0)
    assert np.allclose(tr["fy"], tr["pn_def"]) and np.allclose(tr["fx"], tr["qt_def"])


def test_surface_tractions_deformed_frame_follows_a_rigid_rotation():
    """u = R x - x: the deformed-frame figures are the force per length (6, 10) projected
    on the rotated outward normal R (0, -1) and tangent R (1, 0); the undeformed ones
    keep the axes."""
    pts, _ = square_patch()
    edges = np.array([[0, 1], [1, 2]])
    force = np.zeros((6, 2))
    force[[0, 1, 2]] = [[3.0, 5.0], [6.0, 10.0], [3.0, 5.0]]
    theta = 0.4
    c, s = np.cos(theta), np.sin(theta)
    rot = np.array([[c, -s], [s, c]])
    tr = surface_tractions(pts, edges, force, u=pts @ rot.T - pts)
    normal, tangent = rot @ [0.0, -1.0], rot @ [1.0, 0.0]  # (s, -c), (c, s)
    per_length = np.array([6.0, 10.0])
    assert np.allclose(tr["pn_def"], -per_length @ normal)  # 10 c - 6 s
    assert np.allclose(tr["qt_def"], per_length @ tangent)  # 6 c + 10 s
    assert np.allclose(tr["pn_def"], 10 * c - 6 * s) and np.allclose(tr["qt_def"], 6 * c + 10 * s)
    assert np.allclose(tr["pn"], 10.0) and np.allclose(tr["qt"], 6.0)
    assert not np.allclose(tr["pn_def"], tr["pn"])


def test_recovered_tractions_of_the_slave_faces_body():
    """The slave faces' body (here body 1, E = 2 E) gives the forces; NaN (unprinted)
    displacements count as 0; nodes of the deck's node sets are dropped."""
    deck = two_blocks()
    deck.body, deck.E = np.array([1, 0]), [E, 2 * E]
    deck.node_sets["corner"] = np.array([4])
    u = np.column_stack([np.zeros(8), -1e-3 * np.clip(deck.points[:, 1] - 1.0, 0.0, None)])
    rows = np.column_stack([np.arange(1, 8), u[:7], np.zeros(7)])  # node 8 not printed
    tables = [{"title": "displacements (vx,vy,vz)", "set": "NALL", "time": 1.0, "rows": rows}]
    tr = recovered_tractions(tables, deck, np.array([[4, 5]]))
    u[7] = 0.0
    f = internal_forces(deck.points, deck.quads[:1], u, 2 * E, NU, 1.0)
    want = surface_tractions(deck.points, np.array([[4, 5]]), f, u)
    assert tr["node"].tolist() == [5]
    for key in ("x", "length", "fx", "fy", "pn", "qt", "pn_def", "qt_def"):
        assert tr[key] == pytest.approx(want[key][1:], rel=1e-13), key
    assert tr["force"] == pytest.approx(f[[5]], rel=1e-13)
    deck.slave_faces = np.array([[0, 0], [1, 2]])  # faces of both bodies
    with pytest.raises(ValueError, match="2 bodies"):
        recovered_tractions(tables, deck, np.array([[4, 5]]))


@pytest.mark.skipif(shutil.which("ccx") is None, reason="ccx (CalculiX) not installed")
def test_ccx_two_blocks_recovered_force_balances_the_support(tmp_path):
    deck = two_blocks()
    (tmp_path / "job.inp").write_text(write_deck(deck))
    res = subprocess.run(["ccx", "-i", "job"], cwd=tmp_path, capture_output=True, text=True,
                         env=dict(os.environ, OMP_NUM_THREADS="1"), timeout=120)
    assert res.returncode == 0 and "*ERROR" not in res.stdout
    tables = parse_dat((tmp_path / "job.dat").read_text())
    _, u = nodal_table(tables, "displacements", "NALL", 8, time=1.0)
    f = internal_forces(deck.points, deck.quads[:1], u[:, :2], E, NU, 1.0)
    total = [t for t in tables if t["title"].startswith("total force")][-1]["rows"][0]
    assert f[[6, 7]].sum(axis=0) == pytest.approx(total[:2], rel=1e-4, abs=1e-6)
    tr = surface_tractions(deck.points, np.array([[4, 5]]), f)
    # the support pushes down; the contact force on the upper block (its bottom) is up
    assert tr["fy"].sum() * 0.5 == pytest.approx(-total[1], rel=1e-4) and total[1] < 0


def test_script_without_ccx_exits_2(tmp_path):
    env = dict(os.environ, PATH=str(tmp_path))
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / "calculix_cattaneo.py")],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert res.returncode == 2
    assert res.stderr.strip().splitlines() == [
        "error: ccx (CalculiX) not found on PATH; install calculix-ccx"]


def test_deck_pair_type_and_behavior_values():
    deck = two_blocks()
    deck.pair_type, deck.behavior_extra = "NODE TO SURFACE", (0.01, 0.5)
    lines = write_deck(deck).splitlines()
    assert "*CONTACT PAIR, INTERACTION=SI, TYPE=NODE TO SURFACE" in lines
    assert lines[lines.index("*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR") + 1] == \
        "1000000000, 0.01, 0.5"


def test_c3d8_deck_extrudes_the_scene():
    from calculix_c3d8 import write_deck_c3d8

    deck = two_blocks()
    with pytest.raises(ValueError, match="frictionless"):
        write_deck_c3d8(deck)
    deck.mu = 0.0
    lines = write_deck_c3d8(deck).splitlines()
    assert "16, 0, 2, 1" in lines  # node 7 (0-based) at z = 1 is node 8 + 8
    assert "1, 5, 6, 7, 8, 13, 14, 15, 16" in lines  # C3D8 of the upper quad
    # the upper quad's face 0 (corner 0 -> 1) is its C3D8's face S3; the lower's face 2 S5
    assert lines[lines.index("*SURFACE, NAME=SLAVE, TYPE=ELEMENT") + 1] == "1, S3"
    assert lines[lines.index("*SURFACE, NAME=MASTER, TYPE=ELEMENT") + 1] == "2, S5"
    assert lines[lines.index("*NSET, NSET=ZFIX") + 1] == "1, 2, 7, 8, 9, 10, 15, 16"
    assert "*CONTACT PAIR, INTERACTION=SI, TYPE=MORTAR" in lines and "ZFIX, 3, 3, 0." in lines
    assert "TOP, 2, 2, -0.001" in lines and "*FRICTION" not in lines
    # the 2D deck's fixed components and step (increments, printed sets)
    assert "BASE, 1, 1, 0." in lines and "BASE, 2, 2, 0." in lines
    assert lines[lines.index("*STATIC") + 1] == "0.5, 1., 5e-05, 0.5"
    assert "*NODE PRINT, NSET=TOP, TOTALS=YES" in lines and "*CONTACT FILE" in lines
    deck.steps[0].mu = 0.0  # a step's friction would be written: refused
    with pytest.raises(ValueError, match="frictionless"):
        write_deck_c3d8(deck)


@pytest.mark.skipif(shutil.which("ccx") is None, reason="ccx (CalculiX) not installed")
@pytest.mark.parametrize("contact", ["mortar", "face-to-face"])
def test_calculix_indent_runs_and_balances(contact):
    """scripts/calculix_indent.py on configs/indent.toml, both slave sides: CalculiX's slave
    contact force equals its reaction, P within 1% of the app's, and both codes' p stripes
    with the arc (fine) as slave and is smooth with the block (coarse) as slave."""
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / "calculix_indent.py"),
                          "--contact", contact, "--slaves", "arc", "block"], cwd=ROOT,
                         env=dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1"),
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    rows = [json.loads(line) for line in res.stdout.splitlines()]
    assert [r["slave"] for r in rows] == ["arc", "block"]
    for r in rows:
        ours, ccx = r["ours"], r["calculix"]
        for code in (ours, ccx):
            assert {"P", "n_closed", "max_p", "fit_deviation", "fit_deviation_inside", "x",
                    "p"} <= set(code)
        assert ccx["balance"] < 1e-4
        assert ccx["P"] == pytest.approx(ours["P"], rel=0.01)
        stripes = r["slave"] == "arc"
        for code in (ours, ccx):
            assert (code["fit_deviation"] > 0.2) if stripes else (code["fit_deviation"] < 0.06)
