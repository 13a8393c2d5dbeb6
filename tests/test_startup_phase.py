"""Every second of a run from PETSc's start-up is in a named phase: `startup` holds the
imports, the config checks, the provenance and the --out lock before the first phase.
Before, the run's clock started after them (0.2-0.45 s on hertz.toml, up to half of a
small run's time, in no phase and not in `total`; -log_view's Main Stage)."""

import subprocess
import sys

from support import CONFIGS, ROOT, mpi_env, read_summary

SLOW_CONFIG = """
import sys, time
import app.config
load = app.config.load_config
def slow(*a, **k):
    time.sleep(0.5)
    return load(*a, **k)
app.config.load_config = slow
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_time_before_the_first_phase_is_the_startup_phase(tmp_path):
    out = tmp_path / "o"
    res = subprocess.run([sys.executable, "-c", SLOW_CONFIG, "run",
                          str(CONFIGS / "patch.toml"), "--out", str(out)], cwd=ROOT,
                         env=mpi_env(), capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    mesh = next(ln for ln in res.stderr.splitlines() if "] mesh " in ln)
    assert float(mesh.split("]")[0].strip("[ s")) >= 0.5  # elapsed from the start-up
    t = read_summary(out)["timings"]
    assert t["startup"] >= 0.5 and t["total"] >= 0.5 + t["mesh"]
    phases = sum(v for k, v in t.items() if k != "total")
    assert abs(phases - t["total"]) <= 0.05 * t["total"], t
