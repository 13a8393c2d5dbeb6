"""Tests of the node-to-segment contact pairs (app/contact/pairs.py)."""

from __future__ import annotations

import numpy as np
import pytest

from app.contact.pairs import (
    ContactPairs,
    closest_segments,
    constraint_matrix,
    contact_pairs,
    tributary_length,
)
from app.errors import InputError
from app.mesh.model import Mesh


def block(xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
    """Structured quad grid on the tensor product xs x ys (CCW quads).

    Returns points, quads, curves {bottom, top, left, right} with local node indices.
    Edge node order is deliberately mixed (not the element order) to test orientation.
    """
    nx, ny = len(xs), len(ys)
    X, Y = np.meshgrid(xs, ys, indexing="xy")  # (ny, nx)
    pts = np.column_stack([X.ravel(), Y.ravel()])
    idx = np.arange(nx * ny).reshape(ny, nx)
    quads = np.column_stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(),
                             idx[1:, 1:].ravel(), idx[1:, :-1].ravel()])
    curves = {
        "bottom": np.column_stack([idx[0, :-1], idx[0, 1:]]),
        "top": np.column_stack([idx[-1, :-1], idx[-1, 1:]]),
        "left": np.column_stack([idx[1:, 0], idx[:-1, 0]]),
        "right": np.column_stack([idx[:-1, -1], idx[1:, -1]]),
    }
    return pts, quads, curves


def scene(blocks: dict[str, tuple[np.ndarray, np.ndarray, dict]]) -> Mesh:
    """One Mesh of several bodies; curves are named '<body>_<side>'."""
    pts, quads, body, curves, off = [], [], [], {}, 0
    for b, (name, (p, q, c)) in enumerate(blocks.items()):
        pts.append(p)
        quads.append(q + off)
        body.append(np.full(len(q), b))
        for side, e in c.items():
            curves[f"{name}_{side}"] = e + off
        off += len(p)
    return Mesh(np.vstack(pts), np.vstack(quads), np.concatenate(body), list(blocks), curves)


def stacked(nx_low: int, nx_up: int, gap: float = 0.0, x_up=(0.0, 1.0), x_low=(0.0, 1.0),
            ny: int = 2) -> Mesh:
    """Lower block x_low x [-0.5, 0], upper block x_up x [gap, 0.5 + gap]."""
    low = block(np.linspace(*x_low, nx_low + 1), np.linspace(-0.5, 0.0, ny + 1))
    up = block(np.linspace(*x_up, nx_up + 1), np.linspace(gap, 0.5 + gap, ny + 1))
    return scene({"low": low, "up": up})


def up_field(mesh: Mesh, vec) -> np.ndarray:
    """(2 n_nodes,) displacement: `vec` on the upper body's nodes, zero elsewhere."""
    u = np.zeros((mesh.n_nodes, 2))
    u[mesh.node_body() == 1] = vec
    return u.ravel()


def rotate(mesh: Mesh, deg: float, centre=(0.3, -0.2)) -> tuple[Mesh, np.ndarray]:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    r = np.array([[c, -s], [s, c]])
    pts = (mesh.points - centre) @ r.T + centre
    return Mesh(pts, mesh.quads, mesh.body, mesh.body_names, mesh.curves), r


def test_matching_blocks():
    mesh = stacked(4, 4)
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.1)
    assert p.n_pairs == 5
    assert set(np.round(p.xi, 12)) <= {0.0, 1.0}
    np.testing.assert_allclose(p.g0, 0.0, atol=1e-15)
    np.testing.assert_allclose(p.normal, np.tile([0.0, 1.0], (5, 1)))
    np.testing.assert_allclose(p.tangent, np.tile([-1.0, 0.0], (5, 1)))
    # the projection is a master node at the slave's position
    xp = (1 - p.xi)[:, None] * mesh.points[p.master[:, 0]] + p.xi[:, None] * mesh.points[
        p.master[:, 1]]
    np.testing.assert_allclose(xp, p.position, atol=1e-15)
    np.testing.assert_allclose(p.length, [0.125, 0.25, 0.25, 0.25, 0.125])
    # the master body's element is on the left of A -> B
    nb = mesh.node_body()
    assert np.all(nb[p.master] == 0) and np.all(nb[p.slave] == 1)
    assert np.all(p.interface == 0)


