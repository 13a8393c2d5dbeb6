"""A signal during the mixed-integer search on several ranks: does every stop record itself?

Runs `mpiexec -n RANKS python -m app run configs/multibody.toml --sd 1 --mesh-size 1.2`
(Lemke ends on its secondary ray at step 1; the searches of its LCPs of 95, then 98,
follow, app/lcp/mip.py) and sends SIGTERM to mpiexec DELAY s after the second search of
the LCP of 95 starts, for each delay. One line per trial: the delay, the seconds from the
signal to the job's end, summary.json's status and whether the `error:` line came; the
counts close the output; exit 1 if a trial left anything but `interrupted` with its line.

    .venv/bin/python scripts/stop_in_search.py --delays 0,0.1,0.2,0.3,0.4,0.5,0.6,0.8,1,1.2
"""

from __future__ import annotations

import argparse
import json
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from app_runner import ENV, ROOT, app_command  # noqa: E402

HOOK = f"""
import sys
sys.path.insert(0, {str(ROOT)!r})
from app.lcp import mip
real, seen = mip._search, []

def search(m, q, zb, bound, nodes, seconds):
    seen.append(q.size)
    if seen.count(95) == 2 and q.size == 95:
        print("ready", flush=True)
    return real(m, q, zb, bound, nodes, seconds)

mip._search = search
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def trial(delay: float, ranks: int, out: Path) -> tuple[float, str, bool]:
    """(seconds from the signal to the end, summary.json's status, whether the line came)."""
    shutil.rmtree(out, ignore_errors=True)
    args = ["run", str(ROOT / "configs" / "multibody.toml"), "--sd", "1", "--mesh-size",
            "1.2", "--quiet", "--out", str(out)]
    proc = subprocess.Popen(app_command(args, ranks, HOOK), cwd=ROOT, env=ENV, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    while "ready" not in (line := proc.stdout.readline()):
        if not line:
            break
    time.sleep(delay)
    t0 = time.time()
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    try:
        status = json.loads((out / "summary.json").read_text())["status"]
    except (OSError, ValueError, KeyError):
        status = "unreadable"
    return time.time() - t0, status, "error: interrupted by SIGTERM" in err


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--delays", default="0,0.25,0.5,1.0", help="comma list of seconds")
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("/tmp/stop_in_search"))
    opts = ap.parse_args()
    try:
        delays = [float(d) for d in opts.delays.split(",")]
    except ValueError:
        print(f"error: --delays {opts.delays}: give seconds separated by commas",
              file=sys.stderr)
        return 2
    good = 0
    for delay in delays:
        seconds, status, line = trial(delay, opts.ranks, opts.out)
        good += status == "interrupted" and line
        print(f"delay {delay:.2f} s: ended {seconds:.2f} s after the signal, {status}, "
              f"line {'printed' if line else 'missing'}", flush=True)
    print(f"{good} of {len(delays)} interrupted with their line")
    return 0 if good == len(delays) else 1


if __name__ == "__main__":
    sys.exit(main())
