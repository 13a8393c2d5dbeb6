"""configs/*_aligned.toml: the contact edges (and Cattaneo's stick edges) sit on pairs at
every split level, so the floor of the interpolated L2 definitions converges at a steady
order (README "Edges on pairs")."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from support import CONFIGS, read_summary, run_cli

from app.closed_form import INTERPOLATED_L2_RANGE, cattaneo_traction, hertz_pressure
from app.mesh.build import build_mesh
from app.mesh.refine import refine_mesh, scene_arcs
from app.scene import parse_scene
from app.studies.field_breakdown import floor_sequence, orders

A, H0 = 0.01, 0.002  # the scenes' contact half-width and level-0 pair spacing


@pytest.mark.parametrize("config", ["hertz_aligned.toml", "cattaneo_aligned.toml"])
def test_pairs_are_uniform_and_hold_the_edges_at_every_level(config):
    scene = parse_scene(tomllib.loads((CONFIGS / config).read_text()))
    m0 = build_mesh(scene)
    for level in (0, 1, 2):
        m = refine_mesh(m0, level, scene_arcs(scene)) if level else m0
        x = np.sort(m.points[m.curve_nodes("cyl_arc"), 0])
        x = x[np.abs(x) <= INTERPOLATED_L2_RANGE * A + 1e-9]
        h = H0 / 2**level
        np.testing.assert_allclose(np.diff(x), h, rtol=1e-3)  # x = R sin(s / R) ~ s
        for edge in (A, 0.6 * A):  # the contact edge and Cattaneo's stick edge
            # pairs uniform in arc length s: x = R sin(s / R) sits 5e-7 = H0 / 4000 off
            assert np.abs(np.abs(x) - edge).min() < 1e-6


def _floor_orders(offset: float, ratio: float) -> tuple[list[float], list[float]]:
    """Observed orders of the closed-form floors of L2(p) and L2(q) on uniform pairs."""
    x = np.arange(-0.03, 0.03 + 1e-9, H0) + offset * H0
    p0, mu = 549.45, 0.2
    out = []
    for exact in (lambda s: hertz_pressure(s, A, p0),
                  lambda s: cattaneo_traction(s, A, p0, mu, ratio)):
        rows = floor_sequence(x, exact, INTERPOLATED_L2_RANGE * A, 6, 1)
        out.append(orders([r["floor_ref"] for r in rows]))
    return out[0], out[1]


def test_floors_are_steady_with_the_edges_on_pairs_and_not_otherwise():
    for o in _floor_orders(0.0, 0.64):  # a = 5 h0, c = 3 h0
        assert max(o) - min(o) < 0.05 and abs(np.mean(o) - 1.0) < 0.03
    for o in _floor_orders(0.3, 0.64):  # the edges 0.3 h0 off the pairs
        assert max(o) - min(o) > 0.4
    _, oq = _floor_orders(0.0, 0.5)  # c = a / sqrt(2): the stick edge wanders
    assert max(oq) - min(oq) > 0.3


def test_cattaneo_aligned_gives_the_designed_contact(tmp_path):
    res = run_cli(["run", str(CONFIGS / "cattaneo_aligned.toml"), "--refine", "2", "--out",
                   str(tmp_path / "c"), "--quiet"])
    assert res.returncode == 0, res.stderr
    ref = read_summary(tmp_path / "c")["reference"]
    assert abs(ref["hertz"]["a_hertz"] - A) < 2e-3 * A
    assert abs(ref["cattaneo"]["Q_over_muP"] - 0.64) < 0.01
    assert ref["cattaneo"]["stick_half_width_rel_error"] < 0.01
    assert ref["hertz"]["p_max_rel_error"] < 2e-3
