"""SIGPIPE stays ignored through a run, as Python has it: PETSc's start and gmsh.initialize
reset it to the default action, which ends the process silently on a write to a pipe
without a reader. Under mpiexec that was the race of a signal during the mixed-integer
search on 2 ranks: Open MPI's mpiexec, sent SIGTERM, sends SIGCONT to each rank's process
group, 1 s later SIGTERM, and SIGKILL as soon as a rank has ended; that SIGTERM also
killed rank 0's HiGHS process (app/lcp/mip.py) while rank 0 wrote the problem into it,
rank 0 died of SIGPIPE 40 ms later, before its watchdog had written `interrupted` or its
line, and summary.json said `running` (3 of 3 signals in the candidate LCP's searches)."""

from __future__ import annotations

import shutil
import signal
import sys

from support import CONFIGS, read_summary, signal_when_ready

# the HiGHS process waits before it reads its problem (numpy's and scipy's imports take
# 0.3 s of each 0.5 s search here): rank 0 sits in writing the npz (433 kB for the LCP of
# 95, beyond a pipe's 64 kB) when mpiexec's SIGTERM kills that process
SLOW_READER = """
import sys
from app.lcp import mip
first = "import numpy as np"
assert first in mip._CHILD  # (else the search would not wait)
mip._CHILD = mip._CHILD.replace(first, "import time; time.sleep(30)\\n" + first, 1)
real = mip._search

def search(m, q, zb, bound, nodes, seconds):
    print("ready", flush=True)
    return real(m, q, zb, bound, nodes, seconds)

mip._search = search
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""

SCENE = ["run", str(CONFIGS / "multibody.toml"), "--sd", "1", "--mesh-size", "1.2",
         "--quiet"]
"""Lemke ends on its secondary ray at step 1, a few seconds in: its searches follow."""


def _sigpipe_ignored() -> bool:
    """Whether this process ignores SIGPIPE (its kernel disposition, not Python's note)."""
    with open("/proc/self/status") as fh:
        mask = next(int(line.split()[1], 16) for line in fh if line.startswith("SigIgn"))
    return bool(mask >> (signal.SIGPIPE - 1) & 1)


def test_meshing_leaves_sigpipe_ignored():
    from app.mesh.build import _gmsh_session

    signal.signal(signal.SIGPIPE, signal.SIG_IGN)
    with _gmsh_session():
        assert _sigpipe_ignored()
    assert _sigpipe_ignored()


def test_a_signal_while_rank_0_feeds_its_search_is_recorded(tmp_path):
    """3 signals, each while rank 0 writes a search's problem into its HiGHS process."""
    for k in range(3):
        out = tmp_path / f"o{k}"
        cmd = [shutil.which("mpiexec"), "-n", "2", sys.executable, "-c", SLOW_READER,
               *SCENE, "--out", str(out)]
        res, _, seconds = signal_when_ready(cmd, signal.SIGTERM, settle=0.3, timeout=120)
        assert seconds < 10, res.stderr
        s = read_summary(out)
        assert s["status"] == "interrupted", (k, res.stderr)
        assert s["error"].startswith("interrupted by SIGTERM during step 1/"), s["error"]
        assert f"error: {s['error']}" in res.stderr, (k, res.stderr)


def test_a_closed_stderr_pipe_neither_ends_nor_fails_the_run(tmp_path):
    """`python -m app run ... 2>&1 | head -1`: with SIGPIPE at its default the run died at
    its next progress line (exit -13 / 141, summary.json `running`); ignored, without
    app/output/closed_pipes.py it failed (`cannot write the results into OUT: Broken
    pipe`). Now the lines go to /dev/null and the run completes."""
    import subprocess

    from support import ROOT, mpi_env

    out = tmp_path / "o"
    proc = subprocess.Popen([sys.executable, "-m", "app", "run", str(CONFIGS / "hertz.toml"),
                             "--out", str(out)], cwd=ROOT, env=mpi_env(),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    proc.stderr.close()  # the reader has gone before the first line
    assert proc.wait(timeout=120) == 0
    assert read_summary(out)["status"] == "completed"


SEARCH_ALONE = """
import sys
import numpy as np
from app.lcp import mip
first = "import numpy as np"
mip._CHILD = mip._CHILD.replace(first, "import time; time.sleep(60)\\n" + first, 1)
print("ready", flush=True)
mip._search(np.eye(2), -np.ones(2), np.ones(2), 1.0, 10, 30.0)
"""


def _children(pid: int) -> list[int]:
    with open(f"/proc/{pid}/task/{pid}/children") as fh:
        return [int(p) for p in fh.read().split()]


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_the_search_process_outlives_a_group_signal_not_its_run():
    """The HiGHS process runs in a session of its own: mpiexec's SIGTERM to a rank's process
    group (and Ctrl-C's SIGINT to the terminal's) reaches the rank, not HiGHS, so the rank's
    watchdog records the stop instead of the search reporting `HiGHS was stopped by SIGTERM
    from outside (exit -15)`; the parent-death signal still ends it with the rank (here: the
    rank dies of SIGTERM)."""
    import os
    import subprocess
    import time

    from support import ROOT, mpi_env

    proc = subprocess.Popen([sys.executable, "-c", SEARCH_ALONE], cwd=ROOT, env=mpi_env(),
                            stdout=subprocess.PIPE, start_new_session=True)
    try:
        assert proc.stdout.readline().strip() == b"ready"
        end = time.monotonic() + 20
        while not _children(proc.pid) and time.monotonic() < end:
            time.sleep(0.05)
        (child,) = _children(proc.pid)
        assert os.getpgid(child) != os.getpgid(proc.pid)
        os.killpg(proc.pid, signal.SIGTERM)
        assert proc.wait(timeout=10) == -signal.SIGTERM
        end = time.monotonic() + 5
        while _alive(child) and time.monotonic() < end:
            time.sleep(0.05)
        assert not _alive(child)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
