"""The summary's KKT figures on a step whose displacements are all round-off (no load):
measured against the problem's displacement scale, not against that round-off."""

from __future__ import annotations

import tomllib

from support import CONFIGS

from app.config import parse_config
from app.run import RunOptions, run


def test_unloaded_bonded_step_has_no_kkt_violation(tmp_path):
    """bonded.toml with the top's displacements at 0: every pair bonded at gap 0 to
    round-off. Before, `kkt.gap` read 1.0 (a 1e-19 gap over a 1e-19 max |u|)."""
    raw = tomllib.loads((CONFIGS / "bonded.toml").read_text())
    raw["analysis"]["steps"] = 1
    for s in raw["support"][1:]:
        s["history"] = [0.0]
    summary = run(parse_config(raw, CONFIGS / "bonded.toml"),
                  RunOptions(out=tmp_path / "out", quiet=True))
    step = summary["steps"][0]
    assert step["states"]["bonded"] == summary["n_pairs"]
    assert max(step["kkt"].values()) < 1e-9, step["kkt"]


def test_kkt_figures_of_a_step_without_load_or_motion_are_finite():
    """Every gap, force and scale zero (two_blocks.toml without its load): us * fs
    underflowed to 0 and `kkt.complementarity` was NaN in a completed summary.json
    (found by scripts/fuzz_inputs.py)."""
    import math

    import numpy as np

    from app.output.contact import kkt_check

    z = np.zeros(5)
    kkt = kkt_check(z, z, z, z, z, z, z, z, np.zeros(5, bool))
    assert all(math.isfinite(v) and v == 0.0 for v in kkt.values()), kkt
    g = np.array([0.0, 1e-3])  # an open pair and a closed one: no violation
    p = np.array([2.0, 0.0])
    assert kkt_check(g, z[:2], z[:2], p, z[:2], z[:2], z[:2], z[:2],
                     np.zeros(2, bool))["complementarity"] == 0.0
    assert kkt_check(g, z[:2], z[:2], p[::-1], z[:2], z[:2], z[:2], z[:2],
                     np.zeros(2, bool))["complementarity"] == 1.0  # gap 1e-3 carries p 2


def test_a_step_without_load_costs_no_consistency_re_solve(tmp_path):
    """multibody.toml with a first step of no load (its ramps moved one step on): u is
    round-off (max |u| 4.1e-16), and G u - the LCP's kinematics (3.4e-18) is 8.4e-3 of
    it, far above the run-wide 1e-9: one re-solve, which could not reduce it (round-off
    of the LCP's own data: 64 eps x its initial gaps). Now none; the loaded steps'
    answers are those of the run without the extra step."""
    raw = tomllib.loads((CONFIGS / "multibody.toml").read_text())
    raw["analysis"]["steps"] = 5
    raw["load"][0]["ramp"] = [2, 3]
    raw["load"][1]["ramp"] = [4, 5]
    s = run(parse_config(raw, CONFIGS / "multibody.toml"),
            RunOptions(out=tmp_path / "out", quiet=True))
    assert [st["consistency_refinements"] for st in s["steps"]] == [0] * 5
    assert s["steps"][0]["strain_energy"] < 1e-20


def test_the_lcp_data_round_off_is_that_of_its_largest_term():
    """lcp_data_round_off: 64 eps x the largest of |G| |u_free| (the free motion's terms,
    not their sum: a row whose terms cancel still carries their round-off), |g0|,
    |tau_prev| and C_ii a, C_ii c."""
    import numpy as np
    import scipy.sparse as sp

    from app.driver.contact import lcp_data_round_off
    from app.interface.steps import StepSolution
    from app.output.pair_law import EPS, ROUNDOFF_ULPS

    g = sp.csr_matrix(np.array([[1.0, 0.0], [0.0, 1.0]]))  # one pair: normal, tangential
    res = StepSolution("solved", tau_prev=np.array([0.0]), a=np.array([0.0]),
                       c=np.array([0.0]), compliance_diag=np.array([1e-3, 1e-3]))
    unit = ROUNDOFF_ULPS * EPS
    assert lcp_data_round_off(g, np.zeros(2), np.array([0.01]), res) == unit * 0.01
    assert lcp_data_round_off(g, np.array([0.0, -3.0]), np.array([0.01]), res) == unit * 3
    both = sp.csr_matrix(np.array([[1.0, -1.0], [0.0, 0.0]]))  # both sides move by 2: G u 0
    assert lcp_data_round_off(both, np.array([2.0, 2.0]), np.zeros(1), res) == unit * 4
    res.c = np.array([5e3])  # a bond of strength 5e3 through C_tt = 1e-3: motion 5
    assert lcp_data_round_off(g, np.zeros(2), np.array([0.01]), res) == unit * 5
    res.tau_prev = np.array([7.0])
    assert lcp_data_round_off(g, np.zeros(2), np.zeros(1), res) == unit * 7
