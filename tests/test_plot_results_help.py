"""`scripts/plot_results.py --help` describes what the script draws: before, the
description was the docstring's first line, cut mid-sentence ("... von Mises stress, and
p(x),"), and --zoom and --prefix had no help."""

import subprocess
import sys

from support import ROOT, mpi_env


def test_help_describes_the_pictures_and_every_option():
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / "plot_results.py"), "--help"],
                         cwd=ROOT, env=mpi_env(), capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    text = " ".join(res.stdout.split())
    assert "p(x), q(x) along each interface" in text
    assert "closed form overlaid" in text
    for option in ("--zoom X0 X1 Y0 Y1 deformed mesh only", "--prefix PREFIX put before"):
        assert option in text, text
