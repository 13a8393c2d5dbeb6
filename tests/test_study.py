"""The study command: CSV, plots, fitted rates, mesh reuse."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
from support import CONFIGS, ROOT, read_csv, read_summary, run_cli

from app.studies.convergence import energy_title, fitted_rate, parse_methods


def test_study_writes_csv_and_plots_and_reuses_meshes(tmp_path):
    out = tmp_path / "study"
    args = ["study", str(CONFIGS / "cantilever.toml"), "--levels", "3", "--mesh-size", "0.25",
            "--methods", "1,4,q4", "--reference", "finest", "--out", str(out)]
    res = run_cli(args)
    assert res.returncode == 0, res.stderr
    # progress display: the level as in L2_FEM-Q4 and study.csv, with the range run (before,
    # "level 2/2", the last of three levels)
    assert "level 2 of 0..2 FEM-Q4" in res.stdout
    rows = read_csv(out / "study.csv")
    assert len(rows) == 9
    for name in ("error_vs_dofs.png", "error_vs_time.png", "energy_vs_sd.png"):
        assert (out / name).stat().st_size > 5000
    for m in ("1SD", "4SD", "FEM-Q4"):
        rr = [r for r in rows if r["method"] == m]
        levels = np.array([float(r["level"]) for r in rr])
        err = np.array([float(r["err_tip_deflection"]) for r in rr])
        assert fitted_rate(levels, err) > 1.8  # second order in h
    for level in range(3):
        e = {r["method"]: float(r["strain_energy"]) for r in rows if int(r["level"]) == level}
        assert e["1SD"] >= e["4SD"] >= e["FEM-Q4"]
    # errors against the model reference (finest 4SD), observed orders, energy bracket
    assert all(r["ref_energy"] == "nan" for r in rows if r["method"] == "4SD"
               and int(r["level"]) == 2)
    for m in ("1SD", "FEM-Q4"):
        rr = sorted((r for r in rows if r["method"] == m), key=lambda r: int(r["level"]))
        assert float(rr[0]["ref_energy"]) > float(rr[1]["ref_energy"]) > 0
        assert float(rr[1]["order_ref_tip"]) > 1.5 and rr[0]["order_ref_tip"] in ("", "nan")
    bracket = read_csv(out / "energy_bracket.csv")
    widths = [float(b["width_rel"]) for b in bracket]
    assert len(widths) == 3 and widths[0] > widths[1] > widths[2] > 0
    assert all(b["one_sd_is_upper"] == "True" for b in bracket)
    assert "observed order" in (out / "study_tables.md").read_text()
    assert (out / "energy_bracket.png").stat().st_size > 5000
    s = read_summary(out)  # the study's own summary.json (before: none in OUT)
    assert (s["status"], s["study"], s["rows"], s["results"]) == ("completed", "convergence",
                                                                   9, "study.csv")
    meshes = sorted((out / "mesh_cache").iterdir())
    assert len(meshes) == 1  # level 0 only (levels split it), shared by the methods
    stamps = [p.stat().st_mtime_ns for p in meshes]
    res = run_cli([*args, "--quiet"])
    assert res.returncode == 0 and res.stdout == ""
    assert [p.stat().st_mtime_ns for p in sorted((out / "mesh_cache").iterdir())] == stamps


def test_study_rejects_bad_methods_and_configs(tmp_path):
    res = run_cli(["study", str(CONFIGS / "cantilever.toml"), "--methods", "5", "--out",
                   str(tmp_path / "m")])  # (without --out: a failed summary in out/)
    assert res.returncode == 2 and "--methods" in res.stderr
    res = run_cli(["study", str(CONFIGS / "patch.toml"), "--out", str(tmp_path)])
    assert res.returncode == 2 and "[reference]" in res.stderr
    assert parse_methods("1, 16,q4") == [("cs-fem", 1), ("cs-fem", 16), ("fem-q4", 4)]


def test_study_methods_named_twice_run_once():
    """'4,4' ran 4SD twice into the same folder L<l>_4SD: duplicate study.csv rows."""
    assert parse_methods("4,4,q4,fem-q4,4") == [("cs-fem", 4), ("fem-q4", 4)]


def test_study_remesh_and_contact_reference_columns(tmp_path):
    out = tmp_path / "hz"
    res = run_cli(["study", str(CONFIGS / "hertz.toml"), "--levels", "2", "--mesh-size", "1.0",
                   "--methods", "4,q4", "--reference-method", "FEM-Q4", "--out", str(out),
                   "--quiet"])
    assert res.returncode == 0, res.stderr
    rows = read_csv(out / "study.csv")
    for r in rows:
        assert float(r["err_pressure_l2_interp"]) >= float(r["floor_pressure_l2_interp"]) * 0.5
        is_ref = r["method"] == "FEM-Q4" and r["level"] == "1"
        assert (r["ref_pressure_l2"] == "nan") == is_ref
        if not is_ref:
            assert 0 < float(r["ref_pressure_l2"]) < 0.5 and 0 <= float(r["ref_p_max"]) < 0.5
    l0, l1 = (next(r for r in rows if r["method"] == "4SD" and r["level"] == lv)
              for lv in ("0", "1"))
    assert float(l1["ref_pressure_l2"]) < 0.5 * float(l0["ref_pressure_l2"])  # converging
    assert len(list((out / "mesh_cache").iterdir())) == 1
    out2 = tmp_path / "remesh"
    res = run_cli(["study", str(CONFIGS / "cantilever.toml"), "--levels", "2", "--methods",
                   "4", "--remesh", "--out", str(out2), "--quiet"])
    assert res.returncode == 0, res.stderr
    assert len(list((out2 / "mesh_cache").iterdir())) == 2  # gmsh meshes every level
    res = run_cli(["study", str(CONFIGS / "cantilever.toml"), "--methods", "4",
                   "--reference-method", "1SD", "--out", str(out2)])
    assert res.returncode == 2 and "--reference-method" in res.stderr


def test_energy_plot_title_names_the_bound_the_runs_show():
    """energy_vs_sd.png said "1SD upper, FEM-Q4 lower" also where the runs show the
    reverse (displacements prescribed, e.g. cattaneo.toml: U(1SD) 4.6 < U(FEM-Q4) 10.3)."""
    def rows(u1, uq):
        return [{"level": k, "method": m, "strain_energy": u}
                for k, (a, b) in enumerate(zip(u1, uq, strict=True))
                for m, u in (("1SD", a), ("4SD", 0.5 * (a + b)), ("FEM-Q4", b))]
    assert energy_title(rows([2.0, 1.9], [1.0, 1.5])) == "energy bounds: 1SD upper, FEM-Q4 lower"
    assert energy_title(rows([4.6, 7.3], [10.3, 9.0])) == "energy bounds: FEM-Q4 upper, 1SD lower"
    assert "bounds" not in energy_title(rows([2.0, 1.0], [1.0, 1.5]))
    assert "bounds" not in energy_title([r for r in rows([2.0], [1.0]) if r["method"] != "1SD"])


def test_sweep_only_options_without_sweep_are_an_error(tmp_path):
    """--refine 2 (or --at-step) on a convergence study was silently ignored."""
    for opt in (["--refine", "2"], ["--at-step", "3"]):
        res = run_cli(["study", str(CONFIGS / "cantilever.toml"), *opt, "--levels", "1",
                       "--methods", "4", "--out",
                       str(tmp_path), "--quiet"])
        assert res.returncode == 2
        assert res.stderr.strip().splitlines() == [
            "error: --at-step and --refine apply with --sweep only (a convergence study "
            "refines by --levels and --first-level)"]


def test_convergence_options_with_sweep_are_an_error(tmp_path):
    """--methods 1 (or --levels 2) with --sweep was silently ignored: the sweep ran the
    config's method on its mesh."""
    for opt in (["--methods", "1"], ["--levels", "2"], ["--remesh"]):
        res = run_cli(["study", str(CONFIGS / "bonded.toml"), "--sweep", "interface.bond.c=4",
                       *opt, "--out", str(tmp_path), "--quiet"])
        assert res.returncode == 2
        lines = res.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"error: {opt[0]} does not apply")


