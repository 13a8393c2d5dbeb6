"""A DOF that two supports prescribe (app/assembly/shared_supports.py): one value, from
the first support; different values are an error (before, the run added them)."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from support import rectangle_body, run_cli

from app.assembly.shared_supports import first_support_values
from app.errors import InputError

POINTS = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
NAMES = ["support #1 (base)", "support #2 (corner)"]


def _kept(b: float, ha, hb) -> list[np.ndarray]:
    """Support 1: uy = -0.01 on nodes 0, 1, 2; support 2: uy = b on node 0."""
    dofs = [np.array([1, 3, 5]), np.array([1])]
    vals = [np.full(3, -0.01), np.array([b])]
    return first_support_values(dofs, vals, [np.asarray(ha, float), np.asarray(hb, float)],
                                NAMES, POINTS)


@pytest.mark.parametrize("b, ha, hb", [
    (-0.01, [1, 1], [1, 1]),
    (-0.02, [1, 2], [0.5, 1]),  # other value and history, same displacement every step
])
def test_agreeing_supports_count_the_dof_once(b, ha, hb):
    kept = _kept(b, ha, hb)
    np.testing.assert_array_equal(kept[0], [-0.01] * 3)
    np.testing.assert_array_equal(kept[1], [0.0])


@pytest.mark.parametrize("b, ha, hb, step, values", [
    (-0.02, [1], [1], 1, "-0.01 and -0.02"),
    (-0.01, [0.5, 1], [1, 1], 1, "-0.005 and -0.01"),  # same value, other ramp
    (0.0, [1, 1], [0, 1], 1, "-0.01 and 0"),
])
def test_disagreeing_supports_are_an_error(b, ha, hb, step, values):
    with pytest.raises(InputError, match=f"support #1 \\(base\\) and support #2 \\(corner\\) "
                                         f"both prescribe uy at x=0, y=0, as {values} at "
                                         f"step {step}"):
        _kept(b, ha, hb)


def test_zero_supports_on_shared_dofs_agree():
    kept = first_support_values([np.array([0, 1]), np.array([1, 3])],
                                [np.zeros(2), np.zeros(2)], [np.ones(3), np.ones(3)],
                                NAMES, POINTS)
    assert not np.any(kept[0]) and not np.any(kept[1])


CONFIG = """[analysis]
plane = "strain"
[mesh]
size = 0.5
[points]
corner = [0.0, 0.0]
""" + rectangle_body("col", (0.0, 0.0), curves={"bottom": "base"}) + """[[support]]
on = "base"
ux = 0.0
uy = -0.01
[[support]]
on = "corner"
uy = {corner}
"""


def test_the_shared_corner_moves_by_the_prescribed_value(tmp_path):
    """Before: -0.02 (the two supports' -0.01 added); with -0.02 at the corner -0.03."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(CONFIG.format(corner=-0.01))
    out = tmp_path / "o"
    r = run_cli(["run", str(cfg), "--quiet", "--out", str(out)])
    assert r.returncode == 0, r.stderr
    with h5py.File(out / "step_0001.h5") as f:
        u = f["displacement"][()][:, 1]
    with h5py.File(out / "mesh.h5") as f:
        y = f["points"][()][:, 1]
    assert np.count_nonzero(y == 0.0) == 3
    np.testing.assert_allclose(u[y == 0.0], -0.01, rtol=1e-12)  # the corner too
    np.testing.assert_allclose(u, -0.01, rtol=1e-12)  # nothing else holds it: a translation
    cfg.write_text(CONFIG.format(corner=-0.02))
    r = run_cli(["run", str(cfg), "--quiet", "--out", str(out)])
    assert r.returncode == 2
    assert "both prescribe uy at x=0, y=0, as -0.01 and -0.02" in r.stderr
