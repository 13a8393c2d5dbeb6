"""A study whose reference values are 0 (no load, or a contact that never closes): NaN
relative errors and readable tables, not a ZeroDivisionError traceback with no tables."""

from __future__ import annotations

import math

import numpy as np
from support import CONFIGS, read_csv, run_cli

from app.studies.reference_errors import add_reference_errors, energy_bracket, relative_error


def test_relative_errors_against_zero_are_nan():
    assert relative_error(2.0, 4.0) == 0.5 and math.isnan(relative_error(1.0, 0.0))
    x = np.linspace(-1, 1, 5)
    prof = {"energy": 0.0, "n_dofs": 10, "points": {"tip": 0.0}, "x": x, "p": 0 * x,
            "q": 0 * x, "p_max": 0.0}
    rows = [{"level": lv, "method": m, "strain_energy": 0.0, "n_dofs": 10}
            for lv in (0, 1) for m in ("1SD", "4SD")]
    add_reference_errors(rows, {(r["level"], r["method"]): prof for r in rows}, "4SD",
                         {"energy": 0.0, "p_max": 0.0})
    assert all(math.isnan(r["ref_energy"]) for r in rows)
    (b0, b1) = energy_bracket([r | {"method": "FEM-Q4" if r["method"] == "4SD" else "1SD"}
                               for r in rows])
    assert math.isnan(b0["width_rel"]) and math.isnan(b1["order_width"])


def test_a_study_of_an_unloaded_scene_writes_its_tables(tmp_path):
    out = tmp_path / "s"
    res = run_cli(["study", str(CONFIGS / "hertz.toml"), "--levels", "3", "--methods", "4",
                   "--set", "load.0.total_force=[0.0,0.0]", "--quiet", "--out", str(out)])
    assert res.returncode == 0, res.stderr  # before: exit 1, ZeroDivisionError traceback
    assert "Traceback" not in res.stderr and "could not be refreshed" not in res.stderr
    rows = read_csv(out / "study.csv")
    assert len(rows) == 3 and all(r["ref_energy"] == "nan" for r in rows)
    assert "| 4SD | 2 |" in (out / "study_tables.md").read_text()
    assert (out / "error_vs_dofs.png").is_file()
