"""`run --energy-bracket` (app/studies/energy_bracket.py): U(1SD) >= U(4SD) >= U(FEM-Q4)
under loads."""

from __future__ import annotations

from support import CONFIGS, read_summary, run_cli


def test_run_reports_the_energy_bracket(tmp_path):
    out = tmp_path / "cant"
    res = run_cli(["run", str(CONFIGS / "cantilever.toml"), "--energy-bracket", "--out",
                   str(out), "--quiet"])
    assert res.returncode == 0, res.stderr
    s = read_summary(out)
    b = s["energy_bracket"]
    assert b["upper_method"] == "CS-FEM-1SD" and b["lower_method"] == "FEM-Q4"
    assert b["extra_runs"] == ["CS-FEM-1SD", "FEM-Q4"]  # the run is 4SD: two extra solves
    assert b["lower"] < s["strain_energy"] < b["upper"] and b["contains_run"]
    assert b["width_rel"] == (b["upper"] - b["lower"]) / (0.5 * (b["upper"] + b["lower"]))
    one = read_summary(out / "bracket_CS-FEM-1SD")
    assert one["strain_energy"] == b["upper"]
    res = run_cli(["run", str(CONFIGS / "cantilever.toml"), "--method", "fem-q4",
                   "--energy-bracket", "--out", str(tmp_path / "q4"), "--quiet"])
    assert res.returncode == 0, res.stderr
    b = read_summary(tmp_path / "q4")["energy_bracket"]
    assert b["extra_runs"] == ["CS-FEM-1SD"] and b["width"] == b["upper"] - b["lower"]


def test_the_extra_runs_are_a_phase_of_the_run(tmp_path):
    """The bound runs' seconds were in no phase and not in the run's total."""
    out = tmp_path / "cant"
    res = run_cli(["run", str(CONFIGS / "cantilever.toml"), "--energy-bracket", "--out",
                   str(out), "--quiet"])
    assert res.returncode == 0, res.stderr
    t = read_summary(out)["timings"]
    extra = sum(read_summary(out / f"bracket_{lab}")["timings"]["total"]
                for lab in ("CS-FEM-1SD", "FEM-Q4"))
    assert t["energy_bracket"] >= extra
    phases = sum(v for k, v in t.items() if k != "total")
    assert abs(phases - t["total"]) <= 0.05 * t["total"]
