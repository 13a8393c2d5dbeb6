"""scripts/fuzz_inputs.py: bad input is a clean error (one `error:` line, exit 2, a
`failed` summary.json) or a completed run with finite numbers, never a traceback, a hang,
or a silently accepted invalid value. A fixed-seed sample of random cases plus one case of
every BUG class the fuzzer found and that was fixed (each was BUG before its fix)."""

from __future__ import annotations

import json
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from support import ROOT

sys.path.insert(0, str(ROOT / "scripts"))
import fuzz_inputs as fz  # noqa: E402

SEED, N_RANDOM = 11, 16


def _case(**kw) -> fz.Case:
    return fz.Case(0, "t", "t", "configs/patch.toml", ["run", "{CONFIG}"], **kw)


def _summary(out: Path, **content) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "summary.json").write_text(json.dumps(content))


def test_classify_tells_bugs_from_clean_errors(tmp_path):
    out = tmp_path / "out"
    _summary(out, status="failed", error="x")
    assert fz.classify(_case(), 2, "warning: w\nerror: bad key\n", out)[0] == "CLEAN_ERROR"
    assert fz.classify(_case(), 2, "error: a\nerror: b\n", out)[0] == "BUG"
    assert fz.classify(_case(), 2, "something\nerror: a\n", out)[0] == "BUG"
    assert fz.classify(_case(), 2, "error: " + "x" * 2000, out)[0] == "BUG"
    assert fz.classify(_case(), 1, "Traceback (most recent call last):\n  x\n", out)[0] == "BUG"
    assert fz.classify(_case(), None, "", out) == ("BUG", "timeout")
    assert fz.classify(_case(), 134, "", out)[0] == "BUG"
    _summary(out, status="running")
    assert fz.classify(_case(), 2, "error: a\n", out)[0] == "BUG"  # running left behind
    _summary(out, status="completed", strain_energy=float("nan"))
    assert "non-finite" in fz.classify(_case(), 0, "", out)[1]
    _summary(out, status="completed", strain_energy=1.0, reference={"h": {"e": float("nan")}})
    assert fz.classify(_case(), 0, "", out)[0] == "OK"  # documented: no closed form
    assert fz.classify(_case(must_fail=True), 0, "", out)[0] == "BUG"  # silently accepted
    usage = "usage: python -m app run ...\npython -m app run: error: bad --refine\n"
    assert fz.classify(_case(expect_summary=False), 2, usage, out)[0] == "CLEAN_ERROR"


def test_must_fail_knows_the_physical_ranges():
    assert fz.must_fail("nu", 0.3, 0.5) and fz.must_fail("E", 1.0, -0.0)
    assert fz.must_fail("thickness", 1.0, float("nan")) and fz.must_fail("steps", 1, 2.0)
    assert fz.must_fail("E", 1.0, "1.0") and fz.must_fail("structured", True, 1)
    assert fz.must_fail("nu", 0.3, 0.49) is False and fz.must_fail("x", 0.0, 1e308) is None
    assert fz.must_fail(fz._domain_key(("parameters", "nu"), "nu"), 0.3, 1.0) is None


def test_generator_is_deterministic_and_covers_every_family():
    a = fz.generate_cases(SEED, 400)
    b = fz.generate_cases(SEED, 400)
    assert [(c.desc, c.argv, c.toml) for c in a] == [(c.desc, c.argv, c.toml) for c in b]
    families = {f.__name__ for f, _ in fz.Generator(SEED, ["configs/patch.toml"]).families}
    assert {c.family for c in a} == families


@pytest.mark.parametrize("ranks", [1])
def test_fixed_seed_sample_and_fixed_bug_classes_have_no_bug(tmp_path, ranks):
    cases = fz.generate_cases(SEED, N_RANDOM) + fz.regression_cases()
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(lambda c: fz.run_case(c, tmp_path, 120, ranks, False), cases))
    bugs = [r for r in results if r["verdict"] == "BUG"]
    assert not bugs, json.dumps(bugs, indent=1)[:4000]
    assert {r["verdict"] for r in results} == {"OK", "CLEAN_ERROR"}