def test_non_matching_interpolation_and_G():
    mesh = stacked(5, 7)
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.1, interface=3)
    assert p.n_pairs == 8 and np.all(p.interface == 3)
    x = p.position[:, 0]
    a, b = mesh.points[p.master[:, 0], 0], mesh.points[p.master[:, 1], 0]
    np.testing.assert_allclose((1 - p.xi) * a + p.xi * b, x, atol=1e-14)
    assert np.all((p.xi >= 0) & (p.xi <= 1))
    np.testing.assert_allclose(p.length.sum(), 1.0)

    g = constraint_matrix(p, mesh.n_nodes)
    assert g.shape == (16, 2 * mesh.n_nodes)
    m = p.n_pairs
    # rigid translation and small rigid rotation of everything: no relative displacement
    np.testing.assert_allclose(g @ np.tile([0.3, -0.7], mesh.n_nodes), 0.0, atol=1e-14)
    rot = np.column_stack([-mesh.points[:, 1], mesh.points[:, 0]]).ravel() * 1e-3
    np.testing.assert_allclose(g @ rot, 0.0, atol=1e-15)
    # uniform separation of the upper block
    delta = 0.01
    gu = g @ up_field(mesh, [0.0, delta])
    np.testing.assert_allclose(gu[:m], delta)
    np.testing.assert_allclose(gu[m:], 0.0, atol=1e-16)
    # uniform sliding of the upper block in +x: t = (-1, 0), so the slip t . d = -slide
    slide = 0.02
    gu = g @ up_field(mesh, [slide, 0.0])
    np.testing.assert_allclose(gu[:m], 0.0, atol=1e-16)
    np.testing.assert_allclose(gu[m:], -slide)
    # same slide of the lower (master) block: opposite sign
    u = np.zeros((mesh.n_nodes, 2))
    u[mesh.node_body() == 0] = [slide, 0.0]
    np.testing.assert_allclose((g @ u.ravel())[m:], slide)


def test_G_entries_match_definition():
    mesh = stacked(3, 5, gap=0.01)
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.1)
    g = constraint_matrix(p, mesh.n_nodes).toarray()
    rng = np.random.default_rng(0)
    u = rng.normal(size=(mesh.n_nodes, 2))
    d = u[p.slave] - (1 - p.xi)[:, None] * u[p.master[:, 0]] - p.xi[:, None] * u[p.master[:, 1]]
    gu = g @ u.ravel()
    np.testing.assert_allclose(gu[:p.n_pairs], np.sum(p.normal * d, axis=1))
    np.testing.assert_allclose(gu[p.n_pairs:], np.sum(p.tangent * d, axis=1))


def test_master_above_slave():
    """Swapping roles: master on top has n = (0, -1), t = (1, 0)."""
    mesh = stacked(5, 3, gap=0.02)
    p = contact_pairs(mesh, "low_top", "up_bottom", 0.1)
    np.testing.assert_allclose(p.normal, np.tile([0.0, -1.0], (p.n_pairs, 1)))
    np.testing.assert_allclose(p.tangent, np.tile([1.0, 0.0], (p.n_pairs, 1)))
    np.testing.assert_allclose(p.g0, 0.02)


def test_initial_gap_kept_and_search_distance():
    mesh = stacked(4, 6, gap=0.05)
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.1)
    assert p.n_pairs == 7
    np.testing.assert_allclose(p.g0, 0.05)
    with pytest.raises(InputError, match=r"no slave node of 'up_bottom' lies within "
                                         r"search_distance=0.01 of 'low_top'"):
        contact_pairs(mesh, "up_bottom", "low_top", 0.01, name="c1")


def test_search_distance_filter_on_tilted_slave():
    mesh = stacked(10, 10)
    up = mesh.node_body() == 1
    mesh.points[up, 1] += 0.1 * mesh.points[up, 0]  # gap grows linearly from 0 to 0.1
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.045)
    np.testing.assert_allclose(np.sort(p.position[:, 0]), [0.0, 0.1, 0.2, 0.3, 0.4])
    np.testing.assert_allclose(p.g0, 0.1 * p.position[:, 0], atol=1e-15)


def test_penetration_raises():
    mesh = stacked(4, 4, gap=-0.01)
    with pytest.raises(InputError) as err:
        contact_pairs(mesh, "up_bottom", "low_top", 0.1, name="contact")
    msg = str(err.value)
    assert "\n" not in msg
    assert msg.startswith("interface 'contact': 5 slave nodes penetrate the master by more")
    assert "x=0, y=-0.01" in msg and "penetration_tol" in msg
    # a tolerance above the overlap accepts it, with the negative gap kept
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.1, penetration_tol=0.02)
    np.testing.assert_allclose(p.g0, -0.01)
    # tiny overlaps below the scale-aware default are accepted
    p = contact_pairs(stacked(4, 4, gap=-1e-9), "up_bottom", "low_top", 0.1)
    np.testing.assert_allclose(p.g0, -1e-9)


def test_slave_beyond_shorter_master_dropped():
    mesh = stacked(5, 8, x_up=(-0.3, 1.3))
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.1)
    x = np.sort(p.position[:, 0])
    np.testing.assert_allclose(x, np.linspace(-0.3, 1.3, 9)[2:7])
    # with the master's sides in the master curve, the outer nodes pair with the sides
    mesh.curves["low_ts"] = np.vstack([mesh.curves["low_top"], mesh.curves["low_left"],
                                       mesh.curves["low_right"]])
    p = contact_pairs(mesh, "up_bottom", "low_ts", 0.25)
    out = np.abs(p.position[:, 0] - 0.5) > 0.5
    assert out.sum() == 2
    np.testing.assert_allclose(np.abs(p.normal[out, 0]), 1.0)
    np.testing.assert_allclose(p.g0[out], 0.1, atol=1e-12)
    np.testing.assert_allclose(p.g0[~out], 0.0, atol=1e-15)


