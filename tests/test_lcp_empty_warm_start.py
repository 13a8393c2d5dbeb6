"""An empty warm-start basis (the last load step had every pair open, z = 0) is the textbook
start itself; `lemke` starts from the crash guess instead, as with no basis. Before, such a
step ran the textbook path (one pivot per active unknown), and on
`configs/hard/initial_gap.toml --refine 1` without candidate pairs that path ended
'inaccurate' at the step where the gap closes."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from support import CONFIGS

from app.config import apply_overrides, parse_config
from app.lcp import lemke
from app.lcp.cases import strip_contact_lcp
from app.run import RunOptions, run


@pytest.mark.parametrize("cold_start", [True, False])
def test_an_empty_basis_starts_from_the_crash_guess(cold_start):
    M, q = strip_contact_lcp(200, mu=0.3, seed=4)
    res = lemke(M, q, basis=np.zeros(q.size, dtype=bool), cold_start=cold_start)
    cold = lemke(M, q)
    assert res.ok and res.pivots == 0 and res.warm_start == "crash"
    np.testing.assert_array_equal(res.z, cold.z)


def test_an_empty_basis_of_the_wrong_shape_is_still_an_error():
    M, q = strip_contact_lcp(20, mu=0.3, seed=1)
    with pytest.raises(ValueError, match="basis must have shape"):
        lemke(M, q, basis=np.zeros(q.size + 1, dtype=bool))


def test_an_empty_basis_without_crash_is_the_textbook_start():
    M, q = strip_contact_lcp(60, mu=0.3, seed=2)
    res = lemke(M, q, basis=np.zeros(q.size, dtype=bool), crash=False)
    textbook = lemke(M, q, crash=False)
    assert res.ok and res.pivots == textbook.pivots > 0


def test_the_step_that_closes_an_initial_gap_solves_over_every_pair(tmp_path):
    path = CONFIGS / "hard" / "initial_gap.toml"
    raw = tomllib.loads(path.read_text())
    apply_overrides(raw, ["analysis.candidate_pairs=false"])
    s = run(parse_config(raw, path), RunOptions(out=tmp_path / "o", quiet=True, refine=1))
    assert s["status"] == "completed"
    assert [st["lemke_pivots"] for st in s["steps"]] == [0, 0, 0, 0]
