"""Master nodes behind the deformed slave warn (app/contact/master_penetration.py):
configs/hard/flat_punch.toml with the block's top as slave lets the punch corners sink
into the block by 6% of the largest displacement, with every discretisation; before,
nothing said so. With the punch as slave (as shipped) nothing of the block is behind it."""

from __future__ import annotations

import numpy as np
import pytest

from app.contact.master_penetration import (
    MASTER_DEPTH_WARN,
    master_penetration,
    master_penetration_warning,
)
from tests.support import CONFIGS, read_summary, run_cli
from tests.test_contact_pairs import stacked

SCENE = CONFIGS / "hard" / "flat_punch.toml"
SWAP = ["--set", 'interface.contact.slave="block_top"',
        "--set", 'interface.contact.master="punch_bottom"']


def _warnings(tmp_path, name: str, *args: str) -> list[str]:
    out = tmp_path / name
    res = run_cli(["run", str(SCENE), "--out", str(out), "--quiet", *args])
    assert res.returncode == 0, res.stderr
    s = read_summary(out)
    assert abs(s["steps"][-1]["interfaces"]["contact"]["force"][1]) == pytest.approx(20.0, rel=1e-9)
    return [w for w in s.get("warnings", []) if "lie behind the deformed slave" in w]


def test_punch_corners_behind_the_block_as_slave_warn(tmp_path):
    how = "node-to-segment"
    (w,) = _warnings(tmp_path, how, *SWAP,
                     "--set", f'interface.contact.discretisation="{how}"')
    assert "master 'punch_bottom'" in w and "slave 'block_top'" in w and "x=-1" in w
    ratio = float(w.split("% of the largest")[0].rsplit(" ", 1)[1])
    assert 3.0 < ratio < 10.0  # 6.2% measured


def test_mortar_holds_the_punch_corners_out_of_the_block_as_slave(tmp_path):
    """With the block as slave, mortar's rows now cover the slave edges the punch covers in
    part (`covered_tests`): its corners no longer sink into the block by 6.2% of the largest
    displacement (the warning of node-to-segment's test above; mortar's too before)."""
    assert _warnings(tmp_path, "mortar", *SWAP,
                     "--set", 'interface.contact.discretisation="mortar"') == []


def test_punch_as_slave_is_silent(tmp_path):
    assert _warnings(tmp_path, "shipped") == []


# --- the numpy kernel on hand-made geometry (no run, no MPI, no files) ---------------------
# Two stacked unit blocks (tests/test_contact_pairs.py `stacked`): the slave is the lower
# block's top (2 elements, nodes at x = 0, 0.5, 1), the master the upper block's bottom
# (4 elements, nodes at x = 0, 0.25, ..., 1), both on y = 0. The lower block slides by
# SLIDE along x (a flat slave stays flat: no master node goes behind it), which sets the
# displacement scale; one master node then moves down into the lower block by a depth.

SLIDE = 0.01
"""x-displacement of the lower block: the largest nodal displacement, the check's scale."""


def _pressed(depth: float, gap: float = 0.0):
    """(mesh, u (n, 2), the moved master node): the lower block slid by SLIDE along x,
    the upper block's bottom node at x = 0.25 moved by -depth in y."""
    mesh = stacked(2, 4, gap=gap)
    u = np.zeros((mesh.n_nodes, 2))
    u[mesh.node_body() == 0, 0] = SLIDE
    node = int(np.flatnonzero((mesh.node_body() == 1) & np.isclose(mesh.points[:, 0], 0.25)
                              & np.isclose(mesh.points[:, 1], gap))[0])
    u[node, 1] = -depth
    return mesh, u, node


def test_a_master_node_behind_the_slave_by_a_known_depth_is_reported():
    depth = 0.4 * SLIDE  # 40% of the scale, beyond the 3% threshold
    mesh, u, node = _pressed(depth)
    found = master_penetration(mesh, "low_top", "up_bottom", u, "t")
    assert found is not None and found.count == 1
    assert found.depth == pytest.approx(depth, rel=1e-12)
    assert found.ratio == pytest.approx(depth / SLIDE, rel=1e-12)
    np.testing.assert_allclose(found.position, mesh.points[node])
    text = master_penetration_warning("t", 2, "low_top", "up_bottom", found)
    assert text.startswith("interface 't', step 2: 1 node(s) of the master 'up_bottom'")
    assert "deepest 0.004" in text and "40% of the largest" in text and "x=0.25" in text
    assert "\n" not in text


@pytest.mark.parametrize("share", [0.9, 1.1])
def test_the_threshold_is_master_depth_warn_of_the_largest_displacement(share):
    """Just inside MASTER_DEPTH_WARN x scale: silent; just beyond: reported."""
    depth = share * MASTER_DEPTH_WARN * SLIDE
    mesh, u, _ = _pressed(depth)
    found = master_penetration(mesh, "low_top", "up_bottom", u, "t")
    if share < 1:
        assert found is None
    else:
        assert found is not None and found.depth == pytest.approx(depth, rel=1e-12)


def test_a_master_node_behind_the_slave_at_the_start_is_an_interference_left_alone():
    mesh, u, _ = _pressed(0.4 * SLIDE, gap=-0.05)  # the upper block starts 0.05 inside
    assert master_penetration(mesh, "low_top", "up_bottom", u, "t") is None


def test_nothing_moved_or_a_non_finite_displacement_is_not_judged():
    mesh, u, node = _pressed(0.0)
    assert master_penetration(mesh, "low_top", "up_bottom", np.zeros_like(u), "t") is None
    u[node, 1] = np.nan
    assert master_penetration(mesh, "low_top", "up_bottom", u, "t") is None
