"""configs/indent.toml: multibody's `indent` contact on its own (a fine arc on a block 4.4x
coarser). The app's figures that scripts/calculix_indent.py compares with CalculiX."""

from __future__ import annotations

import pytest
from support import CONFIGS, kkt_violations, read_summary, run_cli

from app.contact.smoothness import local_fit_deviation
from app.output.read import read_pairs

SWAP = ["--set", 'interface.indent.slave="block_top"', "--set", 'interface.indent.master="cyl_arc"']


def indent(tmp_path, *extra: str) -> tuple[dict, dict]:
    """(summary, closed pairs x, p) of one run of the scene."""
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "indent.toml"), "--out", str(out), "--quiet", *extra])
    assert res.returncode == 0, res.stderr
    assert max(kkt_violations(out, 1).values()) < 1e-7
    c = read_pairs(out / "step_0001.h5", 0, ("x", "p"))
    on = c["p"] > 0
    return read_summary(out), {"x": c["x"][on], "p": c["p"][on]}


def test_indent_fine_arc_on_coarse_block_stripes_and_warns(tmp_path):
    """Like multibody's indent (P = 20, 17 closed pairs, max p 86, 30% off a local fit):
    the arc's p follows the block's element period, and the run says so."""
    s, c = indent(tmp_path)
    step = s["steps"][-1]
    assert -step["reactions"]["support:cyl_top"]["Fy"] == pytest.approx(20.0, rel=0.03)
    assert c["x"].size == 17
    assert step["interfaces"]["indent"]["max_pressure"] == pytest.approx(86.8, rel=0.02)
    assert local_fit_deviation(c["x"], c["p"]).max() > 0.25
    assert [w for w in s["warnings"] if "'indent'" in w and "master's elements" in w]


def test_indent_block_as_slave_is_smooth(tmp_path):
    """The coarse side as slave: 6 pairs, within 5% of the local fit (README: 3.7%)."""
    s, c = indent(tmp_path, *SWAP)
    assert c["x"].size == 6
    assert local_fit_deviation(c["x"], c["p"]).max() < 0.05
    assert not [w for w in s.get("warnings", []) if "'indent'" in w]
