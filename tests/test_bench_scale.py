"""scripts/bench_scale.py: the growth exponents of the phases and the many-step figures."""

from __future__ import annotations

import sys

from support import ROOT

sys.path.insert(0, str(ROOT / "scripts"))
import bench_scale as bench  # noqa: E402


def _row(n: int, t_lin: float, t_fast: float, total: float) -> dict:
    return {"n_dofs": n, "total_s": total, "phases": {"lin": t_lin, "fast": t_fast,
                                                      "tiny": 1e-4}}


def test_fits_give_each_phase_its_exponent_in_the_dofs():
    rows = [_row(n, 1e-5 * n, 1e-8 * n ** 1.5, 1e-5 * n + 1e-8 * n ** 1.5)
            for n in (10_000, 40_000, 160_000)]
    fit = bench.fits(rows)
    assert abs(fit["lin"]["b_all"] - 1.0) < 0.01 and abs(fit["lin"]["b_last"] - 1.0) < 0.01
    assert abs(fit["fast"]["b_all"] - 1.5) < 0.01
    assert "tiny" not in fit  # below SMALL_S at the largest size: noise, left out
    assert fit["total"]["share"] == 1.0


def test_step_figures_need_ten_steps_and_read_the_first_and_last_tenth():
    assert bench.step_figures([{"step_seconds": 1.0}] * 9) == {}
    steps = [{"step_seconds": 1.0 + (i >= 90), "lemke_pivots": 2 if i == 0 else 0}
             for i in range(100)]
    out = bench.step_figures(steps)
    assert out["step_s_first"] == 1.0 and out["step_s_last"] == 2.0
    assert out["pivots_mean"] == 0.0