def test_slave_end_aligned_with_master_end_kept():
    mesh = stacked(3, 7)
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.1)
    assert p.n_pairs == 8


@pytest.mark.parametrize("deg", [0.0, 30.0, -89.99])
@pytest.mark.parametrize("x_up, nx_up, expect", [
    ((-0.25, 1.25), 6, [0.125, 0.25, 0.25, 0.25, 0.125]),  # master ends at slave nodes
    ((-0.3, 1.3), 4, [0.3, 0.4, 0.3]),  # master ends inside the slave's half edges
    # master ends between an edge's midpoint and its (dropped) outer node: the end
    # pairs count up to the ends (they read 0.3 each, 0.9 in all, before)
    ((-0.1, 1.1), 4, [0.35, 0.3, 0.35]),
])
def test_overhanging_slave_counts_only_the_length_facing_the_master(deg, x_up, nx_up, expect):
    """A slave wider than its master: the half edges of the kept end nodes that lie
    beyond the master's free ends face nothing, so the pair lengths (the divisor of p and
    the multiplier of c and a) add up to the master's width 1; they were the whole
    tributary lengths (1.5 and 1.4), as with mortar before its covered length."""
    mesh, _ = rotate(stacked(5, nx_up, x_up=x_up), deg)
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.1)
    order = np.argsort(rotate(Mesh(p.position, mesh.quads[:0], mesh.body[:0], [], {}),
                              -deg)[0].points[:, 0])
    np.testing.assert_allclose(p.length[order], expect, atol=1e-12)
    np.testing.assert_allclose(p.length.sum(), 1.0, atol=1e-12)


def test_tributary_lengths_sum_to_curve_length():
    rng = np.random.default_rng(1)
    xs = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0, 1, 11)]))
    mesh = scene({"low": block(np.linspace(0, 1, 4), np.linspace(-1, 0, 3)),
                  "up": block(xs, np.linspace(0, 1, 3))})
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.1)
    assert p.n_pairs == 13
    np.testing.assert_allclose(p.length.sum(), 1.0)
    order = np.argsort(p.position[:, 0])
    h = np.diff(xs)
    expect = 0.5 * (np.concatenate([[0], h]) + np.concatenate([h, [0]]))
    np.testing.assert_allclose(p.length[order], expect)
    nodes, length = tributary_length(mesh.points, mesh.curves["up_bottom"])
    np.testing.assert_allclose(length.sum(), 1.0)
    assert nodes.size == 13


def curved_scene(n_arc: int = 24, n_flat: int = 17, half_angle: float = 0.6) -> Mesh:
    """Master: a curved strip of quads between radii 0.8 and 1 around the bottom of the unit
    circle (the 'arc' curve is the r = 1 polygon, with a node at (0, -1)). Slave: a flat
    block below, top at y = -1, touching the circle at x = 0."""
    th = -np.pi / 2 + np.linspace(-half_angle, half_angle, n_arc + 1)
    r = np.array([0.8, 1.0])
    pts = np.column_stack([(r[:, None] * np.cos(th)).ravel(), (r[:, None] * np.sin(th)).ravel()])
    idx = np.arange(2 * (n_arc + 1)).reshape(2, n_arc + 1)
    # CCW: outer ring (r = 1) is below the inner one at the bottom of the circle
    quads = np.column_stack([idx[1, :-1], idx[1, 1:], idx[0, 1:], idx[0, :-1]])
    arc = {"arc": np.column_stack([idx[1, :-1], idx[1, 1:]])}
    flat = block(np.linspace(-0.45, 0.45, n_flat), np.linspace(-1.3, -1.0, 3))
    return scene({"disk": (pts, quads, arc), "flat": flat})


def test_curved_master():
    mesh = curved_scene()
    p = contact_pairs(mesh, "flat_top", "disk_arc", 0.2)
    assert p.n_pairs == 17
    # brute force: every slave node against every chord
    pa, pb = mesh.points[mesh.curves["disk_arc"][:, 0]], mesh.points[mesh.curves["disk_arc"][:, 1]]
    for i, s in enumerate(p.position):
        xi = np.clip(np.sum((s - pa) * (pb - pa), 1) / np.sum((pb - pa) ** 2, 1), 0, 1)
        d = np.linalg.norm(s - pa - xi[:, None] * (pb - pa), axis=1)
        j = np.argmin(d)
        assert set(p.master[i]) == set(mesh.curves["disk_arc"][j])
        # outward normal of the chord = direction of its midpoint from the centre
        mid = 0.5 * (pa[j] + pb[j])
        n = mid / np.linalg.norm(mid)
        np.testing.assert_allclose(p.normal[i], n, atol=1e-14)
        # gap = distance from the slave node to the chord's line along the normal
        np.testing.assert_allclose(p.g0[i], n @ s - np.linalg.norm(mid), atol=1e-14)
    assert np.all(p.g0 >= -1e-15)
    np.testing.assert_allclose(p.g0[np.argmin(np.abs(p.position[:, 0]))], 0.0, atol=1e-15)
    # tangent: master on the left of A -> B, n = (t_y, -t_x)
    np.testing.assert_allclose(p.normal, np.column_stack([p.tangent[:, 1], -p.tangent[:, 0]]))


