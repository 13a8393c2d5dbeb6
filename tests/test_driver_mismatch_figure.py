"""`steps[k].lcp_displacement_mismatch` (app/driver/contact.py): max |G u - the LCP's
kinematics| over the larger of the step's max |u| and the size of the LCP's kinematic
data (whose round-off the mismatch carries), so that a step with no load does not read
round-off over round-off."""

from __future__ import annotations

import tomllib

from support import CONFIGS

from app.config import parse_config
from app.driver.contact import mismatch_figure
from app.run import RunOptions, run


def test_the_figure_is_relative_to_the_larger_of_max_u_and_the_lcp_data():
    assert mismatch_figure(1e-15, 0.5, 0.04) == 1e-15 / 0.5
    assert mismatch_figure(1.4e-18, 7.9e-16, 0.04) == 1.4e-18 / 0.04
    assert mismatch_figure(0.0, 0.0, 0.0) == 0.0


def test_an_unloaded_step_after_loaded_ones_reads_round_off(tmp_path):
    """multibody.toml pressed, pushed sideways, then both loads back to 0 (step 3): u is
    round-off (max |u| 7.9e-16) and so is G u - the LCP's kinematics (1.4e-18). Over
    max |u| that read 1.7e-3; over the LCP's data (its largest initial gap, 0.040)
    3.5e-17. The loaded steps read as before (their max |u|, 0.06, is the larger)."""
    raw = tomllib.loads((CONFIGS / "multibody.toml").read_text())
    raw["analysis"]["steps"] = 3
    for load, history in zip(raw["load"], ([1.0, 1.0, 0.0], [0.0, 1.0, 0.0]), strict=True):
        del load["ramp"]
        load["history"] = history
    s = run(parse_config(raw, CONFIGS / "multibody.toml"),
            RunOptions(out=tmp_path / "out", quiet=True))
    figures = [st["lcp_displacement_mismatch"] for st in s["steps"]]
    assert s["steps"][2]["strain_energy"] < 1e-20  # the step is unloaded
    assert max(figures) < 1e-13, figures
    assert [st["consistency_refinements"] for st in s["steps"]] == [0, 0, 0]
