"""Scripts that run the app refuse an input they cannot use before running it: before,
`oblique_path.py --k 5` (Q / P above mu = 0.2: no equilibrium) ran two scenes and failed
with the app's `no static equilibrium` (exit 1), `bench_scale.py` and `bench_debond.py` on
a missing config, `bench_warm_start.py --scenes nosuch` and `bench_compliance.py
--mesh-size -1`, `bench_element_fields.py` on a missing config or `--repeat 0` stopped with
tracebacks, `bench_factorization.py` on a missing config printed a traceback as its rows'
`error` and exited 0, and `bench_mortar.py --only nosuch` ran nothing and exited 0."""

from __future__ import annotations

import subprocess
import sys

import pytest
from support import ROOT


@pytest.mark.parametrize("script, args, words", [
    ("oblique_path.py", ["--k", "5"], "--k 5.0: Q / P must be above 0 and below mu = 0.2"),
    ("oblique_path.py", ["--k", "0.1", "--steps", "0"], "--steps must be at least 1"),
    ("bench_scale.py", ["configs/no_such.toml"], "config configs/no_such.toml: [Errno 2]"),
    ("bench_debond.py", ["configs/no_such.toml"], "config configs/no_such.toml: [Errno 2]"),
    ("bench_mortar.py", ["--only", "nosuch"], "argument --only: invalid choice: 'nosuch'"),
    ("bench_warm_start.py", ["--scenes", "nosuch"], "--scenes nosuch: no configs/nosuch.toml"),
    ("bench_compliance.py", ["--mesh-size", "-1"], "--mesh-size must be > 0"),
    ("bench_element_fields.py", ["--config", "configs/no_such.toml"],
     "config configs/no_such.toml: [Errno 2]"),
    ("bench_element_fields.py", ["--config", "configs/patch.toml", "--repeat", "0"],
     "--repeat must be at least 1"),
    ("bench_factorization.py", ["--config", "configs/no_such.toml"],
     "config file 'configs/no_such.toml' does not exist"),
    ("bench_factorization.py", ["--routes", "nosuch"], "invalid choice: 'nosuch'"),
    ("bench_crossing.py", ["--configs", "configs/no_such.toml"],
     "config configs/no_such.toml: [Errno 2]"),
    ("bench_crossing.py", ["--repeat", "0"], "--repeat must be at least 1"),
    ("bench_phases.py", ["--repeat", "0"], "--repeat must be at least 1"),
    ("bench_phases.py", ["--only", "multibody", "nosuch"],
     "--only nosuch: no configs/nosuch.toml or configs/hard/nosuch.toml"),
    ("bench_phases.py", ["--skip", "multibody", "--only", "multibody"],
     "--only multibody: also in --skip"),
    ("bench_mip.py", ["--sizes", "201"], "--sizes 201: a size must be 1 to 200"),
    ("check_invariance.py", ["configs/patch.toml", "--mesh-size", "-1"],
     "--mesh-size must be a number > 0 (got -1.0)"),
])
def test_an_unusable_input_is_an_error_before_any_run(tmp_path, script, args, words):
    extra = ["--out", str(tmp_path / "o")] if script == "oblique_path.py" else []
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / script), *args, *extra],
                         capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith(f"{script}: error: ") and words in last
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("args, words", [
    (["--configs", "configs/nothing*.toml"], "--configs: no config matches"),
    (["--families", "nosuch"], "--families: unknown families ['nosuch']; the families: "),
])
def test_fuzz_inputs_refuses_what_it_cannot_generate(args, words):
    """Before: a bare line (`unknown families ['nosuch']`) and exit 1."""
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / "fuzz_inputs.py"),
                          "--cases", "1", *args], capture_output=True, text=True,
                         timeout=120, cwd=ROOT)
    assert res.returncode == 2 and res.stdout == ""
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith("fuzz_inputs.py: error: ") and words in last
