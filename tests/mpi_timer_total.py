"""Run under `mpiexec -n 2` by tests/test_timer_total.py: patch.toml with rank 0's phase
timer started 2 s after rank 1's (as when rank 0 writes the first summary.json while
rank 1 goes on). Rank 0 prints the summary's total and the sum of its phases as JSON."""

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
    timer = context.Timer

    def late_on_rank0(*args, **kwargs):
        if rank == 0:
            time.sleep(2.0)
        return timer(*args, **kwargs)

    context.Timer = late_on_rank0
    path = Path(__file__).resolve().parents[1] / "configs" / "patch.toml"
    cfg = parse_config(tomllib.loads(path.read_text()), path)
    s = run(cfg, RunOptions(out=Path(sys.argv[1]), quiet=True))
    if rank == 0:
        t = s["timings"]
        print(json.dumps({"total": t["total"],
                          "phases": sum(v for k, v in t.items() if k != "total")}))


if __name__ == "__main__":
    main()
