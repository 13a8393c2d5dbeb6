"""scripts/bench.py: the one runner of the benchmarks."""

from __future__ import annotations

import json
import subprocess
import sys

from tests.support import ROOT, mpi_env

BENCH = ROOT / "scripts" / "bench.py"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(BENCH), *args], cwd=ROOT, env=mpi_env(),
                          capture_output=True, text=True, timeout=600)


def test_lists_every_benchmark_script():
    res = _run("--list")
    assert res.returncode == 0
    names = {line.split()[0] for line in res.stdout.splitlines() if line.strip()}
    scripts = {p.stem[len("bench_"):] for p in (ROOT / "scripts").glob("bench_*.py")}
    assert names == scripts


def test_unknown_benchmark_is_a_one_line_error():
    res = _run("nonexistent")
    assert res.returncode == 2 and res.stderr.startswith("error: unknown benchmark")


def test_runs_a_benchmark_and_tags_its_json_lines(tmp_path):
    log = tmp_path / "bench.jsonl"
    res = _run("lemke", "--log", str(log), "--", "--n", "60")
    assert res.returncode == 0, res.stderr
    records = [json.loads(line) for line in res.stdout.splitlines()]
    assert records and all(r["benchmark"] == "lemke" and "commit" in r for r in records)
    assert log.read_text().count("\n") == len(records)
