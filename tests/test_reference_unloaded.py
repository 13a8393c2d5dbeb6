"""Hertz and Cattaneo references of a run whose contact carries no force at the end
(unloaded, or lifted off): no closed form to compare with, NaN errors, no traceback."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support import CONFIGS, read_summary, run_cli

from app.closed_form import hertz_errors


@pytest.mark.parametrize("P", [0.0, -1e-12])
def test_hertz_errors_without_a_normal_force(P):
    x = np.linspace(-0.1, 0.1, 9)
    e = hertz_errors(x, np.zeros(9), np.full(9, 0.025), P=P, R=1.0, E_star=1e5)
    assert e["P"] == P and e["p_max"] == 0.0
    for key in ("a_hertz", "p0_hertz", "p_max_rel_error", "half_width_rel_error",
                "pressure_l2_rel_error", "pressure_l2_interp_rel_error"):
        assert math.isnan(e[key]), key


@pytest.mark.parametrize("config", ["hertz.toml", "cattaneo.toml"])
def test_unloaded_run_with_a_reference_completes(tmp_path, config):
    """The cylinder's top held where it touches, no load: every pair open, P = 0 (before:
    ZeroDivisionError traceback after the last step, exit 1, status failed)."""
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / config), "--out", str(out), "--quiet",
                   "--set", "support.1.uy=0.0", "--set", "load.0.total_force=[0.0, 0.0]"])
    assert res.returncode == 0, res.stderr
    assert "Traceback" not in res.stderr
    s = read_summary(out)
    assert s["status"] == "completed"
    hz = s["reference"]["hertz"]
    assert hz["P"] == 0.0 and math.isnan(hz["p_max_rel_error"])
