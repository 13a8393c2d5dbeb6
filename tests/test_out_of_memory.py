"""Running out of memory inside a run is one line, exit 2, with summary.json failed and
the reason; before, numpy's MemoryError was a traceback with exit 1."""

import subprocess
import sys

from support import CONFIGS, ROOT, mpi_env, read_summary

NO_MEMORY = """
import sys
import app.run
def condense(*a, **k):
    raise MemoryError("Unable to allocate 7.63 GiB for an array with shape (31999, 31999)")
app.run.condense = condense
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_memory_error_is_one_line(tmp_path):
    out = tmp_path / "o"
    res = subprocess.run([sys.executable, "-c", NO_MEMORY, "run", str(CONFIGS / "patch.toml"),
                          "--out", str(out), "--quiet"], cwd=ROOT, env=mpi_env(),
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 2, res.stderr
    assert res.stderr.startswith("error: out of memory (Unable to allocate 7.63 GiB")
    assert len(res.stderr.strip().splitlines()) == 1, res.stderr
    s = read_summary(out)
    assert s["status"] == "failed" and s["error"].startswith("out of memory")
