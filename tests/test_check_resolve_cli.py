"""scripts/check_resolve.py: random LCPs through the re-solve on pair states
(`ContactLCP._polished`). Frictionless ones (C positive definite: a P-matrix LCP, on which
Murty's least-index rule terminates) all settle, from any basis; --compare of a run with
itself reports no difference."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
from support import ROOT


def _run(*args: str) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    res = subprocess.run([sys.executable, "scripts/check_resolve.py", *args], cwd=ROOT,
                         env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def test_random_frictionless_lcps_all_settle_and_a_run_equals_itself(tmp_path):
    out, again = tmp_path / "run.json", tmp_path / "again.json"
    got = _run("--cases", "90", "--out", str(out))
    assert got["cases"] == 90
    assert got["settled_by_kind"]["frictionless"] == [30, 30]
    assert 0 < got["solves_max"] <= 24  # UNSHIFTED_PIVOTS + SINGLE_FLIPS
    _run("--cases", "90", "--out", str(again))  # a second run, not the same file twice
    same = _run("--compare", str(out), str(again))
    assert same["settled_first_only"] == same["settled_second_only"] == same["differ"] == []


def test_compare_runs_the_other_coulomb_module(tmp_path):
    """--coulomb loads that file, not app.interface.coulomb: a copy with no single flips
    (SINGLE_FLIPS = 0, the re-solve stops after the block pivots) settles fewer cases, and
    --compare lists them."""
    text = (ROOT / "app/interface/coulomb.py").read_text()
    assert "\nSINGLE_FLIPS = 16\n" in text
    capped = tmp_path / "coulomb_capped.py"
    capped.write_text(text.replace("\nSINGLE_FLIPS = 16\n", "\nSINGLE_FLIPS = 0\n"))
    new, old = tmp_path / "new.json", tmp_path / "old.json"
    _run("--cases", "90", "--out", str(new))
    got = _run("--cases", "90", "--coulomb", str(capped), "--out", str(old))
    assert got["solves_max"] <= 8  # UNSHIFTED_PIVOTS alone
    diff = _run("--compare", str(old), str(new))
    assert diff["settled_second_only"] and not diff["settled_first_only"]
    assert diff["first"]["settled"] < diff["second"]["settled"]


def test_every_settled_answer_solves_the_lcp_judged_from_c_alone():
    """A settled answer is checked against the interface law from C (not by the re-solve's
    own `_basis_errors`): none is off. The bonded cases have c >= mu a, as app/config.py
    requires: with c = a and mu > 1 (the harness before) the re-solve settled on slipping
    pairs whose bound c + mu p was < 0 (2 of the first 120 cases, 76 of 3000, counted as
    settled), answers no LCP has."""
    got = _run("--cases", "120")
    assert got["settled"] >= 110
    assert got["invalid"] == 0


def test_law_error_sees_a_force_off_the_law():
    """`law_error` is 0 to round-off on a settled answer and flags one with a pair's p moved
    by 1 (its gap or p + a then leaves complementarity)."""
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import check_resolve as cr
    finally:
        sys.path.pop(0)
    rec, (_, d) = next((r, case) for r, case in zip(cr.run(cr.load(None), 3, 2026),
                                                   cr.cases(3, 2026), strict=True)
                       if r["settled"])
    p, q = np.array(rec["p"]), np.array(rec["q"])
    assert cr.law_error(d, p, q) < 1e-14
    p[0] += 1.0
    assert cr.law_error(d, p, q) > cr.LAW_TOL


def test_bad_input_is_one_error_line_and_exit_2(tmp_path):
    """A missing --coulomb file, --compare of runs of other sizes or of a file that is not
    JSON, --cases 0: `error: ...` and exit 2, no traceback."""
    short, long_ = tmp_path / "short.json", tmp_path / "long.json"
    short.write_text(json.dumps([{"kind": "mixed", "settled": False, "solves": 1}]))
    long_.write_text(json.dumps([{"kind": "mixed", "settled": False, "solves": 1}] * 2))
    (tmp_path / "junk.json").write_text("not json")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    for args in (["--coulomb", str(tmp_path / "none.py")], ["--cases", "0"],
                 ["--compare", str(short), str(long_)],
                 ["--compare", str(tmp_path / "junk.json"), str(short)]):
        res = subprocess.run([sys.executable, "scripts/check_resolve.py", *args], cwd=ROOT,
                             env=env, capture_output=True, text=True, timeout=120)
        assert res.returncode == 2, (args, res.stderr)
        assert res.stderr.startswith("error: ") and "Traceback" not in res.stderr, args
        assert res.stderr.count("\n") == 1, res.stderr


def test_cases_with_a_floating_mode_settle_on_answers_that_keep_the_balance():
    """--modes 1: each case gets a floating body's mode (free columns N alpha, T alpha and
    the balance e0 + N^T p + T^T q = 0, judged by `law_error` too); the settled answers
    solve the LCP, and the cases without modes are those of the run without the flag."""
    got = _run("--cases", "60", "--modes", "1")
    plain = _run("--cases", "60")
    assert got["invalid"] == 0 and got["settled"] >= 40
    assert got["settled"] != plain["settled"] or got["solves_total"] != plain["solves_total"]
    res = subprocess.run([sys.executable, "scripts/check_resolve.py", "--modes", "-1"],
                         cwd=ROOT, env=dict(os.environ, PYTHONPATH=str(ROOT)),
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 2 and res.stderr.startswith("error: --modes -1")
