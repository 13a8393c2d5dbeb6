"""Runs on more ranks than the scene needs give the 1-rank answer (tiny meshes, errors)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import pytest

from tests.support import CONFIGS, ROOT, mpi_env, run_cli

HARD = CONFIGS / "hard"


def test_a_singular_stiffness_counts_its_modes_alike_on_any_rank_count(tmp_path):
    """hourglass_1sd.toml at --mesh-size 2.0 is one CS-FEM-1SD element on a pin and a
    roller: 8 DOFs, a stiffness of rank 3, 3 supported DOFs, so 2 zero-energy modes. The
    message quoted MUMPS's null-pivot count, which depends on the distribution: 2 on 1
    rank, 1 on 3 ranks."""
    lines = {}
    for ranks in (1, 3):
        out = tmp_path / f"n{ranks}"
        res = run_cli(["run", str(HARD / "hourglass_1sd.toml"), "--mesh-size", "2.0",
                       "--out", str(out), "--quiet"], ranks=ranks, timeout=120)
        errors = [x for x in res.stderr.splitlines() if x.startswith("error:")]
        assert res.returncode == 2 and len(errors) == 1, res.stderr
        assert "Traceback" not in res.stderr
        summary = json.loads((out / "summary.json").read_text())
        assert summary["status"] == "failed" and errors[0] == f"error: {summary['error']}"
        lines[ranks] = errors[0]
    assert "(2 zero-energy modes)" in lines[1] and "body 'block'" in lines[1]
    assert lines[1] == lines[3]


@pytest.mark.parametrize("where, exc, code, extra", [
    ("mesh", "ValueError", 1, []), ("lcp", "IndexError", 1, []),
    ("lcp", "MemoryError", 2, []), ("contact_output", "RuntimeError", 1, []),
    ("write", "ValueError", 1, []), ("schur_factor", "MemoryError", 2, []),
    ("compliance", "MemoryError", 2, []),
    ("symmetrise", "MemoryError", 2, ["-contact_compliance", "solve"])])
def test_a_failure_on_rank_0_alone_ends_the_job_as_on_one_rank(tmp_path, where, exc, code,
                                                                 extra):
    """An exception that is no user error, raised on rank 0 alone (the mesh, the dense S
    and C of the contact, which only rank 0 holds, each step's LCP, the step's contact
    output or files): the other ranks waited in a collective and the job hung (timeout)
    instead of ending as on 1 rank, exit 1 and rank 0's traceback (a MemoryError: exit 2
    and one line), summary.json `failed`."""
    out = tmp_path / "o"
    cmd = [sys.executable, str(ROOT / "tests" / "mpi_rank0_failure.py"), f"{where}:{exc}",
           "run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet", *extra]
    mpiexec = shutil.which("mpiexec")
    res = subprocess.run([mpiexec, "-n", "3", *cmd], cwd=ROOT, env=mpi_env(),
                         capture_output=True, text=True, timeout=90)
    assert res.returncode == code, res.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed" and f"injected at {where}" in summary["error"]
    assert res.stderr.count("Traceback") == (1 if code == 1 else 0), res.stderr
    assert res.stderr.count("error:") == (1 if code == 2 else 0), res.stderr
    assert "PeerFailure" not in res.stderr


@pytest.mark.slow
def test_a_failure_on_another_rank_alone_ends_the_job(tmp_path):
    """A MemoryError on rank 1 alone, in its share of the element fields: it waited in the
    phase's closing barrier and rank 0 in the fields' gather, and the job hung. Now rank 1
    skips the barrier of a failed phase, waits app/exit_sync.py's OTHER_SECONDS (30 s) for
    the others at the end, prints its line and exits; mpiexec ends the rest (exit 2)."""
    out = tmp_path / "o"
    cmd = [sys.executable, str(ROOT / "tests" / "mpi_rank0_failure.py"), "fields:MemoryError:1",
           "run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet"]
    res = subprocess.run([shutil.which("mpiexec"), "-n", "3", *cmd], cwd=ROOT, env=mpi_env(),
                         capture_output=True, text=True, timeout=100)
    assert res.returncode == 2, res.stderr
    assert "error: out of memory (injected at fields)" in res.stderr
    assert "(rank 1; the other ranks did not fail)" in res.stderr


def test_a_failure_on_rank_1_alone_is_recorded_as_its_failure(tmp_path):
    """Rank 1 fails alone (a MemoryError in its share of the element fields) while rank 0
    waits in the fields' gather until mpiexec's SIGTERM, sent when rank 1 exits: summary.json
    said `interrupted by SIGTERM during step 1/1`, and rank 0 printed
    that line after rank 1's. Now rank 1 leaves its line for rank 0 (app/exit_sync.py):
    `failed` with rank 1's reason, one `error:` line. (OTHER_SECONDS 3 s here, not 30.)"""
    out = tmp_path / "o"
    cmd = [sys.executable, str(ROOT / "tests" / "mpi_rank0_failure.py"),
           "fields:MemoryError:1:3", "run", str(CONFIGS / "patch.toml"), "--out", str(out),
           "--quiet"]
    res = subprocess.run([shutil.which("mpiexec"), "-n", "2", *cmd], cwd=ROOT, env=mpi_env(),
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2, res.stderr
    errors = [x for x in res.stderr.splitlines() if x.startswith("error:")]
    assert len(errors) == 1 and "(rank 1; the other ranks did not fail)" in errors[0], res.stderr
    assert errors[0].startswith("error: out of memory (injected at fields)"), res.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["status"], f"error: {summary['error']}") == ("failed", errors[0])
    assert summary["failed_step"] == 1
    assert not list(out.glob(".failed_rank*"))  # (rank 0 took the note)


def test_a_failure_on_rank_1_alone_in_a_sweep_ends_it_as_failed(tmp_path):
    """The same failure in a sweep's first run: rank 1 took it as the run's own failure
    (a `failed` row) and went on to the next run while rank 0 waited in the first: the job
    hung (killed at 90 s, `interrupted by SIGTERM` from the kill, rank 1's line never
    printed). Now the ranks meet after a failed run (app/exit_sync.py `failed_together`);
    rank 1, alone there, ends the job: the run's and the study's summary.json say
    `failed` with rank 1's line."""
    out = tmp_path / "o"
    cmd = [sys.executable, str(ROOT / "tests" / "mpi_rank0_failure.py"),
           "fields:MemoryError:1:3", "study", str(CONFIGS / "patch.toml"), "--sweep",
           "interface.interface.mu=0.2,0.4", "--out", str(out), "--quiet"]
    res = subprocess.run([shutil.which("mpiexec"), "-n", "2", *cmd], cwd=ROOT, env=mpi_env(),
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2, res.stderr
    errors = [x for x in res.stderr.splitlines() if x.startswith("error:")]
    assert len(errors) == 1 and "(rank 1; the other ranks did not fail)" in errors[0], res.stderr
    for folder in (out / "run_000", out):
        s = json.loads((folder / "summary.json").read_text())
        assert (s["status"], f"error: {s['error']}") == ("failed", errors[0]), folder
    assert not (out / "run_001").exists()