def test_plots_import_matplotlib_without_a_warning():
    """With Debian's matplotlib on the path too (the venv sees the system's packages, e.g.
    ParaView's), every study and sweep printed "UserWarning: Unable to import Axes3D"."""
    res = subprocess.run([sys.executable, "-W", "error::UserWarning", "-c",
                          "from app.plotting import pyplot; pyplot()"], cwd=ROOT,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr


REFRESH_FAILS = """
import sys
import app.studies.convergence
real = app.studies.convergence.finish_study

def finish(*args, plots=True, **kwargs):
    if not plots:
        raise ValueError("made up")
    return real(*args, plots=plots, **kwargs)

app.studies.convergence.finish_study = finish
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_a_failing_table_refresh_between_runs_is_a_warning(tmp_path):
    """The tables are refreshed after each run on rank 0 only: an exception there must not
    end the study (on several ranks rank 0 alone would have left)."""
    out = tmp_path / "s"
    res = subprocess.run([sys.executable, "-c", REFRESH_FAILS, "study",
                          str(CONFIGS / "cantilever.toml"), "--levels", "2", "--methods", "4",
                          "--out", str(out), "--quiet"], cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert res.stderr.count("warning: the study's tables could not be refreshed") == 2
    assert len(read_csv(out / "study.csv")) == 2
    assert (out / "study_tables.md").exists()


def test_energy_vs_sd_runs_in_increasing_sd_whatever_the_methods_order():
    from app.studies.convergence import sd_series

    rows = {"16SD": {"strain_energy": 1.82}, "1SD": {"strain_energy": 1.86},
            "4SD": {"strain_energy": 1.83}, "FEM-Q4": {"strain_energy": 1.81}}
    assert sd_series(rows, ["FEM-Q4", "16SD", "1SD", "4SD"]) == ([1, 4, 16],
                                                                [1.86, 1.83, 1.82])
    assert sd_series(rows, ["2SD", "16SD"]) == ([16], [1.82])  # a level without 2SD
