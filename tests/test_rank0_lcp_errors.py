"""An LCP that rank 0 cannot build or solve stops every rank (it hung on 2 ranks)."""

from __future__ import annotations

import pytest
from support import CONFIGS, read_summary, run_cli


@pytest.mark.parametrize("ranks", [1, 2])
def test_lcp_matrix_overflow_is_one_line_on_every_rank_count(tmp_path, ranks):
    """E = 1e300 with friction: H = C_tt^-1 overflows, and rank 0 raises 'the contact LCP
    matrix is not finite' while building the LCP. On 2 ranks the other rank went on to the
    next collective: the run hung with status 'running' and no line."""
    out = tmp_path / "out"
    r = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                 "--set", "body.upper.E=1e300", "--set", "body.lower.E=1e300",
                 "--set", "interface.interface.mu=0.3"], ranks=ranks, timeout=120)
    assert r.returncode != 0
    assert "error: the contact LCP matrix is not finite" in r.stderr
    assert "Traceback" not in r.stderr
    s = read_summary(out)
    assert s["status"] == "failed" and "LCP matrix is not finite" in s["error"]