@pytest.mark.parametrize("which", ["stacked", "curved"])
def test_rotation_invariance(which):
    if which == "stacked":
        mesh, args = stacked(5, 7, gap=0.01), ("up_bottom", "low_top", 0.1)
    else:
        mesh, args = curved_scene(), ("flat_top", "disk_arc", 0.2)
    p = contact_pairs(mesh, *args)
    rmesh, r = rotate(mesh, 37.0)
    q = contact_pairs(rmesh, *args)
    np.testing.assert_array_equal(p.slave, q.slave)
    np.testing.assert_array_equal(p.master, q.master)
    np.testing.assert_allclose(q.xi, p.xi, atol=1e-12)
    np.testing.assert_allclose(q.g0, p.g0, atol=1e-12)
    np.testing.assert_allclose(q.normal, p.normal @ r.T, atol=1e-12)
    np.testing.assert_allclose(q.tangent, p.tangent @ r.T, atol=1e-12)
    np.testing.assert_allclose(q.length, p.length, atol=1e-12)


def test_convex_corner_tie_breaks_towards_facing_segment():
    """Point off a convex corner: equal distance to both edges, pick the facing one."""
    xa = np.array([[1.0, 0.0], [1.0, -1.0]])
    xb = np.array([[0.0, 0.0], [1.0, 0.0]])
    x = np.array([[1.1, 0.0], [1.0, 0.1], [1.1, 0.1]])
    seg, xr, dist = closest_segments(x, xa, xb, 1.0)
    np.testing.assert_array_equal(seg[:2], [1, 0])
    np.testing.assert_allclose(dist, [0.1, 0.1, np.hypot(0.1, 0.1)])
    assert seg[2] == 0  # a true tie in excursion: lowest segment index


def test_closest_segments_long_and_short_segments():
    """A long segment next to many short ones: the k-nearest query must be widened."""
    xs = np.linspace(0, 1, 201)
    xa = np.vstack([np.column_stack([xs[:-1], np.zeros(200)]), [[0.0, 0.3]]])
    xb = np.vstack([np.column_stack([xs[1:], np.zeros(200)]), [[10.0, 0.3]]])
    x = np.array([[5.0, 0.25], [0.5, 0.2], [0.5025, 0.1]])
    seg, xr, dist = closest_segments(x, xa, xb, 1.0)
    np.testing.assert_array_equal(seg, [200, 200, 100])
    np.testing.assert_allclose(dist, [0.05, 0.1, 0.1])
    seg, _, dist = closest_segments(x, xa, xb, 0.01)
    np.testing.assert_array_equal(seg, [-1, -1, -1])


@pytest.mark.parametrize("sigma", [0.3, 2.0])
def test_closest_segments_brute_force(sigma):
    """Random wavy polyline with very uneven segment lengths against brute force."""
    rng = np.random.default_rng(5)
    x = np.cumsum(rng.lognormal(0, sigma, 400))
    x /= x[-1]
    pts = np.column_stack([x, 0.05 * np.sin(7 * x) + 0.01 * rng.normal(size=x.size)])
    xa, xb = pts[:-1], pts[1:]
    q = rng.uniform([-0.1, -0.2], [1.1, 0.2], size=(1500, 2))
    sd = 0.08
    seg, xr, dist = closest_segments(q, xa, xb, sd)
    ab = xb - xa
    t = np.clip(np.einsum("qsj,sj->qs", q[:, None] - xa, ab) / np.sum(ab**2, 1), 0, 1)
    d = np.linalg.norm(q[:, None] - xa - t[..., None] * ab, axis=2).min(1)
    np.testing.assert_array_equal(seg >= 0, d <= sd)
    ok = seg >= 0
    np.testing.assert_allclose(dist[ok], d[ok], rtol=1e-8)
    xp = xa[seg[ok]] + np.clip(xr[ok], 0, 1)[:, None] * ab[seg[ok]]
    np.testing.assert_allclose(np.linalg.norm(q[ok] - xp, axis=1), dist[ok], rtol=1e-12)


def test_same_body_different_curves_allowed():
    mesh = stacked(3, 4)
    mesh.body[:] = 0
    mesh.body_names = ["one"]
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.1)
    assert p.n_pairs == 5


def test_shared_nodes_skipped():
    """Slave nodes that are master-curve nodes (a corner of one body) are not paired."""
    mesh = stacked(4, 4, gap=0.02)
    # the only slave node within reach is the shared top-right corner: skipped, no pair
    with pytest.raises(InputError, match="no slave node of 'low_right'"):
        contact_pairs(mesh, "low_right", "low_top", 0.1)
    mesh.curves["low_both"] = np.vstack([mesh.curves["low_top"], mesh.curves["low_right"]])
    p = contact_pairs(mesh, "up_bottom", "low_both", 0.1)
    assert p.n_pairs == 5
    np.testing.assert_allclose(p.normal, np.tile([0.0, 1.0], (5, 1)))


