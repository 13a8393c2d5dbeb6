"""A config file's [petsc] table cannot write files or load code (app/petsc_config_guard.py).

Before, a shared config with `ksp_view = "ascii:FILE"` truncated FILE (any file the user
can write), `mat_view = "binary"` wrote `binaryoutput` into the working directory, and
`pc_type = "python"` with `pc_python_type = "os.abort"` imported and called os.abort
(exit 134, a C backtrace). The user's own command line and --set stay unrestricted.
"""

import subprocess
import sys

import pytest
from support import CONFIGS, mpi_env, read_summary, run_cli

from app.config import load_config
from app.errors import InputError
from app.petsc_config_guard import refusal


@pytest.mark.parametrize("key, value", [
    ("ksp_view", "ascii:/tmp/x.txt"), ("mat_view", ":notes.txt"), ("log_view", ":log.txt"),
    ("ksp_monitor", "ascii:out.txt:ascii_info_detail"), ("ksp_view_mat", "binary"),
    ("mat_view", "hdf5"), ("ksp_converged_reason", "socket"), ("pc_type", "python"),
    ("ksp_type", "PYTHON"), ("pc_python_type", "os.abort"), ("snes_python_type", "m.C"),
    ("options_file", "/etc/passwd"), ("history", "h.txt"), ("start_in_debugger", "gdb"),
    ("viewer_binary_filename", "b.dat"), ("-ksp_view", "ascii:f"),
    # not on the allow-list (before, accepted: draw_save wrote images anywhere)
    ("draw_save", "/tmp/x.ppm"), ("draw_type", "image"), ("dll_append", "/tmp/evil.so"),
    ("dynamic_library_preload", "e.so"), ("malloc_dump", ""), ("on_error_attach_debugger", ""),
    ("START_IN_DEBUGGER", ""), ("no_such_option", "1"), ("ksp_rtol -options_file", "x"),
    # solver names that draw or write, Python anywhere, units that write fort.N files
    ("ksp_plot_eigenvalues", ""), ("ksp_monitor_lg_residualnorm", ""),
    ("mat_view_draw", ""), ("pc_mg_dump_binary", ""), ("sub_pc_python_type", "m.C"),
    ("pc_composite_pcs", "lu,python"), ("mat_mumps_icntl_2", "58"),
    ("mg_levels_1_mat_mumps_icntl_1", "7"), ("ksp_view", "stdout"), ("ksp_view", "vu"),
    ("ksp_view_eigenvalues", "draw"), ("ksp_monitor", "string"),
    ("ksp_max_it", "2000000000"), ("sub_ksp_max_it", "1e9"), ("ksp_max_it", "many"),
])
def test_file_writing_and_code_loading_options_are_refused(key, value):
    assert refusal(key, value)


@pytest.mark.parametrize("key, value", [
    ("log_view", "true"), ("log_view", ""), ("ksp_view", "ascii"),
    ("ksp_monitor", "::default"), ("ksp_type", "cg"), ("pc_type", "gamg"),
    ("pc_factor_mat_solver_type", "mumps"), ("mat_mumps_icntl_14", "50"),
    ("ksp_rtol", "1e-10"), ("contact_compliance", "solve"),
    ("sub_pc_type", "icc"), ("mg_levels_ksp_type", "chebyshev"), ("mg_levels_2_pc_type", "sor"),
    ("mg_coarse_pc_type", "lu"), ("mat_mumps_icntl_4", "3"), ("mat_mumps_icntl_3", "6"),
    ("mat_mumps_icntl_1", "-1"), ("mat_mumps_icntl_2", "0"), ("ksp_view_eigenvalues", ""),
    ("options_left", ""), ("contact_candidate_pairs", "false"), ("ksp_monitor_short", ""),
    ("ksp_max_it", "100000"), ("mg_levels_ksp_max_it", "2"),
    # inner solvers' prefixes (before, refused as not solver options): GAMG's Chebyshev
    # smoother's eigenvalue estimate, a Schur fieldsplit's inner and upper solvers,
    # PCTELESCOPE, PCREDISTRIBUTE; and -log_view's own flags
    ("mg_levels_esteig_ksp_type", "cg"), ("mg_levels_esteig_ksp_max_it", "10"),
    ("fieldsplit_1_inner_ksp_type", "preonly"), ("fieldsplit_1_upper_pc_type", "jacobi"),
    ("telescope_pc_type", "gamg"), ("redistribute_ksp_type", "cg"),
    ("log_view_memory", ""), ("log_view_gpu_time", ""),
    ("pc_hypre_boomeramg_relax_type_all", "symmetric-SOR/Jacobi"),
    ("pc_hypre_boomeramg_strong_threshold", "0.7"), ("mat_superlu_dist_rowperm", "NOROWPERM"),
    ("mat_mumps_cntl_3", "1e-12"), ("pc_fieldsplit_schur_fact_type", "full"),
])
def test_ordinary_options_are_allowed(key, value):
    assert refusal(key, value) is None


