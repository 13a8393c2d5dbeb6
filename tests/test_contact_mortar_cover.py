"""Knife edges of the mortar rows: half-covered slave nodes at a master end (MIN_COVER),
curves meeting end to end, and master turns of exactly MAX_KINK_DEG (mortar-smooth)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from test_contact_pairs import stacked

from app.contact.discretisation import DISCRETISATIONS
from app.contact.mortar_smooth import master_neighbours
from app.errors import InputError


def itf() -> SimpleNamespace:
    return SimpleNamespace(name="t", slave="up_bottom", master="low_top", search_distance=0.1,
                           penetration_tol=None, interference=False)


@pytest.mark.parametrize("name", ["mortar", "mortar-smooth", "mortar-bisector"])
@pytest.mark.parametrize("n_low, n_up, x_up", [(4, 50, 0.5), (2, 10, 0.5), (4, 10, 1.0),
                                                (2, 14, 0.7)])
def test_half_covered_end_nodes_kept_on_both_sides(name, n_low, n_up, x_up):
    """A narrow master [-0.2, 0.2] under a wider slave with nodes at x = +-0.2: those two
    nodes have exactly half their support facing the master, and the scene is symmetric,
    so both are kept (before: one or both dropped, depending on the rounding)."""
    mesh = stacked(n_low, n_up, x_low=(-0.2, 0.2), x_up=(-x_up, x_up))
    x = DISCRETISATIONS[name](mesh, itf(), 0).pairs.position[:, 0]
    x = np.sort(x)
    np.testing.assert_allclose(x, -x[::-1], atol=1e-12)  # the pair set is symmetric
    assert x[0] == pytest.approx(-0.2) and x[-1] == pytest.approx(0.2)


@pytest.mark.parametrize("name", ["mortar", "mortar-smooth", "mortar-bisector"])
def test_curves_meeting_end_to_end_say_so(name):
    """Two blocks that touch at one corner: the slave node there is at distance 0 from
    the master, but no part of its support faces it. The error names that, not a
    search_distance to raise (which cannot help)."""
    mesh = stacked(4, 4, x_low=(0.0, 1.0), x_up=(1.0, 2.0))
    with pytest.raises(InputError, match="less than half of their support") as info:
        DISCRETISATIONS[name](mesh, itf(), 0)
    assert "raise search_distance" not in str(info.value)
    with pytest.raises(InputError, match="no slave node .* lies within"):  # truly far
        DISCRETISATIONS[name](stacked(4, 4, x_low=(0.0, 1.0), x_up=(1.5, 2.5)), itf(), 0)


@pytest.mark.parametrize("rot", [0.0, 0.1, 0.37])
def test_a_regular_12_gon_master_is_smooth_at_every_node(rot):
    """Every node of a regular 12-gon turns by exactly MAX_KINK_DEG = 30 deg: not sharper,
    so smooth everywhere (before: 4 or 5 of the 12 nodes were corners, by rounding, so a
    symmetric master was smoothed asymmetrically). 31 deg is a corner, 29 deg is not."""
    n = 12
    t = rot + 2 * np.pi * np.arange(n) / n
    pts = np.c_[np.cos(t), np.sin(t)]
    edges = np.c_[np.arange(n), (np.arange(n) + 1) % n]
    prev, nxt = master_neighbours(pts, edges)
    assert np.all(prev >= 0) and np.all(nxt >= 0)
    for deg, corner in ((31.0, True), (29.0, False)):
        a = np.radians(deg)
        chain = np.array([[-1.0, 0.0], [0.0, 0.0], [np.cos(a), np.sin(a)]])
        prev, nxt = master_neighbours(chain, np.array([[0, 1], [1, 2]]))
        assert bool(nxt[0] < 0) == corner and bool(prev[1] < 0) == corner
