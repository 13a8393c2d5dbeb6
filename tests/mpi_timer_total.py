"""Run under `mpiexec -n 2` by tests/test_timer_total.py: patch.toml with rank 0's phase
clock started 2 s after rank 1's (as when rank 0 writes the first summary.json while
rank 1 goes on; the clock of a run without `startup` starts in RunContext). Rank 0
prints the summary's total and the sum of its phases as JSON."""

from __future__ import annotations

import json
import sys
import time
import tomllib
from pathlib import Path

from petsc4py import PETSc

import app.driver.context as context
from app.config import parse_config
from app.run import RunOptions, run


def main() -> None:
    rank = PETSc.COMM_WORLD.getRank()
    start_clock = context.RunContext.__post_init__  # (where a study's run starts its clock)

    def late_on_rank0(self):
        if rank == 0:
            time.sleep(2.0)
        start_clock(self)

    context.RunContext.__post_init__ = late_on_rank0
    path = Path(__file__).resolve().parents[1] / "configs" / "patch.toml"
    cfg = parse_config(tomllib.loads(path.read_text()), path)
    s = run(cfg, RunOptions(out=Path(sys.argv[1]), quiet=True))
    if rank == 0:
        t = s["timings"]
        print(json.dumps({"total": t["total"],
                          "phases": sum(v for k, v in t.items() if k != "total")}))


if __name__ == "__main__":
    main()
