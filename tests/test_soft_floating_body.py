"""A soft floating body pressed between stiff ones: multibody.toml with block2's E = 0.05
(6e4 below the cylinder's 3000, 4e4 below block1's 2000). Lemke's path on this LCP ends on
a complementary basis with a basic z_i of -1e-5 (round-off), which failed the check and
stopped the run ('inaccurate' at step 1); a warm start from that final basis solves it."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.support import CONFIGS, ROOT, mpi_env, read_summary, run_cli


@pytest.mark.parametrize("ranks", [1, 2])
def test_soft_floating_block_between_stiff_bodies_solves(tmp_path, ranks):
    out = tmp_path / "out"
    res = run_cli(["run", str(CONFIGS / "multibody.toml"), "--set", "body.block2.E=0.05",
                   "--out", str(out)], ranks=ranks)
    assert res.returncode == 0, res.stderr[-2000:]
    s = read_summary(out)
    assert s["status"] == "completed" and len(s["steps"]) == 4
    for step in s["steps"]:
        assert step["balance"]["max_relative_residual"] < 1e-9
        its = step["interfaces"]
        # block2 floats: the cylinder presses it (indent, block2 master) and block1
        # holds it (stack, block2 slave); the side push is ramped over steps 3-4
        push = {1: 0.0, 2: 0.0, 3: 0.4, 4: 0.8}[step["step"]]
        net = [its["stack"]["force"][k] - its["indent"]["force"][k] for k in range(2)]
        assert abs(net[0] + push) < 1e-8 and abs(net[1]) < 1e-8, net
    law = subprocess.run([sys.executable, "scripts/check_interface_law.py", str(out)],
                         cwd=ROOT, env=mpi_env(), capture_output=True, text=True)
    assert law.returncode == 0, law.stdout[-1000:] + law.stderr[-1000:]
    assert json.loads(law.stdout.splitlines()[-1])["failed"] == []
