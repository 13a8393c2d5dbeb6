"""The command line: parallel runs, output files, and one-line errors on bad input."""

from __future__ import annotations

import json
import time
from pathlib import Path

import h5py
import meshio
import numpy as np
import pytest
from support import CONFIGS, ROOT, mpi_env, read_summary, run_cli

CANTILEVER = CONFIGS / "cantilever.toml"


@pytest.mark.mpi
def test_two_ranks_match_one_rank(tmp_path):
    outs = {}
    for ranks in (1, 2):
        out = tmp_path / f"r{ranks}"
        res = run_cli(["run", str(CANTILEVER), "--out", str(out), "--mesh-size", "0.0625",
                       "--quiet"], ranks=ranks)
        assert res.returncode == 0, res.stderr
        outs[ranks] = out
    s1, s2 = read_summary(outs[1]), read_summary(outs[2])
    assert s1["ranks"] == 1 and s2["ranks"] == 2
    with h5py.File(outs[1] / "step_0001.h5") as a, h5py.File(outs[2] / "step_0001.h5") as b:
        u1, u2 = a["displacement"][()], b["displacement"][()]
        vm1, vm2 = a["von_mises"][()], b["von_mises"][()]
    assert np.abs(u1 - u2).max() <= 1e-10 * np.abs(u1).max()
    assert np.abs(vm1 - vm2).max() <= 1e-9 * np.abs(vm1).max()
    assert abs(s1["strain_energy"] - s2["strain_energy"]) <= 1e-10 * s1["strain_energy"]


