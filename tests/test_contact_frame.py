"""Mortar rows in a turned frame: straight sides read flat at any angle and position, and
a flat-on-flat interface at an angle (a tilted block on a foundation) gets the turned
normals (issue 10's contact normal weights the sides by their curvatures)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from test_contact_pairs import rotate, stacked

from app.contact.discretisation import DISCRETISATIONS
from app.contact.mortar import nodal_normals
from app.mesh.model import Mesh


def itf():
    return SimpleNamespace(name="t", slave="up_bottom", master="low_top", search_distance=0.1,
                           penetration_tol=None, interference=False)


@pytest.mark.parametrize("deg", [0.0, 17.0, 30.0, -41.0])
@pytest.mark.parametrize("shift", [0.0, 1e4])
def test_straight_side_has_zero_curvature(deg, shift):
    t = np.radians(deg)
    x = np.linspace(-0.5, 0.5, 21)
    pts = np.column_stack([x * np.cos(t), x * np.sin(t)]) + shift
    edges = np.column_stack([np.arange(20), np.arange(1, 21)])
    nu, kappa = nodal_normals(pts, edges, 21)
    assert np.all(kappa == 0.0)
    np.testing.assert_allclose(nu, np.tile([np.sin(t), -np.cos(t)], (21, 1)), atol=1e-12)


def test_circle_curvature():
    th = np.linspace(0.0, np.pi, 41)
    pts = 2.0 * np.column_stack([np.cos(th), np.sin(th)])
    edges = np.column_stack([np.arange(40), np.arange(1, 41)])[:, ::-1]  # body inside
    _, kappa = nodal_normals(pts, edges, 41)
    assert kappa[0] == 0.0 and kappa[-1] == 0.0
    np.testing.assert_allclose(kappa[1:-1], 0.5, rtol=1e-3)


def tilted(deg: float) -> Mesh:
    """stacked(5, 7) with the upper block's bottom tilted by 1.1 deg (touching at x = 0),
    turned by `deg` about (0.3, -0.2)."""
    mesh = stacked(5, 7, gap=0.0)
    up = mesh.node_body() == 1
    pts = mesh.points.copy()
    pts[up, 1] += 0.02 * pts[up, 0]
    return rotate(Mesh(pts, mesh.quads, mesh.body, mesh.body_names, mesh.curves), deg)


@pytest.mark.parametrize("name", [n for n in DISCRETISATIONS if n != "node-to-segment"])
@pytest.mark.parametrize("deg", [30.0, -17.0, 90.0])
def test_flat_on_flat_at_an_angle_is_frame_independent(name, deg):
    build = DISCRETISATIONS[name]
    a = build(tilted(0.0)[0], itf(), 0)
    rmesh, r = tilted(deg)
    b = build(rmesh, itf(), 0)
    np.testing.assert_allclose(b.pairs.normal, a.pairs.normal @ r.T, atol=1e-12)
    np.testing.assert_allclose(b.pairs.g0, a.pairs.g0, atol=1e-13)
    np.testing.assert_allclose(b.g_normal, a.g_normal @ np.kron(np.eye(a.g_normal.shape[1]
                                                                        // 2), r.T),
                               atol=1e-12)


@pytest.mark.parametrize("name", list(DISCRETISATIONS))
def test_partly_covered_slave_node_gets_its_covered_length(name):
    """A wider slave (the foundation) under a narrower master: the slave nodes at the
    master's ends face it over half their tributary length. Their pair length (the
    divisor of p, and the length that multiplies the bond strength c and adhesion a) is
    that half, so the lengths add up to the contact length; it was the whole tributary
    length (0.75 for a block 0.5 wide), which doubled the strength of the bond's edge
    pair and halved its p. Node-to-segment kept the whole tributary length until helper
    `hunt2` (bonded.toml swapped: bond force 8.4 for c x 2 = 8, first debond at step 12)."""
    mesh = stacked(4, 3, x_up=(0.25, 0.75), x_low=(0.0, 1.0))
    spec = SimpleNamespace(name="t", slave="low_top", master="up_bottom", search_distance=0.1,
                           penetration_tol=None, interference=False)
    rows = DISCRETISATIONS[name](mesh, spec, 0)
    x = rows.pairs.position[:, 0]
    np.testing.assert_allclose(np.sort(x), [0.25, 0.5, 0.75])
    np.testing.assert_allclose(rows.pairs.length[np.argsort(x)], [0.125, 0.25, 0.125])


def moved(shift) -> Mesh:
    """stacked(4, 8) with the upper block's bottom tilted by 1/64 (touching at x = 0),
    moved by `shift`. Every coordinate is a multiple of 1/512, so the moved points are
    exact (moved - shift == unmoved bit for bit): the scene is the same geometry, and
    any difference in its rows is the contact code's own round-off."""
    mesh = stacked(4, 8, gap=0.0)
    up = mesh.node_body() == 1
    pts = mesh.points.copy()
    pts[up, 1] += pts[up, 0] / 64
    return Mesh(pts + np.asarray(shift, dtype=float), mesh.quads, mesh.body,
                mesh.body_names, mesh.curves)


@pytest.mark.parametrize("name", list(DISCRETISATIONS))
@pytest.mark.parametrize("shift", [(1e6, 3e5), (1e8, -3e7)])
def test_moved_scene_gives_the_same_rows(name, shift):
    """The mortar integrals come from coordinate differences: moved by 1e6, g0 differed
    by 5.7e-11 (3.7e-9 of g0), the weights of G by 1.7e-10 (the Gauss points' eta and the
    weighted gap x_j - sum w x_l were formed from absolute coordinates); now to 1e-12 of
    their size (bit for bit on this scene)."""
    a = DISCRETISATIONS[name](moved((0.0, 0.0)), itf(), 0)
    mesh = moved(shift)
    assert np.array_equal(mesh.points - np.asarray(shift), moved((0.0, 0.0)).points)
    b = DISCRETISATIONS[name](mesh, itf(), 0)
    g_scale = np.abs(a.pairs.g0).max()
    assert g_scale > 0.01
    np.testing.assert_allclose(b.pairs.g0, a.pairs.g0, rtol=0, atol=1e-12 * g_scale)
    np.testing.assert_allclose(b.g_normal, a.g_normal, rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.g_tangent, a.g_tangent, rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.pairs.normal, a.pairs.normal, rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.pairs.length, a.pairs.length, rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.pairs.position - np.asarray(shift), a.pairs.position,
                               rtol=0, atol=0)
