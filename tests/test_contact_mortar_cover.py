"""Mortar's MIN_COVER test at its knife edge: slave nodes right above a master end."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from test_contact_pairs import stacked

from app.contact.discretisation import DISCRETISATIONS
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
