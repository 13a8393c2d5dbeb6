"""The `mortar-bisector` discretisation: the bisector contact normal, and the CalculiX
scene of Cattaneo (README, "Where the tangential-traction error comes from")."""

from __future__ import annotations

import json
import sys

import numpy as np
from support import CONFIGS, ROOT, run_cli
from test_contact_mortar import itf
from test_contact_pairs import stacked

from app.contact.discretisation import DISCRETISATIONS
from app.contact.mortar import mortar_constraints
from app.contact.mortar_bisector import bisector_normal, mortar_bisector_constraints

sys.path.insert(0, str(ROOT / "scripts"))
from calculix_cattaneo import SCENE_SETS  # noqa: E402

CALCULIX_SCENE = [x for s in SCENE_SETS for x in ("--set", s)]


def test_bisector_normal_is_the_mean_whatever_the_curvatures():
    up, tilt = np.array([[0.0, 1.0]]), np.array([[0.6, -0.8]])
    n = bisector_normal(-up, np.array([0.0]), -tilt, np.array([7.0]))
    np.testing.assert_allclose(n[0], (up[0] - tilt[0]) / np.linalg.norm(up[0] - tilt[0]))
    np.testing.assert_allclose(bisector_normal(-tilt, np.array([7.0]), -up, np.array([0.0])),
                               -n)
    assert DISCRETISATIONS["mortar-bisector"] is mortar_bisector_constraints


def test_flat_faces_give_the_mortar_rows():
    """Between flat parallel faces both normals agree: the rows are mortar's."""
    mesh = stacked(5, 7, gap=0.01)
    a, b = mortar_constraints(mesh, itf(), 0), mortar_bisector_constraints(mesh, itf(), 0)
    np.testing.assert_allclose(b.pairs.normal, a.pairs.normal, atol=1e-14)
    np.testing.assert_array_equal(b.cols, a.cols)
    np.testing.assert_allclose(b.g_normal, a.g_normal, atol=1e-14)
    np.testing.assert_allclose(b.g_tangent, a.g_tangent, atol=1e-14)


def test_calculix_scene_q_close_to_cattaneo_mindlin(tmp_path):
    """README: L2(q) 5.8% at a/20 with symmetric stick edges (mortar: 25.3%, edges
    [-0.0765, 0.0617] around the exact +-0.0714)."""
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "cattaneo.toml"), "--out", str(out), "--quiet",
                   "--set", 'interface.contact.discretisation="mortar-bisector"',
                   *CALCULIX_SCENE])
    assert res.returncode == 0, res.stderr
    c = json.loads((out / "summary.json").read_text())["reference"]["cattaneo"]
    assert c["traction_l2_interp_rel_error"] < 0.07
    left, right = c["stick_edges"]
    assert abs(left + right) < 0.005  # within one contact element (0.005)
    assert abs(right - c["stick_half_width_exact"]) < 0.005