def _config(tmp_path, petsc: str):
    path = tmp_path / "shared.toml"
    path.write_text((CONFIGS / "patch.toml").read_text() + "\n[petsc]\n" + petsc + "\n")
    return path


def test_the_file_table_is_refused_but_set_is_not(tmp_path):
    with pytest.raises(InputError, match=r"petsc.ksp_view = .*not allowed in a config file"):
        load_config(_config(tmp_path, 'ksp_view = "ascii:/tmp/clobber.txt"'))
    cfg = load_config(CONFIGS / "patch.toml", ["petsc.log_view=':/tmp/log.txt'"])
    assert cfg.petsc["log_view"] == ":/tmp/log.txt"  # the user's own command line
    assert load_config(_config(tmp_path, "log_view = true")).petsc["log_view"] == ""  # bare flag


def test_a_shared_config_leaves_files_alone_and_runs_no_code(tmp_path):
    victim = tmp_path / "precious.txt"
    victim.write_text("keep me\n")
    for n, petsc in enumerate([f'ksp_view = "ascii:{victim}"',
                               'pc_type = "python"\npc_python_type = "os.abort"']):
        out = tmp_path / f"o{n}"
        res = run_cli(["run", str(_config(tmp_path, petsc)), "--out", str(out), "--quiet"])
        assert res.returncode == 2, res.stderr
        assert res.stderr.startswith("error: config file") and len(
            res.stderr.strip().splitlines()) == 1, res.stderr
        assert read_summary(out)["status"] == "failed"
    assert victim.read_text() == "keep me\n"


def test_a_shared_config_cannot_draw_images_anywhere_or_write_fortran_units(tmp_path):
    """Before the allow-list: `draw_type = "image"`, `draw_save = FILE` and
    `ksp_plot_eigenvalues = true` wrote FILE_0.ppm ... FILE_25.ppm and a folder FILE
    anywhere, and `mat_mumps_icntl_2 = 58` wrote fort.58 into the working directory."""
    target = tmp_path / "elsewhere" / "victim"
    target.parent.mkdir()
    tables = [f'ksp_type = "gmres"\npc_type = "jacobi"\nksp_plot_eigenvalues = true\n'
              f'draw_type = "image"\ndraw_save = "{target}.ppm"',
              "mat_mumps_icntl_2 = 58"]
    for n, petsc in enumerate(tables):
        out = tmp_path / f"o{n}"
        res = subprocess.run([sys.executable, "-m", "app", "run", str(_config(tmp_path, petsc)),
                              "--out", str(out), "--quiet"], cwd=tmp_path, env=mpi_env(),
                             capture_output=True, text=True, timeout=300)
        assert res.returncode == 2, res.stderr
        assert res.stderr.startswith("error: config file") and "not allowed" in res.stderr
        assert read_summary(out)["status"] == "failed"
    assert list(target.parent.iterdir()) == [] and not list(tmp_path.glob("fort.*"))


def test_a_monitor_format_is_one_line_not_a_segmentation_fault(tmp_path):
    """`ksp_monitor = "::ascii_info_detail"` passes the guard (a viewer to the standard
    output), but PETSc 3.18 has ASCII KSP monitors for the default format only and called
    a NULL monitor: exit 139 at the first iteration, from the config or the command line."""
    table = 'ksp_type = "cg"\npc_type = "jacobi"\nksp_monitor = "::ascii_info_detail"'
    runs = [[str(_config(tmp_path, table))],
            [str(CONFIGS / "patch.toml"), "-ksp_type", "cg", "-pc_type", "jacobi",
             "-mg_levels_ksp_monitor_short", "ascii::ascii_info"]]
    for n, args in enumerate(runs):
        out = tmp_path / f"o{n}"
        res = run_cli(["run", *args, "--out", str(out), "--quiet"])
        assert res.returncode == 2, res.stderr
        assert res.stderr.startswith("error: PETSc option -") and "monitor" in res.stderr
        assert len(res.stderr.strip().splitlines()) == 1, res.stderr
        assert read_summary(out)["status"] == "failed"
    res = run_cli(["run", str(_config(tmp_path, 'ksp_type = "cg"\npc_type = "jacobi"\n'
                                      'ksp_monitor_short = "ascii::default"')),
                   "--out", str(tmp_path / "ok"), "--quiet"])
    assert res.returncode == 0 and "KSP Residual norm" in res.stdout, res.stderr
