"""Bad input found before the run starts (config, --set, size checks) is recorded in
OUT/summary.json as `failed` too (app/startup/input_failure.py)."""

from __future__ import annotations

import fcntl

import pytest
from support import CONFIGS, read_summary, run_cli

PATCH = str(CONFIGS / "patch.toml")


def _one_line_error(res) -> str:
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), res.stderr
    return lines[0]


@pytest.mark.parametrize("args, reason", [
    (["--set", "interface.interface.discretisation=3"], "discretisation must be a name"),
    (["--set", "interface.interface.mu='x'"], "mu must be a finite number"),
    (["--set", "analysis.sdd=3"], "unknown key analysis.sdd"),
    (["--mesh-size", "1e-5"], "more than this machine's"),
])
def test_input_error_replaces_an_earlier_completed_summary(tmp_path, args, reason):
    """A completed run, then a run into the same OUT with a mistake found before meshing:
    summary.json says failed and why (before: no summary.json, or the earlier run's
    `completed` one), and the earlier run's step files are gone as for any new run."""
    out = tmp_path / "o"
    first = run_cli(["run", PATCH, "--out", str(out), "--quiet"])
    assert first.returncode == 0, first.stderr
    assert (out / "step_0001.h5").exists()
    res = run_cli(["run", PATCH, "--out", str(out), "--quiet", *args])
    assert reason in _one_line_error(res)
    s = read_summary(out)
    assert s["status"] == "failed" and reason in s["error"]
    assert s["failed_step"] == 1 and s["steps"] == []
    assert s["provenance"]["overrides"] == [a for a in args[1::2] if args[0] == "--set"]
    assert not (out / "step_0001.h5").exists() and not (out / "results.xdmf").exists()


def test_input_error_leaves_a_locked_folder_alone(tmp_path):
    """Another run holds OUT: the config's error is reported, its files are untouched."""
    out = tmp_path / "o"
    out.mkdir()
    (out / "summary.json").write_text('{"status": "running"}')
    with open(out / ".lock", "a") as fh:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        res = run_cli(["run", PATCH, "--out", str(out), "--quiet", "--set",
                       "interface.interface.mu='x'"])
    assert "mu must be a finite number" in _one_line_error(res)
    assert read_summary(out) == {"status": "running"}


@pytest.mark.mpi
def test_input_error_on_two_ranks(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["run", PATCH, "--out", str(out), "--quiet", "--set",
                   "interface.interface.mu='x'"], ranks=2)
    assert res.returncode != 0
    assert res.stderr.count("error: interface 'interface': mu must be") == 1
    s = read_summary(out)
    assert s["status"] == "failed" and "mu must be a finite number" in s["error"]
    assert s["provenance"]["ranks"] == 2


@pytest.mark.parametrize("args, reason", [
    (["--sd", "x"], "argument --sd: invalid int value: 'x'"),
    (["--method", "nope"], "argument --method: invalid choice: 'nope'"),
    (["-options_file", "/nonexistent/opts"], "PETSc cannot start with the options"),
])
def test_a_refused_command_line_replaces_an_earlier_completed_summary(tmp_path, args, reason):
    """Refused before PETSc starts (argparse, or PETSc's own start): summary.json says
    failed with the printed line (before: the earlier run's `completed` one stayed), and
    the earlier run's files are gone as for any new run."""
    out = tmp_path / "o"
    first = run_cli(["run", PATCH, "--out", str(out), "--quiet"])
    assert first.returncode == 0, first.stderr
    res = run_cli(["run", PATCH, "--out", str(out), "--quiet", *args])
    assert res.returncode == 2
    line = res.stderr.strip().splitlines()[-1]
    assert reason in line and line.endswith(read_summary(out)["error"])
    s = read_summary(out)
    assert s["status"] == "failed" and s["steps"] == [] and s["config"] == PATCH
    assert not (out / "step_0001.h5").exists() and not (out / "results.xdmf").exists()


def test_an_out_under_a_file_is_named_with_the_config_error(tmp_path):
    (tmp_path / "f").write_text("")
    res = run_cli(["run", PATCH, "--out", str(tmp_path / "f" / "o"), "--quiet", "--set",
                   "interface.interface.mu='x'"])
    line = _one_line_error(res)
    assert "mu must be a finite number" in line
    assert f"no summary.json written: --out {tmp_path / 'f' / 'o'}: cannot write there" in line