def test_errors():
    mesh = stacked(3, 4)
    with pytest.raises(InputError, match=r"slave curve 'nope' is not in the mesh \(available "
                                         r"curves: 'low_bottom'"):
        contact_pairs(mesh, "nope", "low_top", 0.1)
    with pytest.raises(InputError, match=r"master curve 'nada' is not in the mesh"):
        contact_pairs(mesh, "up_bottom", "nada", 0.1)
    with pytest.raises(InputError, match=r"interface 'c': slave and master are the same curve"):
        contact_pairs(mesh, "up_bottom", "up_bottom", 0.1, name="c")
    for bad in (0.0, -1.0, np.inf, np.nan):
        with pytest.raises(InputError, match="search_distance must be a positive length"):
            contact_pairs(mesh, "up_bottom", "low_top", bad)
    with pytest.raises(InputError, match="penetration_tol must be a non-negative"):
        contact_pairs(mesh, "up_bottom", "low_top", 0.1, penetration_tol=-1.0)
    mesh.curves["inner"] = np.array([[mesh.quads[0, 1], mesh.quads[0, 2]]])
    with pytest.raises(InputError, match="interior edges shared by two elements"):
        contact_pairs(mesh, "up_bottom", "inner", 0.1)
    mesh.curves["diag"] = np.array([[mesh.quads[0, 0], mesh.quads[0, 2]]])
    with pytest.raises(InputError, match="are not element edges"):
        contact_pairs(mesh, "up_bottom", "diag", 0.1)
    mesh.curves["empty"] = np.zeros((0, 2), dtype=int)
    with pytest.raises(InputError, match="must be a non-empty"):
        contact_pairs(mesh, "empty", "low_top", 0.1)
    mesh.curves["far"] = np.array([[0, 10**6]])
    with pytest.raises(InputError, match="refers to nodes outside"):
        contact_pairs(mesh, "far", "low_top", 0.1)


def test_clockwise_owner_still_outward():
    """An element listed clockwise: the normal still points out of the master body."""
    mesh = stacked(4, 4, gap=0.01)
    mesh.quads[mesh.body == 0] = mesh.quads[mesh.body == 0][:, ::-1]
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.1)
    np.testing.assert_allclose(p.normal, np.tile([0.0, 1.0], (5, 1)))
    np.testing.assert_allclose(p.g0, 0.01)


def test_select_and_concatenate():
    mesh = stacked(4, 6, gap=0.01)
    a = contact_pairs(mesh, "up_bottom", "low_top", 0.1, interface=0)
    b = contact_pairs(mesh, "low_top", "up_bottom", 0.1, interface=1)
    c = ContactPairs.concatenate([a, b])
    assert c.n_pairs == a.n_pairs + b.n_pairs == len(c)
    np.testing.assert_array_equal(c.interface, [0] * a.n_pairs + [1] * b.n_pairs)
    s = c.select(c.interface == 1)
    np.testing.assert_array_equal(s.slave, b.slave)
    np.testing.assert_allclose(s.normal, b.normal)
    s2 = c.select(np.array([0, 2]))
    assert s2.n_pairs == 2 and s2.master.shape == (2, 2)
    e = ContactPairs.concatenate([])
    assert e.n_pairs == 0 and e.master.shape == (0, 2)
    g = constraint_matrix(e, mesh.n_nodes)
    assert g.shape == (0, 2 * mesh.n_nodes)
    with pytest.raises(ValueError):
        c.select(np.ones(3, dtype=bool))


def strips(n_slave: int, n_master: int) -> Mesh:
    """Two one-element-thick strips on [0, 1], the upper one with n_slave elements."""
    low = block(np.linspace(0, 1, n_master + 1), np.array([-0.01, 0.0]))
    up = block(np.linspace(0, 1, n_slave + 1), np.array([0.0, 0.01]))
    return scene({"low": low, "up": up})


def test_vectorised_large_search():
    """200,000 pairs on non-matching strips come out right (its speed is a benchmark's:
    the `pair_search` phase of `scripts/bench_scale.py`, not a timed test: the machines
    are shared and noisy)."""
    mesh = strips(200_000 - 1, 150_000)
    p = contact_pairs(mesh, "up_bottom", "low_top", 1e-3)
    g = constraint_matrix(p, mesh.n_nodes)
    assert p.n_pairs == 200_000
    np.testing.assert_allclose(p.g0, 0.0, atol=1e-15)
    np.testing.assert_allclose(p.length.sum(), 1.0)
    x = (1 - p.xi) * mesh.points[p.master[:, 0], 0] + p.xi * mesh.points[p.master[:, 1], 0]
    np.testing.assert_allclose(x, p.position[:, 0], atol=1e-14)
    assert g.shape == (400_000, 2 * mesh.n_nodes)


