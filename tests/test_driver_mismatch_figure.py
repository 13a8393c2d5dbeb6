"""`steps[k].lcp_displacement_mismatch` (app/driver/contact.py): max |G u - the LCP's
kinematics| over the step's max |u|, that scale at least the round-off of the LCP's own
kinematic data over CONSISTENCY_TOL, so that a step with no load does not read round-off
over round-off."""

from __future__ import annotations

import tomllib

from support import CONFIGS

from app.config import parse_config
from app.driver.contact import CONSISTENCY_TOL, mismatch_figure
from app.run import RunOptions, run


def test_the_figure_is_over_max_u_unless_that_is_below_the_datas_round_off():
    assert mismatch_figure(1e-15, 0.5, 5.6e-16) == 1e-15 / 0.5
    # a mismatch at the data's round-off reads CONSISTENCY_TOL, not 1e-18 / 7.9e-16
    assert mismatch_figure(5.6e-16, 7.9e-16, 5.6e-16) == CONSISTENCY_TOL
    assert mismatch_figure(0.0, 0.0, 0.0) == 0.0


def test_an_unloaded_step_after_loaded_ones_reads_round_off(tmp_path):
    """multibody.toml pressed, pushed sideways, then both loads back to 0 (step 3): u is
    round-off (max |u| 7.9e-16) and so is G u - the LCP's kinematics (1.4e-18). Over
    max |u| that read 1.7e-3; now over the round-off of the LCP's data (64 eps x its
    largest initial gap 0.040 = 5.6e-16) / 1e-9, 2.5e-12. The loaded steps read as before
    (max |u| 0.06 is the larger scale there: 2.8e-15 and 4.2e-15)."""
    raw = tomllib.loads((CONFIGS / "multibody.toml").read_text())
    raw["analysis"]["steps"] = 3
    for load, history in zip(raw["load"], ([1.0, 1.0, 0.0], [0.0, 1.0, 0.0]), strict=True):
        del load["ramp"]
        load["history"] = history
    s = run(parse_config(raw, CONFIGS / "multibody.toml"),
            RunOptions(out=tmp_path / "out", quiet=True))
    figures = [st["lcp_displacement_mismatch"] for st in s["steps"]]
    assert s["steps"][2]["strain_energy"] < 1e-20  # the step is unloaded
    assert max(figures[:2]) < 1e-13, figures
    assert figures[2] < 0.1 * CONSISTENCY_TOL, figures  # 2.5e-12 / 1.0e-11 (1.7e-3 before)
    assert [st["consistency_refinements"] for st in s["steps"]] == [0, 0, 0]
