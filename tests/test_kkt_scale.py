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
