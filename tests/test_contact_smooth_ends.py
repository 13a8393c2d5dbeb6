"""A mortar-smooth contact that reaches its smoothed master's end warns
(app/contact/smooth_ends.py): the patch test fails there (two_blocks, master 10x the slave:
17% of p = 10), and before, nothing said so."""

from __future__ import annotations

from types import SimpleNamespace

import h5py
import numpy as np

from app.contact.pairs import contact_pairs
from app.contact.smooth_ends import (
    SMOOTHED,
    smooth_end_checks,
    smooth_end_warning,
    unsmoothed_nodes,
)
from tests.support import CONFIGS, read_summary, run_cli
from tests.test_contact_pairs import stacked

FINE_SLAVE = ["--set", "body.lower.shape.divisions=[80,8]",
              "--set", "body.upper.shape.divisions=[8,4]",
              "--set", 'interface.interface.slave="lower_top"',
              "--set", 'interface.interface.master="upper_bottom"']


def _run(tmp_path, name: str, discretisation: str) -> tuple[dict, np.ndarray]:
    out = tmp_path / name
    res = run_cli(["run", str(CONFIGS / "two_blocks.toml"), "--out", str(out), "--quiet",
                   *FINE_SLAVE, "--set", f'interface.interface.discretisation="{discretisation}"'])
    assert res.returncode == 0, res.stderr
    with h5py.File(out / "step_0001.h5") as f:
        p = f["contact/p"][()]
    return read_summary(out), p


def test_smoothed_master_end_in_contact_warns(tmp_path):
    s, p = _run(tmp_path, "smooth", "mortar-smooth")
    assert s["contact_interfaces"]["interface"]["master_interpolation"] == "quadratic B-spline"
    assert np.abs(p - 10.0).max() / 10.0 > 0.1  # what the warning is about
    hits = [w for w in s.get("warnings", []) if "smoothed master 'upper_bottom'" in w]
    assert len(hits) == 1 and "reaches an end" in hits[0] and '"mortar"' in hits[0]


def test_linear_master_passes_and_does_not_warn(tmp_path):
    s, p = _run(tmp_path, "mortar", "mortar")
    assert np.abs(p - 10.0).max() / 10.0 < 1e-9
    assert not [w for w in s.get("warnings", []) if "smoothed master" in w]


# --- the numpy check on hand-made geometry (no run, no MPI, no files) ----------------------
# The lower block's top (4 elements, nodes at x = 0, 0.25, ..., 1) is the smoothed master;
# the upper block's bottom the slave, on y = 0 (matching nodes: every pair's master segment
# is the one under it). The straight master curve has two ends (x = 0 and x = 1) and no
# corner; its end segments are [0, 0.25] and [0.75, 1].

SMOOTH = {"t": {"master_interpolation": SMOOTHED}}


def _checks(x_up: tuple[float, float], force: float = 1.0, described=SMOOTH,
            master: str = "low_top") -> list[dict]:
    """smooth_end_checks of the upper block's bottom (2 elements over x_up) on `master`,
    every pair carrying `force` against a force scale of 1."""
    mesh = stacked(4, 2, x_up=x_up)
    mesh.curves["low_corner"] = np.vstack([mesh.curves["low_top"], mesh.curves["low_right"]])
    pairs = contact_pairs(mesh, "up_bottom", master, 0.1)
    itf = [SimpleNamespace(name="t", master=master)]
    return smooth_end_checks(mesh, pairs, np.full(pairs.n_pairs, force), itf, described, 1.0)


def test_the_ends_of_a_straight_master_are_its_unsmoothed_nodes():
    mesh = stacked(4, 2)
    ends, corners = unsmoothed_nodes(mesh, "low_top", "t")
    assert sorted(map(tuple, mesh.points[ends])) == [(0.0, 0.0), (1.0, 0.0)]
    assert corners.size == 0


def test_a_closed_pair_facing_an_end_segment_warns():
    # slave nodes at x = 0.05, 0.3, 0.55: the first faces [0, 0.25], the others interior
    (c,) = _checks((0.05, 0.55))
    assert c["interface"] == "t" and c["master"] == "low_top" and c["where"] == "an end"
    assert c["pairs"] == 1 and c["at"] == (0.05, 0.0)
    text = smooth_end_warning(c, 3)
    assert text.startswith("interface 't', step 3: the contact reaches an end of its "
                           "smoothed master 'low_top' (1 closed pair(s), the first at "
                           "x=0.05, y=0)")
    assert "\n" not in text


def test_closed_pairs_on_interior_segments_do_not_warn():
    # slave nodes at x = 0.3, 0.5, 0.7: their segments [0.25, 0.5], [0.5, 0.75]
    assert _checks((0.3, 0.7)) == []


def test_a_closed_pair_facing_a_corner_segment_warns():
    """The master 'low_corner' is the lower block's top and right side: a 90 degree turn at
    (1, 0), beyond MAX_KINK_DEG, where the B-spline falls back to the linear segment."""
    mesh = stacked(4, 2)
    mesh.curves["low_corner"] = np.vstack([mesh.curves["low_top"], mesh.curves["low_right"]])
    ends, corners = unsmoothed_nodes(mesh, "low_corner", "t")
    assert sorted(map(tuple, mesh.points[ends])) == [(0.0, 0.0), (1.0, -0.5)]
    np.testing.assert_allclose(mesh.points[corners], [[1.0, 0.0]])
    # slave nodes at x = 0.8, 0.9 (and 1.0, on the corner): all face a segment at (1, 0)
    (c,) = _checks((0.8, 1.0), master="low_corner")
    assert c["where"] == "a corner" and c["pairs"] >= 2 and c["at"] == (0.8, 0.0)
    assert _checks((0.3, 0.7), master="low_corner") == []


def test_open_pairs_and_unsmoothed_masters_do_not_warn():
    assert _checks((0.0, 0.5), force=0.0) == []  # below CLOSED_REL x force scale
    assert _checks((0.0, 0.5), described={"t": {"master_interpolation": "linear"}}) == []
