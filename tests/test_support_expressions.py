"""Support expressions singular at (or near) a node are errors naming the support and the
node. Before, `support.0.ux="y**-1"` ran: gmsh put a base node at y = 1e-17, so the value
was a finite 1e17 there and the run completed with a strain energy of 1.6e26."""

from __future__ import annotations

import numpy as np
import pytest
from support import CONFIGS, read_summary, run_cli

from app.assembly.loads import support_dofs
from app.config import Support
from app.errors import InputError
from app.mesh.model import Mesh


def _square(y0: float = 1e-17) -> Mesh:
    """One unit square whose bottom-left node is at y = y0 (round-off off y = 0)."""
    pts = np.array([[0.0, y0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    return Mesh(points=pts, quads=np.array([[0, 1, 2, 3]]), body=np.array([0]),
                body_names=["block"], curves={"base": np.array([[0, 1]])})


def _support(value) -> Support:
    return Support(on="base", values={0: value}, history=np.linspace(0.5, 1.0, 2))


def test_an_expression_infinite_at_a_node_off_its_axis_by_round_off_is_an_error():
    with pytest.raises(InputError, match=r"support on 'base', ux: expression 'y\*\*-1' is "
                       r"infinite .* \(first at node 0, x = 0, y = 0\)"):
        support_dofs(_square(), _support("y**-1"))


def test_an_expression_far_larger_than_the_scene_is_an_error_naming_the_node():
    with pytest.raises(InputError, match=r"'1/\(y \+ 1e-9\)' prescribes 1e\+09 at node 0 "
                       r"\(x = 0, y = 0\), more than 10 times the scene's size 1.41"):
        support_dofs(_square(0.0), _support("1/(y + 1e-9)"))


def test_ordinary_values_are_unchanged():
    """Smooth expressions, a displacement as large as the scene, and numbers (the user's
    own, however large: tests/test_overflowing_loads.py names those) are taken as given."""
    dofs, vals = support_dofs(_square(), _support("0.01 * (x + 1)"))
    assert dofs.tolist() == [0, 2] and np.allclose(vals, [0.01, 0.02], rtol=0, atol=1e-15)
    assert np.allclose(support_dofs(_square(), _support("14 * (x + 0.001)"))[1], [0.014, 14.014])
    assert support_dofs(_square(), _support(1e30))[1].tolist() == [1e30, 1e30]


def test_the_run_fails_with_one_error_line_and_a_failed_summary(tmp_path):
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(tmp_path), "--quiet",
                   "--set", 'support.0.ux="y**-1"'])
    assert res.returncode == 2, res.stderr
    errors = [ln for ln in res.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "support on 'lower_base', ux" in errors[0], res.stderr
    assert "node" in errors[0] and "Traceback" not in res.stderr
    assert read_summary(tmp_path)["status"] == "failed"
