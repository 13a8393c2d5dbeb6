"""Runs on more ranks than the scene needs give the 1-rank answer (tiny meshes, errors)."""

from __future__ import annotations

import json

from tests.support import CONFIGS, run_cli

HARD = CONFIGS / "hard"


def test_a_singular_stiffness_counts_its_modes_alike_on_any_rank_count(tmp_path):
    """hourglass_1sd.toml at --mesh-size 2.0 is one CS-FEM-1SD element on a pin and a
    roller: 8 DOFs, a stiffness of rank 3, 3 supported DOFs, so 2 zero-energy modes. The
    message quoted MUMPS's null-pivot count, which depends on the distribution: 2 on 1
    rank, 1 on 3 ranks."""
    lines = {}
    for ranks in (1, 3):
        out = tmp_path / f"n{ranks}"
        res = run_cli(["run", str(HARD / "hourglass_1sd.toml"), "--mesh-size", "2.0",
                       "--out", str(out), "--quiet"], ranks=ranks, timeout=120)
        errors = [x for x in res.stderr.splitlines() if x.startswith("error:")]
        assert res.returncode == 2 and len(errors) == 1, res.stderr
        assert "Traceback" not in res.stderr
        summary = json.loads((out / "summary.json").read_text())
        assert summary["status"] == "failed" and errors[0] == f"error: {summary['error']}"
        lines[ranks] = errors[0]
    assert "(2 zero-energy modes)" in lines[1] and "body 'block'" in lines[1]
    assert lines[1] == lines[3]
