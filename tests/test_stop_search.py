"""A signal while the run sits in the mixed-integer search (app/lcp/mip.py, HiGHS through
scipy.optimize.milp): HiGHS holds the GIL for the whole search (minutes), so neither
Python's handlers nor the watchdog thread could act, and on 1 rank `hard_stop.armed()`
does nothing. The search now runs in a process of its own: the run stops at once with
`interrupted`, and the HiGHS process ends with it."""

from __future__ import annotations

import os
import shutil
import signal
import sys
import time
from pathlib import Path

import pytest
from support import CONFIGS, read_summary, signal_when_ready

# announces the search of step 1's LCP of 98 (pids in the folder argv[1]; rank 0 solves
# the LCPs), its node limit x 50: a search of minutes (README "Floating bodies": up to
# MIP_SECONDS). Not the candidate set's LCP of 95 before it (3 x 1-2 s): a signal after it,
# in a long Lemke call (C, with the GIL), left `running` on 2 ranks (mpiexec's SIGKILL)
ANNOUNCE_SEARCH = """
import os, sys
from pathlib import Path
from app.lcp import mip
real, marks = mip._search, Path(sys.argv.pop(1))

def search(m, q, zb, bound, nodes, seconds):
    (marks / f"rank_{os.getpid()}").touch()
    if q.size >= 98:
        print("ready", flush=True)
    return real(m, q, zb, bound, 50 * nodes, seconds)

mip._search = search
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""

SCENE = ["run", str(CONFIGS / "multibody.toml"), "--sd", "1", "--mesh-size", "1.2",
         "--quiet"]
"""Lemke ends on its secondary ray at step 1 (a few seconds in), where the search takes
10-30 s (its 1,250 nodes)."""


def _searches_left(marks: Path) -> list[int]:
    """The HiGHS processes (app.lcp.mip's children) of the ranks marked in `marks` that
    are still alive 5 s after the run ended."""
    parents = {p.name.split("_")[1] for p in marks.glob("rank_*")}
    assert parents
    end = time.time() + 5
    while True:
        left = []
        for proc in Path("/proc").iterdir():
            try:
                argv = (proc / "cmdline").read_bytes().split(b"\0")
            except OSError:
                continue
            if b"PR_SET_PDEATHSIG" in b"".join(argv) and argv[-2].decode() in parents:
                left.append(int(proc.name))
        if not left or time.time() > end:
            return left
        time.sleep(0.2)


@pytest.mark.parametrize("ranks,sig", [(1, signal.SIGTERM), (1, signal.SIGINT),
                                       (2, signal.SIGTERM)])
def test_a_signal_during_the_search_stops_the_run_at_once(tmp_path, ranks, sig):
    out, marks = tmp_path / "o", tmp_path / "marks"
    marks.mkdir()
    launch = [shutil.which("mpiexec"), "-n", "2"] if ranks > 1 else []
    cmd = [*launch, sys.executable, "-c", ANNOUNCE_SEARCH, str(marks), *SCENE,
           "--out", str(out)]
    res, seen, seconds = signal_when_ready(cmd, sig, settle=1.0, timeout=120)
    assert seconds < 10, f"stopped {seconds:.0f} s after the signal: {res.stderr}"
    assert "Traceback" not in res.stderr, res.stderr
    s = read_summary(out)
    assert s["status"] == "interrupted", res.stderr
    name = "SIGINT" if sig == signal.SIGINT and ranks == 1 else "SIGTERM"
    assert s["error"].startswith(f"interrupted by {name} during step 1/"), s["error"]
    assert f"error: {s['error']}" in res.stderr
    assert _searches_left(marks) == []


def test_the_search_ends_with_its_run_however_it_ends(tmp_path):
    """SIGKILL leaves no HiGHS process behind (PR_SET_PDEATHSIG)."""
    marks = tmp_path / "marks"
    marks.mkdir()
    cmd = [sys.executable, "-c", ANNOUNCE_SEARCH, str(marks), *SCENE,
           "--out", str(tmp_path / "o")]
    res, _, seconds = signal_when_ready(cmd, signal.SIGKILL, settle=1.0, timeout=60)
    assert res.returncode == -signal.SIGKILL and seconds < 5
    assert _searches_left(marks) == []
    assert os.path.exists(tmp_path / "o" / "summary.json")
