"""scripts/check_interface_law.py on folders with nothing to audit: a one-line error and
exit 2 (it was a traceback for a missing folder or a run without interfaces, and exit 0
with an empty audit for a run that failed before its first step)."""

from __future__ import annotations

import json
import subprocess
import sys

from tests.support import CONFIGS, ROOT, mpi_env, run_cli


def audit(out) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "scripts/check_interface_law.py", str(out)],
                          cwd=ROOT, env=mpi_env(), capture_output=True, text=True)


def one_line_error(res: subprocess.CompletedProcess, words: str) -> None:
    assert res.returncode == 2, res.stdout + res.stderr
    assert "Traceback" not in res.stderr and res.stderr.count("\n") == 1, res.stderr
    assert res.stderr.startswith("error: ") and words in res.stderr, res.stderr


def test_missing_folder(tmp_path):
    one_line_error(audit(tmp_path / "nowhere"), "summary.json not found")


def test_run_without_interfaces(tmp_path):
    out = tmp_path / "out"
    assert run_cli(["run", str(CONFIGS / "cantilever.toml"), "--out", str(out)]).returncode == 0
    one_line_error(audit(out), "without [[interface]]")


def test_run_that_failed_before_its_first_step(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text(json.dumps({
        "status": "failed", "steps": [],
        "contact_interfaces": {"contact": {"discretisation": "mortar", "n_pairs": 3}}}))
    one_line_error(audit(out), "no completed step")
