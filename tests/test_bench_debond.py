"""scripts/bench_debond.py: the figures it reads from a run and the agreement of two runs."""

from __future__ import annotations

import sys

from support import ROOT

sys.path.insert(0, str(ROOT / "scripts"))
import bench_debond as bench  # noqa: E402


def _summary(force: float, states: dict, debonded: int = 0) -> dict:
    itf = {"normal_force": force, "tangential_force": 0.5 * force, "states": states,
           "debonded_pairs": debonded}
    steps = [{"step": 1, "lcp_seconds": 0.1, "lcp_solves": 1, "lemke_pivots": 9,
              "interfaces": {"bond": itf}},
             {"step": 2, "lcp_seconds": 0.5, "lcp_solves": 7, "lemke_pivots": 3,
              "interfaces": {"bond": itf}}]
    return {"timings": {"lcp": 0.7, "total": 2.0}, "steps": steps}


def test_figures_are_those_of_the_step_with_the_most_solves():
    out = bench.figures(_summary(1.0, {"open": 2}))
    assert (out["step"], out["step_lcp_s"], out["lcp_solves"], out["pivots"]) == (2, 0.5, 7, 3)
    assert out["lcp_s"] == 0.7 and out["total_s"] == 2.0


def test_agreement_reports_force_differences_and_changed_states():
    ref = _summary(2.0, {"open": 2})
    assert bench.agreement(ref, _summary(2.0, {"open": 2})) == {"force_rel_diff": 0.0,
                                                               "same_states": True}
    out = bench.agreement(ref, _summary(2.0 + 2e-9, {"open": 2}))
    assert abs(out["force_rel_diff"] - 1e-9) < 1e-12 and out["same_states"]
    assert not bench.agreement(ref, _summary(2.0, {"open": 1, "stick": 1}))["same_states"]
    assert not bench.agreement(ref, _summary(2.0, {"open": 2}, debonded=1))["same_states"]
