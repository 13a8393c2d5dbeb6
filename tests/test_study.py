"""The study command: CSV, plots, fitted rates, mesh reuse."""

from __future__ import annotations

import csv

import numpy as np
from support import CONFIGS, run_cli

from app.study import fitted_rate, parse_methods


def test_study_writes_csv_and_plots_and_reuses_meshes(tmp_path):
    out = tmp_path / "study"
    args = ["study", str(CONFIGS / "cantilever.toml"), "--levels", "3", "--mesh-size", "0.25",
            "--methods", "1,4,q4", "--out", str(out)]
    res = run_cli(args)
    assert res.returncode == 0, res.stderr
    assert "level 2/2 FEM-Q4" in res.stdout  # progress display
    rows = list(csv.DictReader(open(out / "study.csv")))
    assert len(rows) == 9
    for name in ("error_vs_dofs.png", "error_vs_time.png", "energy_vs_sd.png"):
        assert (out / name).stat().st_size > 5000
    for m in ("1SD", "4SD", "FEM-Q4"):
        rr = [r for r in rows if r["method"] == m]
        dofs = np.array([float(r["n_dofs"]) for r in rr])
        err = np.array([float(r["err_tip_deflection"]) for r in rr])
        assert fitted_rate(dofs, err) > 1.8  # second order in h
    for level in range(3):
        e = {r["method"]: float(r["strain_energy"]) for r in rows if int(r["level"]) == level}
        assert e["1SD"] >= e["4SD"] >= e["FEM-Q4"]
    meshes = sorted((out / "mesh_cache").iterdir())
    assert len(meshes) == 1  # level 0 only (levels split it), shared by the methods
    stamps = [p.stat().st_mtime_ns for p in meshes]
    res = run_cli([*args, "--quiet"])
    assert res.returncode == 0 and res.stdout == ""
    assert [p.stat().st_mtime_ns for p in sorted((out / "mesh_cache").iterdir())] == stamps


def test_study_rejects_bad_methods_and_configs(tmp_path):
    res = run_cli(["study", str(CONFIGS / "cantilever.toml"), "--methods", "5"])
    assert res.returncode == 2 and "--methods" in res.stderr
    res = run_cli(["study", str(CONFIGS / "patch.toml"), "--out", str(tmp_path)])
    assert res.returncode == 2 and "[reference]" in res.stderr
    assert parse_methods("1, 16,q4") == [("cs-fem", 1), ("cs-fem", 16), ("fem-q4", 4)]
