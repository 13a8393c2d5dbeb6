"""Loads beyond float64 are named as such, not as a singular stiffness. Before, a body
force of 1e308 on hertz.toml (or a total force of -1e308) stopped with "linear solve
produced NaN: the stiffness is probably singular: check that every body is held by
supports", and a prescribed value of -1e308 the same way."""

import pytest
from support import CONFIGS, read_summary, run_cli


@pytest.mark.parametrize("override, needle", [
    ("body.block.body_force=[1e308,1e308]", "the displacements overflow float64"),
    ("load.0.total_force=[0.0,-1e308]", "the displacements overflow float64"),
    ("support.1.uy=-1e308", "the load vector of a linear solve is not finite"),
])
def test_overflowing_loads_are_not_called_a_singular_stiffness(tmp_path, override, needle):
    res = run_cli(["run", str(CONFIGS / "hertz.toml"), "--out", str(tmp_path), "--quiet",
                   "--set", override])
    assert res.returncode == 2, res.stderr
    errors = [ln for ln in res.stderr.splitlines() if not ln.startswith("warning:")]
    assert len(errors) == 1 and errors[0].startswith("error: ") and needle in errors[0]
    assert "singular" not in res.stderr, res.stderr
    assert read_summary(tmp_path)["status"] == "failed"


def test_overflow_on_two_ranks(tmp_path):
    res = run_cli(["run", str(CONFIGS / "hertz.toml"), "--out", str(tmp_path), "--quiet",
                   "--set", "body.block.body_force=[1e308,1e308]"], ranks=2)
    assert res.returncode != 0 and "overflow float64" in res.stderr, res.stderr
