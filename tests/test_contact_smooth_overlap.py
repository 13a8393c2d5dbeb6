"""mortar-smooth on a concave coarse master: the smoothed surface makes no initial overlap
(app.contact.mortar.no_made_overlap)."""

from __future__ import annotations

import pytest
from support import read_summary, run_cli

VALLEY = """
[analysis]
plane = "strain"
[mesh]
size = 0.25
[[body]]
name = "lower"
E = 1000.0
nu = 0.3
size = 0.25
[body.shape]
type = "polygon"
points = [[-1.0, 0.0], [1.0, 0.0], [1.0, 0.5], [0.0, 0.45], [-1.0, 0.5]]
[body.curves]
side0 = "lower_base"
side2 = "lower_top"
side3 = "lower_top"
[[body]]
name = "upper"
E = 1000.0
nu = 0.3
size = 0.04
[body.shape]
type = "polygon"
points = [[-1.0, 0.5], [0.0, 0.45], [1.0, 0.5], [1.0, 0.8], [-1.0, 0.8]]
[body.curves]
side0 = "upper_bottom"
side1 = "upper_bottom"
side3 = "upper_top"
[[support]]
on = "lower_base"
ux = 0.0
uy = 0.0
[[support]]
on = "upper_top"
ux = 0.0
uy = 0.0
[[interface]]
name = "contact"
slave = "upper_bottom"
master = "lower_top"
mu = 0.3
search_distance = 0.05
discretisation = "mortar-smooth"
"""


@pytest.mark.parametrize("interference", [False, True])
def test_touching_bodies_on_a_concave_coarse_master_stay_unloaded(tmp_path, interference):
    """Two bodies meeting along the same shallow valley (master 6x coarser than the
    slave, so the master is smoothed), both held, no load: no contact force. The
    B-spline lies above the valley's kink by about h^2 x curvature / 8 = 3e-3; before,
    that overlap pressed the bodies apart (max p 25.7 with E = 1000). With interference
    = true an overlap is an intended fit, and the smoothed one is kept."""
    cfg = tmp_path / "valley.toml"
    cfg.write_text(VALLEY + f"interference = {str(interference).lower()}\n")
    out = tmp_path / "o"
    res = run_cli(["run", str(cfg), "--out", str(out), "--quiet"])
    assert res.returncode == 0, res.stderr
    s = read_summary(out)
    assert s["contact_interfaces"]["contact"]["master_interpolation"] == "quadratic B-spline"
    p_max = s["steps"][0]["interfaces"]["contact"]["max_pressure"]
    if interference:
        assert p_max > 1.0
    else:
        assert p_max < 1e-9 and s["steps"][0]["strain_energy"] < 1e-20