def test_outputs_open_with_meshio_and_summary_keys(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["run", str(CANTILEVER), "--out", str(out), "--sd", "2", "-ksp_type",
                   "preonly", "-pc_type", "lu"])
    assert res.returncode == 0, res.stderr
    s = read_summary(out)
    for key in ("method", "sd", "ranks", "n_dofs", "n_elements", "strain_energy",
                "strain_energy_by_body", "timings"):
        assert key in s
    assert s["method"] == "cs-fem" and s["sd"] == 2
    for key in ("mesh", "assembly", "factorization", "solve", "output", "total"):
        assert s["timings"][key] >= 0.0
    assert s["strain_energy_by_body"]["beam"] == pytest.approx(s["strain_energy"])
    assert s["reference"]["tip_deflection_rel_error"] < 0.02
    with meshio.xdmf.TimeSeriesReader(out / "results.xdmf") as reader:
        points, cells = reader.read_points_cells()
        _, point_data, cell_data = reader.read_data(0)
    assert cells[0].type == "quad" and len(cells[0].data) == s["n_elements"]
    assert point_data["displacement"].shape == (s["n_dofs"] // 2, 3)
    for key in ("stress", "von_mises", "strain_energy_density", "body_id"):
        assert key in cell_data
    sed = cell_data["strain_energy_density"][0]
    area = 10.0 / s["n_elements"]  # structured 10 x 1 beam, equal elements
    assert sed.sum() * area == pytest.approx(s["strain_energy"], rel=1e-10)


def test_petsc_options_pass_through(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["run", str(CANTILEVER), "--out", str(out), "--quiet", "-ksp_type", "cg",
                   "-pc_type", "jacobi", "-ksp_rtol", "1e-12", "-ksp_max_it", "20000",
                   "-ksp_view"])
    assert res.returncode == 0, res.stderr
    assert "type: cg" in res.stdout
    ref = tmp_path / "ref"
    assert run_cli(["run", str(CANTILEVER), "--out", str(ref), "--quiet"]).returncode == 0
    assert read_summary(out)["strain_energy"] == pytest.approx(
        read_summary(ref)["strain_energy"], rel=1e-8)


def test_petsc_table_true_is_the_bare_flag(tmp_path):
    """`ksp_monitor = true` in [petsc]: before, `-ksp_monitor true`, read as a viewer
    named 'true' (`error: PETSc: Unsupported viewer true`, exit 2)."""
    out = tmp_path / "o"
    res = run_cli(["run", str(CANTILEVER), "--out", str(out), "--quiet", "--mesh-size", "0.5",
                   "--set", "petsc.ksp_monitor=true", "--set", "petsc.ksp_view=true"])
    assert res.returncode == 0, res.stderr
    assert "KSP Residual norm" in res.stdout and "type: preonly" in res.stdout
    assert "petsc_options_unused" not in read_summary(out)


def test_petsc_table_false_turns_a_viewer_off(tmp_path):
    """`ksp_view = false` in [petsc]: before, `-ksp_view false`, read as a viewer named
    'false' (`error: PETSc: Unsupported viewer false`, exit 2); a viewer set to false is
    now left out (off). A non-viewer option keeps the value "false"."""
    from app.config import load_config

    out = tmp_path / "o"
    res = run_cli(["run", str(CANTILEVER), "--out", str(out), "--quiet", "--mesh-size", "0.5",
                   "--set", "petsc.ksp_monitor=false", "--set", "petsc.ksp_view=false"])
    assert res.returncode == 0, res.stderr
    assert "KSP Residual norm" not in res.stdout and "type: preonly" not in res.stdout
    petsc = load_config(CANTILEVER, ["petsc.ksp_view=false",
                                     "petsc.ksp_initial_guess_nonzero=false"]).petsc
    assert "ksp_view" not in petsc and petsc["ksp_initial_guess_nonzero"] == "false"


def test_help_explains_the_command():
    res = run_cli(["--help"])
    assert res.returncode == 0 and "PETSc" in res.stdout
    res = run_cli(["run", "--help"])
    assert "--mesh-size" in res.stdout and "--sd" in res.stdout


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "scene.toml"
    p.write_text(text)
    return p


BASE = CANTILEVER.read_text()
SHAPE = ('[body.shape]\ntype = "rectangle"\norigin = [0.0, -0.5]\nwidth = 10.0\nheight = 1.0\n'
         'structured = true\n[body.curves]\nleft = "clamp"\nright = "tip_edge"\n')
NO_SHAPE = BASE.replace(SHAPE, "")  # for a mesh.file (a body shape is then an error)
assert NO_SHAPE != BASE


def _bad_input_cases(tmp_path: Path) -> list[tuple[list[str], str]]:
    tri = tmp_path / "tri.msh"
    tri.write_text(
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n2 1 \"beam\"\n"
        "$EndPhysicalNames\n$Entities\n0 0 1 0\n1 0 0 0 1 1 0 1 1 0\n$EndEntities\n"
        "$Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n3\n0 0 0\n1 0 0\n0 1 0\n$EndNodes\n"
        "$Elements\n1 1 1 1\n2 1 2 1\n1 1 2 3\n$EndElements\n"
    )
    unreadable = tmp_path / "garbage.msh"
    unreadable.write_text("this is not a mesh\n")
    return [
        (BASE.replace("size = 0.125", "size_typo = 0.125"), "mesh.size"),
        (BASE.replace('on = "tip_edge"', 'on = "tip_edg"'), "tip_edg"),
        (BASE.replace("E = 1000.0\nnu", "E = -5.0\nnu"), "E must be > 0"),
        (BASE.replace("nu = 0.3\n[body", "nu = 0.5\n[body"), "nu must lie in (-1, 0.5)"),
        (BASE.replace("sd = 4", "sd = 5"), "analysis.sd"),
        (NO_SHAPE.replace("[mesh]\nsize = 0.125", f'[mesh]\nsize = 0.125\nfile = "{tri}"'),
         "triangle"),
        (NO_SHAPE.replace("[mesh]\nsize = 0.125",
                          f'[mesh]\nsize = 0.125\nfile = "{tmp_path / "nope.msh"}"'), "nope.msh"),
        (NO_SHAPE.replace("[mesh]\nsize = 0.125",
                          f'[mesh]\nsize = 0.125\nfile = "{unreadable}"'),
         "garbage.msh"),
        (BASE + "\n[[support]]\non = \"clamp\"\nux = \"undefined_name * x\"\n",
         "undefined_name"),
        ("this is [ not toml", "not valid TOML"),
    ]


def test_bad_input_gives_one_line_error(tmp_path):
    for text, needle in _bad_input_cases(tmp_path):
        cfg = _write(tmp_path, text)
        res = run_cli(["run", str(cfg), "--out", str(tmp_path / "o"), "--quiet"])
        lines = [ln for ln in res.stderr.strip().splitlines() if ln.strip()]
        assert res.returncode == 2, (needle, res.stderr)
        assert len(lines) == 1 and lines[0].startswith("error: "), res.stderr
        assert needle in lines[0], (needle, lines[0])
        assert "Traceback" not in res.stderr


def test_bad_command_line_values(tmp_path):
    res = run_cli(["run", str(CANTILEVER), "--sd", "7", "--out", str(tmp_path / "o")])
    assert res.returncode == 2 and "--sd 7" in res.stderr
    res = run_cli(["run", str(tmp_path / "missing.toml")])
    assert res.returncode == 2 and "missing.toml" in res.stderr


def test_singular_stiffness_is_reported(tmp_path):
    text = (
        '[analysis]\nsd = 1\n[mesh]\nsize = 0.25\n[[body]]\nname = "plate"\nE = 100.0\n'
        'nu = 0.3\n[body.shape]\ntype = "rectangle"\norigin = [0.0, 0.0]\nwidth = 1.0\n'
        'height = 1.0\nstructured = true\n[body.curves]\ntop = "top"\n[points]\n'
        'pin = [0.0, 0.0]\nroller = [1.0, 0.0]\n[[support]]\non = "pin"\nux = 0.0\nuy = 0.0\n'
        '[[support]]\non = "roller"\nuy = 0.0\n[[load]]\non = "top"\ntraction = [0.0, -1.0]\n'
    )
    cfg = _write(tmp_path, text)
    res = run_cli(["run", str(cfg), "--out", str(tmp_path / "o"), "--quiet"])
    assert res.returncode == 2 and "hourglass" in res.stderr and "--sd 2" in res.stderr
    assert "in body 'plate'" in res.stderr
    failed = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert failed["status"] == "failed" and "hourglass" in failed["error"]
    res = run_cli(["run", str(cfg), "--out", str(tmp_path / "o"), "--quiet", "--sd", "2"])
    assert res.returncode == 0, res.stderr
    free = _write(tmp_path, text.replace('on = "roller"', 'on = "pin"'))
    res = run_cli(["run", str(free), "--out", str(tmp_path / "o"), "--quiet", "--sd", "2"])
    assert res.returncode == 2 and "body 'plate' is free to move" in res.stderr
    assert "rotation about (x=0" in res.stderr
    # the failed run's own status, not the earlier completed run's
    failed = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert failed["status"] == "failed" and "free to move" in failed["error"]
    assert not list((tmp_path / "o").glob("step_*.h5"))


def test_log_view_shows_the_phases_as_stages(tmp_path):
    res = run_cli(["run", str(CONFIGS / "hertz.toml"), "--out", str(tmp_path / "o"), "--quiet",
                   "-log_view"])
    assert res.returncode == 0, res.stderr
    for stage in ("mesh", "assembly", "factorization", "compliance", "lcp", "output"):
        assert f" {stage}: " in res.stdout, stage


DEGENERATE_MSH = """$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
2
1 1 "base"
2 2 "plate"
$EndPhysicalNames
$Nodes
6
1 0 0 0
2 1 0 0
3 1 1 0
4 0 1 0
5 2 0 0
6 2 1 0
$EndNodes
$Elements
3
1 1 2 1 1 1 2
2 3 2 2 1 1 2 3 4
3 3 2 2 1 2 5 5 3
$EndElements
"""
FILE_CONFIG = """[mesh]
size = 1.0
file = "plate.msh"
[[body]]
name = "plate"
E = 100.0
nu = 0.3
[[support]]
on = "base"
ux = 0.0
uy = 0.0
"""


def _one_line_cases(tmp_path: Path) -> list[tuple[list[str], str]]:
    (tmp_path / "plate.msh").write_text(DEGENERATE_MSH)
    (tmp_path / "plate.toml").write_text(FILE_CONFIG)
    (tmp_path / "latin1.toml").write_bytes('title = "Müller"\n'.encode("latin-1"))
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    patch, out = str(CONFIGS / "patch.toml"), str(tmp_path / "o")
    return [
        (["run", str(tmp_path / "latin1.toml")], "not UTF-8"),
        (["run", patch, "--out", ""], "--out is empty"),
        (["run", patch, "--out", "/proc/guard_out"], "cannot write there"),
        (["run", patch, "--out", "/proc"], "cannot write there"),
        (["run", patch, "--out", "/dev/null"], "is not a folder"),
        (["run", patch, "--out", str(a_file)], "is not a folder"),
        (["run", patch, "--out", out, "--mesh-cache", str(a_file)], "--mesh-cache"),
        (["run", patch, "--out", out, "-ksp_type", "foo"], "-ksp_type foo: unknown type"),
        (["run", patch, "--out", out, "-pc_type", "foo"], "-pc_type foo: unknown type"),
        (["run", patch, "--out", out, "-pc_factor_mat_solver_type", "nonsense"],
         "-pc_factor_mat_solver_type nonsense"),
        (["run", patch, "--out", out, "-ksp_type"], "-ksp_type needs a value"),
        (["run", patch, "--out", out, "--mesh-size", "1e-4"], "--allow-large"),
        (["study", patch, "--out", out, "--mesh-size", "0.001", "--levels", "6"],
         "--allow-large"),
        (["run", str(tmp_path / "plate.toml"), "--out", out, "--mesh-size", "0.1"],
         "--mesh-size does not apply"),
        (["run", str(tmp_path / "plate.toml"), "--out", out], "repeats a node"),
        (["run", patch, "--out", out, "--method", "fem-q4", "--sd", "8"],
         "--sd does not apply to --method fem-q4"),
        (["run", patch, "--out", out, "--set", 'analysis.method="fem-q4"', "--sd", "8"],
         "--sd does not apply to analysis.method = fem-q4"),  # (before: ignored, exit 0)
    ]


def test_bad_command_lines_give_one_line_and_exit_2(tmp_path):
    for args, needle in _one_line_cases(tmp_path):
        t0 = time.perf_counter()
        res = run_cli([*args, "--quiet"])
        lines = [ln for ln in res.stderr.strip().splitlines() if ln.strip()]
        assert res.returncode == 2, (args, res.stderr)
        assert len(lines) == 1 and lines[0].startswith("error: "), (args, res.stderr)
        assert needle in lines[0], (needle, lines[0])
        assert time.perf_counter() - t0 < 30


def test_misspelled_petsc_option_is_reported_as_unused(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                   "-ksp_typ", "cg", "-ksp_rtol", "1e-12"])
    assert res.returncode == 0, res.stderr
    assert "-ksp_typ" in res.stderr and "-ksp_rtol" in res.stderr  # rtol unused with preonly
    assert read_summary(out)["petsc_options_unused"] == ["-ksp_rtol", "-ksp_typ"]
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet"])
    assert res.returncode == 0 and res.stderr == "" and (
        "petsc_options_unused" not in read_summary(out))


