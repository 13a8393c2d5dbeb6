"""scripts/check_lcp.py --help names the solvers as --solver takes them: before, argparse's
usage line dropped the parentheses (`{lemke,lemkecrash=False,lemke_tableau}`), and the name
copied from it was refused (`invalid choice: 'lemkecrash=False'`)."""

from __future__ import annotations

import subprocess
import sys

from support import ROOT


def test_the_help_names_every_solver_as_the_option_takes_it():
    res = subprocess.run([sys.executable, "scripts/check_lcp.py", "--help"], cwd=ROOT,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0
    text = " ".join(res.stdout.split())
    assert "lemkecrash=False" not in text
    assert "'lemke', 'lemke(crash=False)', 'lemke_tableau'" in text
