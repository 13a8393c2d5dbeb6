"""scripts/plot_results.py's --zoom and --scale: a view that cannot draw anything is one
`error:` line and exit 2 (before: an empty picture and exit 0)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.support import CONFIGS, ROOT, mpi_env, run_cli

PLOT = ROOT / "scripts" / "plot_results.py"


@pytest.fixture(scope="module")
def patch_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("plot") / "o"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet"])
    assert res.returncode == 0, res.stderr
    return out


def _plot(out, *extra):
    return subprocess.run([sys.executable, str(PLOT), str(out), "--prefix", "v_", *extra],
                          cwd=ROOT, env=mpi_env(), capture_output=True, text=True,
                          timeout=300)


@pytest.mark.parametrize("extra, needle", [
    (["--scale", "nan"], "--scale nan"),
    (["--scale", "inf"], "--scale inf"),
    (["--scale", "-5"], "--scale -5"),
    (["--zoom", "1", "0", "0", "1"], "X0 < X1"),
    (["--zoom", "0", "nan", "0", "1"], "X0 < X1"),
    (["--zoom", "100", "101", "100", "101"], "no element of step 1 has its deformed centre"),
])
def test_a_view_that_draws_nothing_is_an_error(patch_out, extra, needle):
    res = _plot(patch_out, *extra)
    lines = [ln for ln in res.stderr.strip().splitlines() if "Warning" not in ln
             and not ln.startswith(" ")]  # matplotlib's import warnings, if any
    assert res.returncode == 2 and len(lines) == 1, res.stderr
    assert lines[0].startswith("error: ") and needle in lines[0], res.stderr
    assert not list(patch_out.glob("v_*.png"))


def test_scale_zero_draws_the_undeformed_mesh(patch_out):
    res = _plot(patch_out, "--scale", "0")
    assert res.returncode == 0, res.stderr
    assert (patch_out / "v_deformed_von_mises.png").is_file()
