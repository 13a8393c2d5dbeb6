"""A config file's [petsc] table cannot write files or load code (app/petsc_config_guard.py).

Before, a shared config with `ksp_view = "ascii:FILE"` truncated FILE (any file the user
can write), `mat_view = "binary"` wrote `binaryoutput` into the working directory, and
`pc_type = "python"` with `pc_python_type = "os.abort"` imported and called os.abort
(exit 134, a C backtrace). The user's own command line and --set stay unrestricted.
"""

import pytest
from support import CONFIGS, read_summary, run_cli

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
])
def test_file_writing_and_code_loading_options_are_refused(key, value):
    assert refusal(key, value)


@pytest.mark.parametrize("key, value", [
    ("log_view", "true"), ("log_view", ""), ("ksp_view", "ascii"), ("ksp_view", "stdout"),
    ("ksp_monitor", "::ascii_info_detail"), ("ksp_type", "cg"), ("pc_type", "gamg"),
    ("pc_factor_mat_solver_type", "mumps"), ("mat_mumps_icntl_14", "50"),
    ("ksp_rtol", "1e-10"), ("contact_compliance", "solve"),
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
