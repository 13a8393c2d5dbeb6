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