def test_one_slave_on_two_masters_meeting_inside_an_edge_counts_all_of_it():
    """A slave curve over two masters side by side, [0, 1] and [1, 2], meeting inside a
    slave edge (nodes at 0.9 and 1.2): each interface's lengths reach the joint, so each
    adds up to its master's width 1. Before, the second read 0.9: the parts between the
    joint and the edge's midpoint (1.05), and between 1.95 and its far end 2 (the slave
    node at 2.1 is dropped), counted for no node."""
    low_a = block(np.linspace(0.0, 1.0, 5), np.linspace(-0.5, 0.0, 3))
    low_b = block(np.linspace(1.0, 2.0, 5), np.linspace(-0.5, 0.0, 3))
    up = block(np.linspace(0.0, 2.1, 8), np.linspace(0.0, 0.5, 3))
    mesh = scene({"a": low_a, "b": low_b, "up": up})
    pa = contact_pairs(mesh, "up_bottom", "a_top", 0.1)
    pb = contact_pairs(mesh, "up_bottom", "b_top", 0.1)
    assert pa.n_pairs + pb.n_pairs == 7
    np.testing.assert_allclose(pa.length.sum(), 1.0, atol=1e-12)
    np.testing.assert_allclose(pb.length.sum(), 1.0, atol=1e-12)


def corner_scene(f: float, gap: float, deg: float) -> tuple[Mesh, int]:
    """A slave of 5 edges of 0.2 (bottom of the upper block) whose left node lies f x 0.2
    beyond the left end of a master of 4 edges of 0.25 on [0, 1] (the lower block's
    top), the slave gap above the master's line (negative: an overlap), turned by deg;
    the mesh and the slave's left node."""
    low = block(np.linspace(0.0, 1.0, 5), np.linspace(-0.5, 0.0, 3))
    up = block(-0.2 * f + 0.2 * np.arange(6), np.linspace(gap, 0.5 + gap, 3))
    mesh, _ = rotate(scene({"low": low, "up": up}), deg)
    return mesh, low[0].shape[0]


@pytest.mark.parametrize("deg", [0.0, 30.0, -89.99])
@pytest.mark.parametrize("f", [1e-5, 1e-3, 0.1, 0.29, 0.3, 0.5])
def test_overlapping_slave_node_just_beyond_a_master_end_pairs_with_the_end(deg, f):
    """A slave node beyond a free master end that overlaps the end segment's line pairs
    with that segment (xi at the end, g0 its distance to the line) when it faces the
    master over at least half its support, int_cov N ds = 0.1 (1 - f)^2 >= 0.05, i.e.
    f <= 1 - 1/sqrt(2) = 0.293, the rule of mortar's rows: its length is its half edge up
    to the end's line. Before, a node beyond the end by more than XI_EPS had no pair
    (f = 1e-5: 8e-6 of the end segment) and its overlap of 0.002 was ignored without a
    word (a tilted interference fit ran with it where mortar refused it). Beyond that
    cover its neighbour's length reaches the end's line, as before; either way the
    lengths add up to the covered length 1 - 0.2 f."""
    mesh, corner = corner_scene(f, -0.002, deg)
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.1, interference=True)
    np.testing.assert_allclose(p.length.sum(), 1.0 - 0.2 * f, atol=1e-12)
    at = np.flatnonzero(p.slave == corner)
    if f > 1.0 - np.sqrt(0.5):
        assert at.size == 0
        return
    assert at.size == 1
    (i,) = at
    assert p.xi[i] in (0.0, 1.0)
    np.testing.assert_allclose(p.g0[i], -0.002, atol=1e-12)
    np.testing.assert_allclose(p.length[i], 0.1 - 0.2 * f, atol=1e-12)
    np.testing.assert_allclose(p.g0, -0.002, atol=1e-12)


@pytest.mark.parametrize("gap", [0.002, 0.0, -1e-9])
def test_open_or_touching_slave_node_beyond_a_master_end_stays_unpaired(gap):
    """Open, touching, or overlapping within penetration_tol: nothing to push out, so a
    slave node beyond a free master end stays without a pair, as before."""
    mesh, corner = corner_scene(0.1, gap, 30.0)
    p = contact_pairs(mesh, "up_bottom", "low_top", 0.1)
    assert corner not in p.slave
    np.testing.assert_allclose(p.length.sum(), 0.98, atol=1e-12)


def test_overlap_beyond_a_master_end_without_interference_is_refused_naming_the_node():
    """Without `interference` the overlapping node beyond the end is a penetration like
    any other, named in the error (before: no pair, the run went on with it)."""
    mesh, _ = corner_scene(0.1, -0.002, 0.0)
    with pytest.raises(InputError, match=r"6 slave nodes penetrate .*first at x=-0.02, "
                       r"y=-0.002"):
        contact_pairs(mesh, "up_bottom", "low_top", 0.1, name="c")