def test_options_left_is_not_reported_as_unused(tmp_path):
    """PETSc reads -options_left only at PetscFinalize, after the summary: it was listed in
    petsc_options_unused (a "misspelled?" option) on every run that asked for the list."""
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                   "-options_left", "-ksp_typ", "cg"])
    assert res.returncode == 0, res.stderr
    assert read_summary(out)["petsc_options_unused"] == ["-ksp_typ"]


PLOT = ROOT / "scripts" / "plot_results.py"


def test_plot_script_errors_and_long_names(tmp_path):
    import subprocess
    import sys

    out = tmp_path / "o"
    long_name = "n" * 5000
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                   "--set", f"interface.0.name={long_name}"])
    assert res.returncode == 0, res.stderr

    def plot(*extra):
        return subprocess.run([sys.executable, str(PLOT), str(out), *extra], cwd=ROOT,
                              env=mpi_env(), capture_output=True, text=True, timeout=300)

    for extra, needle in ((["--step", "99"], "--step 99"), (["--step", "0"], "--step 0")):
        res = plot(*extra)
        lines = [ln for ln in res.stderr.strip().splitlines() if "Warning" not in ln
                 and not ln.startswith(" ")]  # matplotlib's import warnings, if any
        assert res.returncode == 2 and len(lines) == 1 and needle in lines[0], res.stderr
    res = plot()
    assert res.returncode == 0, res.stderr
    names = [p.name for p in out.glob("contact_*.png")]
    assert len(names) == 1 and len(names[0]) <= 120
    res = subprocess.run([sys.executable, str(PLOT), str(tmp_path / "missing")], cwd=ROOT,
                         env=mpi_env(), capture_output=True, text=True, timeout=300)
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    assert res.stderr.strip().splitlines()[-1].startswith("error: "), res.stderr
