"""The LCP-solver registry (app/lcp/solvers.py) and its use by the contact LCP."""

from __future__ import annotations

import numpy as np
import pytest

from app.errors import InputError
from app.interface.coulomb import ContactLCP
from app.lcp import lemke
from app.lcp.solvers import LCP_SOLVERS, lcp_solver
from tests.support import CONFIGS, run_cli


def test_lemke_is_registered_and_unknown_names_are_one_line_errors():
    assert lcp_solver("lemke") is lemke and "lemke" in LCP_SOLVERS
    with pytest.raises(InputError, match="analysis.lcp_solver = 'pgs': use one of 'lemke'"):
        lcp_solver("pgs")


def test_contact_lcp_calls_the_solver_it_is_given():
    calls = []

    def recording(M, q, **kw):
        calls.append(M.shape[0])
        return lemke(M, q, **kw)

    c = np.diag([2e-3, 2e-3, 5e-3, 5e-3])
    lcp = ContactLCP(c, np.full(2, 0.3), np.ones(2, bool), solver=recording)
    sol = lcp.solve(np.array([-1e-3, 1e-3]), np.zeros(2), np.zeros(2), np.zeros(2),
                    np.zeros(2), np.full(2, 0.3), np.zeros(0))
    assert sol.status == "solved" and calls == [lcp.size]
    np.testing.assert_allclose(sol.p, [0.5, 0.0], atol=1e-12)


def test_unknown_solver_stops_before_meshing(tmp_path):
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(tmp_path / "o"),
                   "--set", "analysis.lcp_solver='pgs'"])
    assert res.returncode == 2 and res.stderr.count("\n") == 1
    assert "analysis.lcp_solver = 'pgs'" in res.stderr
    assert not (tmp_path / "o" / "mesh.h5").exists()


def _readme_solver_signature() -> list[str]:
    """The keyword names README "Extension points" gives a new LCP solver's function."""
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    row = next(line for line in text.splitlines() if line.startswith("| LCP solver |"))
    sig = re.search(r"\(M, q, \*, ([^)]*)\) -> LCPResult", row)
    assert sig, row
    return [name.strip() for name in sig.group(1).split(",")]


def test_a_solver_with_the_documented_signature_runs_in_the_contact_lcp():
    """A solver written to README's signature, and nothing more, is one the contact LCP can
    call (before: README gave (M, q, *, basis, max_pivots, cold_start) and ContactLCP's
    call with cache= was a TypeError that failed the run)."""
    names = _readme_solver_signature()
    namespace = {"lemke": lemke}
    params = ", ".join(f"{n}=None" for n in names)
    forward = ", ".join(f"{n}={n}" for n in names)
    exec(f"def documented(M, q, *, {params}):\n"  # noqa: S102 (the README's own signature)
         f"    return lemke(M, q, {forward})", namespace)
    c = np.diag([2e-3, 2e-3, 5e-3, 5e-3])
    lcp = ContactLCP(c, np.full(2, 0.3), np.ones(2, bool), solver=namespace["documented"])
    sol = lcp.solve(np.array([-1e-3, 1e-3]), np.zeros(2), np.zeros(2), np.zeros(2),
                    np.zeros(2), np.full(2, 0.3), np.zeros(0))
    assert sol.status == "solved"
    np.testing.assert_allclose(sol.p, [0.5, 0.0], atol=1e-12)