def _slave_corner_beside_a_block_corner(slope: float, deg: float):
    """A block [0, 1] x [-0.5, 0] and an upper block whose bottom corner lies 0.02 beyond
    the lower one's end and 0.002 below its top's line, the bottom rising with `slope`;
    the scene turned by `deg`: the mesh and the slave corner's node (the upper block's first)."""
    low = block(np.linspace(0.0, 1.0, 5), np.linspace(-0.5, 0.0, 3))
    pts, quads, curves = block(-0.02 + 0.2 * np.arange(6), np.linspace(0.0, 0.5, 3))
    pts = pts.copy()
    bottom = pts[:, 1] == 0.0
    pts[bottom, 1] = -0.002 + slope * (pts[bottom, 0] + 0.02)
    mesh, _ = rotate(scene({"low": low, "up": (pts, quads, curves)}), deg)
    return mesh, low[0].shape[0]


@pytest.mark.parametrize("deg", [0.0, 30.0])
@pytest.mark.parametrize("slope", [0.1, 0.5])
def test_slave_end_below_the_end_line_whose_edge_clears_the_master_stays_unpaired(slope, deg):
    """A slave corner 0.02 beyond the master's end (a block corner) and 0.002 below the
    end segment's line, its edge rising with `slope` so that it reaches the master at the
    end's line at y = 0 (slope 0.1: touching the corner) or above it (0.5: 0.008 clear):
    the corner lies beside the master body, not in it, and no part of the slave overlaps
    it, so it gets no pair and nothing is refused (before: paired with g0 = -0.002,
    refused as a penetration, and with interference pushed out by 0.002)."""
    mesh, corner = _slave_corner_beside_a_block_corner(slope, deg)
    for interference in (False, True):
        p = contact_pairs(mesh, "up_bottom", "low_top", 0.1, interference=interference)
        assert corner not in p.slave
        assert p.g0.min() >= 0.0
        if slope == 0.1:  # the slave's length over the master, x in [0, 0.98]
            np.testing.assert_allclose(p.length.sum(), 0.98 * np.hypot(1.0, slope), atol=1e-12)


