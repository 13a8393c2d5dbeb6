"""Slave nodes without a pair that move through the master (app/contact/unpaired.py)."""

from __future__ import annotations

import numpy as np
import pytest
from support import CONFIGS, read_summary, run_cli
from test_contact_pairs import stacked

from app.contact.unpaired import crossed_unpaired, crossing_warning


def _moved_up_block(mesh, dy: float) -> np.ndarray:
    u = np.zeros((mesh.n_nodes, 2))
    u[mesh.node_body() == 1, 1] = dy
    return u


def test_a_block_pushed_through_its_master_is_found():
    mesh = stacked(4, 4, gap=0.2)  # no pair: every upper-bottom node starts 0.2 above
    none = np.zeros(0, dtype=np.int64)
    assert crossed_unpaired(mesh, "up_bottom", "low_top", none, _moved_up_block(mesh, -0.1),
                            "t") is None
    c = crossed_unpaired(mesh, "up_bottom", "low_top", none, _moved_up_block(mesh, -0.3), "t")
    assert c.count == 5 and c.depth == pytest.approx(0.1)
    assert c.position[1] == pytest.approx(0.2)
    text = crossing_warning("t", 3, c, 0.05)
    assert text.startswith("interface 't', step 3: 5 slave node(s)") and "\n" not in text
    # the paired nodes are the pairs' business, not this check's
    paired = np.unique(mesh.curves["up_bottom"])
    assert crossed_unpaired(mesh, "up_bottom", "low_top", paired, _moved_up_block(mesh, -0.3),
                            "t") is None


def test_nodes_beyond_the_master_end_or_behind_it_at_the_start_are_not_judged():
    beside = stacked(4, 4, gap=0.2, x_up=(1.5, 2.5))  # beyond the master's free end
    none = np.zeros(0, dtype=np.int64)
    assert crossed_unpaired(beside, "up_bottom", "low_top", none,
                            _moved_up_block(beside, -0.3), "t") is None
    # the upper block already overlapping (an interference fit): not a crossing
    fit = stacked(4, 4, gap=-0.05)
    assert crossed_unpaired(fit, "up_bottom", "low_top", none, _moved_up_block(fit, -0.01),
                            "t") is None


def test_hertz_pressed_far_beyond_its_search_distance_warns(tmp_path):
    """58x the Hertz load: the contact half-width (0.76) outgrows the pairs within
    search_distance = 0.05 of the block, and the arc beyond them sinks into the block."""
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "hertz.toml"), "--out", str(out), "--quiet",
                   "--set", "load.0.total_force=[0.0, -50000.0]"])
    assert res.returncode == 0, res.stderr
    (w,) = [w for w in read_summary(out)["warnings"] if "moved through the master" in w]
    assert w.startswith("interface 'contact', step 1:") and "search_distance=0.05" in w
    ok = run_cli(["run", str(CONFIGS / "hertz.toml"), "--out", str(tmp_path / "p"),
                  "--quiet"])
    assert "moved through" not in ok.stderr


def test_the_watch_gives_the_closest_segment_within_any_reach():
    """The run keeps each node's closest segment at any distance (`watch`, built once);
    within a reach it must be the one `closest_segments` finds within that reach, which
    the checks searched afresh every step before."""
    from app.contact.pairs import closest_segments
    from app.contact.unpaired import watch

    mesh = stacked(7, 5, gap=0.03, x_up=(0.1, 1.3))
    rng = np.random.default_rng(3)
    pts = mesh.points + rng.normal(0.0, 0.01, mesh.points.shape)
    low = np.unique(mesh.curves["low_top"])
    edges = np.array(mesh.curves["low_top"])
    nodes = np.unique(mesh.curves["up_bottom"])
    w = watch(pts, nodes, edges, (nodes, low))
    for reach in (0.005, 0.02, 0.04, 0.1, 0.3, 5.0):
        seg, _, dist = closest_segments(pts[nodes], pts[edges[:, 0]], pts[edges[:, 1]], reach)
        np.testing.assert_array_equal(w.dist <= reach, seg >= 0)
        np.testing.assert_array_equal(w.dist[seg >= 0], dist[seg >= 0])


def test_the_watch_judges_ties_as_the_search_within_the_reach_did():
    """Nodes at the master's corners and on their bisectors (equidistant from two
    segments, whose signed gaps differ): the Watch (closest segment at any distance,
    built once) and the search within the step's reach (as every step did before) pick
    the same segment, so the same nodes are judged (a random check of 4000 cases against
    the code before, corners, bisectors and arcs, found no difference)."""
    from app.contact.pairs import closest_segments
    from app.contact.unpaired import watch

    rng = np.random.default_rng(5)
    corners = np.column_stack([np.arange(7) * 0.1, [0.0, 0.03, -0.03, 0.03, 0.0, -0.03, 0.0]])
    d1, d2 = corners[1:-1] - corners[:-2], corners[2:] - corners[1:-1]
    n = np.column_stack([d1[:, 1], -d1[:, 0]]) / np.linalg.norm(d1, axis=1)[:, None] + \
        np.column_stack([d2[:, 1], -d2[:, 0]]) / np.linalg.norm(d2, axis=1)[:, None]
    n /= np.linalg.norm(n, axis=1)[:, None]
    ties = np.vstack([corners] + [corners[1:-1] + s * n for s in (0.01, 0.05, -0.01)])
    pts = np.vstack([corners, ties])
    edges = np.column_stack([np.arange(6), np.arange(1, 7)])
    nodes, master = np.arange(7, pts.shape[0]), np.arange(7)
    w = watch(pts, nodes, edges, (nodes, master))
    a, b = pts[edges[:, 0]], pts[edges[:, 1]]
    for _ in range(20):
        u = np.zeros_like(pts)
        u[nodes] = rng.normal(0.0, 0.02, (nodes.size, 2)) + rng.normal(0.0, 0.05, 2)
        reach = float(np.abs(u).max()) * 2 * np.sqrt(2.0)
        seg, _, _ = closest_segments(pts[nodes], a, b, reach)
        w_seg, _, _ = closest_segments(pts[nodes], a, b, np.inf)
        near = seg >= 0
        np.testing.assert_array_equal(seg[near], w_seg[near])
        np.testing.assert_array_equal(near, w.dist <= reach)