def ring(r0: float, r1: float, th: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
    """A strip of quads between radii r0 < r1 over the angles th (increasing); curves
    'inner' (r0) and 'outer' (r1)."""
    r = np.array([r0, r1])
    pts = np.column_stack([(r[:, None] * np.cos(th)).ravel(),
                           (r[:, None] * np.sin(th)).ravel()])
    idx = np.arange(2 * th.size).reshape(2, th.size)
    quads = np.column_stack([idx[0, :-1], idx[0, 1:], idx[1, 1:], idx[1, :-1]])
    return pts, quads, {"inner": np.column_stack([idx[0, :-1], idx[0, 1:]]),
                        "outer": np.column_stack([idx[1, :-1], idx[1, 1:]])}


def pin_and_hole(f: float, d: float, pin_longer: bool) -> Mesh:
    """A pin (strip 0.8 .. 1 of the unit circle) in a hole (strip 1 - d .. 1.2: d a radial
    overlap) over +-0.6 rad around the bottom, 12 edges each; one of the two arcs is
    longer by f of an edge at both ends (the pin's if pin_longer, else the hole's)."""
    base = -np.pi / 2 + np.linspace(-0.6, 0.6, 13)
    long = -np.pi / 2 + np.linspace(-0.6 - 0.1 * f, 0.6 + 0.1 * f, 13)
    pin = ring(0.8, 1.0, long if pin_longer else base)
    hole = ring(1.0 - d, 1.2, base if pin_longer else long)
    return scene({"pin": pin, "hole": hole})


def _both_discretisations(mesh: Mesh, slave: str, master: str, interference: bool
                          ) -> tuple[ContactPairs, ContactPairs]:
    """The node-to-segment and mortar pairs of one interface (search_distance 0.1)."""
    from types import SimpleNamespace

    from app.contact.mortar import mortar_constraints
    itf = SimpleNamespace(name="c", slave=slave, master=master, search_distance=0.1,
                          penetration_tol=None, interference=interference)
    return (contact_pairs(mesh, slave, master, 0.1, interference=interference),
            mortar_constraints(mesh, itf, 0).pairs)


@pytest.mark.parametrize("deg", [0.0, 30.0])
@pytest.mark.parametrize("f", [0.05, 0.2, 0.28])
@pytest.mark.parametrize("d", [0.0, 1e-3])
@pytest.mark.parametrize("pin_longer", [False, True])
def test_an_arc_end_beyond_a_curved_master_end_reads_its_depth_below_the_curve(
        pin_longer, d, f, deg):
    """A slave arc longer than its master arc (same circle, edges of 0.1 rad) by f of an
    edge: its end node lies on the master's circle continued (d = 0) or d inside it, and
    reads that depth with node-to-segment and mortar, on a convex master (the hole's arc
    as slave of the pin) and a concave one (the pin's arc as slave of the hole). The end
    segment's line read it a (a + h) / 2 = 2.6e-4 to 1.8e-3 deep on the pin (a = f h),
    and with `interference` pushed it out by that much more than d; on the hole,
    a (a + h) / 2 less than d. (Interference throughout: the pin's polygon, its nodes
    between the hole's, overlaps the hole's chords by up to 2e-4 inside the arcs.)"""
    mesh, _ = rotate(pin_and_hole(f, d, pin_longer), deg)
    slave, master = ("pin_outer", "hole_inner") if pin_longer else ("hole_inner", "pin_outer")
    ends = mesh.curves[slave][[0, -1], [0, 1]]  # the slave arc's end nodes
    for q in _both_discretisations(mesh, slave, master, True):
        at = np.isin(q.slave, ends)
        assert at.sum() == 2 or (d == 0.0 or f == 0.28) and q.n_pairs == 11
        np.testing.assert_allclose(q.g0[at], -d, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("deg", [0.0, 30.0])
@pytest.mark.parametrize("f", [0.05, 0.28])
def test_a_hole_longer_than_its_pin_where_they_touch_is_no_penetration(f, deg):
    """The hole's arc, touching the pin, longer than the pin's arc by f of an edge: no
    overlap anywhere, so nothing is refused (before, both discretisations refused its end
    nodes as penetrations of a (a + h) / 2 = 2.6e-4 and 1.8e-3, their depths below the
    pin's end segment's line) and no row pushes: every gap >= 0 at the end nodes."""
    mesh, _ = rotate(pin_and_hole(f, 0.0, False), deg)
    ends = mesh.curves["hole_inner"][[0, -1], [0, 1]]
    for q in _both_discretisations(mesh, "hole_inner", "pin_outer", False):
        np.testing.assert_allclose(q.g0[np.isin(q.slave, ends)], 0.0, atol=1e-12)


@pytest.mark.parametrize("deg", [0.0, 30.0])
@pytest.mark.parametrize("slope", [0.1, 0.5])
def test_mortar_leaves_a_slave_corner_beside_a_block_corner_without_a_row_as_node_to_segment(
        slope, deg):
    """The scene of the test above with mortar: the corner lies 0.002 below the end line,
    its edge meets the master at that line (slope 0.1) or clears it (0.5), so it faces
    no overlap. Mortar refused it as a penetration of 0.002 (its nodal gap) and with
    `interference` kept its row with g0 -0.002 to -0.00205 (a push); now it applies
    node-to-segment's rule (`end_overlaps`): no row, nothing refused, no negative gap,
    and where every slave node is in reach (slope 0.1) both read the same lengths."""
    mesh, corner = _slave_corner_beside_a_block_corner(slope, deg)
    for interference in (False, True):
        p, c = _both_discretisations(mesh, "up_bottom", "low_top", interference)
        assert corner not in c.slave and corner not in p.slave
        assert c.g0.min() >= 0.0
        if slope == 0.1:
            np.testing.assert_allclose(c.length.sum(), p.length.sum(), atol=1e-12)


@pytest.mark.parametrize("turn_deg", [10.0, 29.0, 31.0, 90.0])
def test_the_master_is_continued_along_its_circle_below_a_30_degree_turn_else_its_line(
        turn_deg):
    """`continued_end_gaps` on a master of two edges of 0.1, turning by turn_deg at their
    joint (convex): a point 0.01 past the end lies on the circle through the three nodes
    (gap 0) where the turn is at most END_CURVE_TURN = 30 deg (a polygon of a curve), and
    is measured to the end segment's line beyond that (a corner: the circle would turn the
    continued boundary by more than the edge's own turn)."""
    from app.contact.pairs import continued_end_gaps

    t = np.radians(turn_deg)
    # nodes P -> O -> E, the body on the left, turning left (convex) by t at O
    pts = np.array([[-0.1, 0.0], [0.0, 0.0], [0.1 * np.cos(t), 0.1 * np.sin(t)]])
    m_edges = np.array([[0, 1], [1, 2]])
    seg_len = np.full(2, 0.1)
    m_degree = np.array([1, 2, 1])
    c, r = circle_through(pts)
    a = np.arctan2(*(pts[2] - c)[::-1]) + 0.01 / r  # 0.01 of arc past E
    x = (c + r * np.array([np.cos(a), np.sin(a)]))[None]
    xr = np.array([(x[0] - pts[1]) @ (pts[2] - pts[1]) / 0.01])
    line = np.array([np.cross(pts[2] - pts[1], x[0] - pts[1]) / -0.1])  # open > 0
    g, beyond = continued_end_gaps(x, np.array([1]), xr, line, pts, m_edges, seg_len,
                                   m_degree)
    assert beyond.all() and line[0] < -1e-4
    np.testing.assert_allclose(g, 0.0 if turn_deg < 30.0 else line, atol=1e-15)


def circle_through(p: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre (2,) and radius of the circle through the three points p (3, 2)."""
    a = 2.0 * (p[1:] - p[0])
    b = np.sum(p[1:] ** 2 - p[0] ** 2, axis=1)
    c = np.linalg.solve(a, b)
    return c, float(np.linalg.norm(p[0] - c))
