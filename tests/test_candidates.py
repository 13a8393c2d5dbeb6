"""Candidate pairs (app/interface/candidates.py): the LCP over the pairs near contact gives
the full LCP's answer. Every config of configs/ and configs/hard/ is run with and without
candidate pairs; states, pair forces and displacements agree to 1e-10."""

from __future__ import annotations

import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest
from support import CONFIGS

from app.config import apply_overrides, parse_config
from app.errors import InputError, SolveError
from app.interface.candidates import CandidateLCP
from app.interface.coulomb import ContactLCP
from app.run import RunOptions, run

ALL = sorted(CONFIGS.glob("*.toml")) + sorted((CONFIGS / "hard").glob("*.toml"))
SHORT = {  # the 2000-pair scene on a coarser arc in 10 steps, as in test_hard.py
    "cattaneo_many": ["analysis.steps=10", "support.1.ramp=[1, 4]", "load.0.ramp=[5, 10]",
                      "mesh.refine.1.size=0.0045"],
}
REL = 1e-10


def _run(path: Path, out: Path, candidates: bool):
    raw = tomllib.loads(path.read_text())
    apply_overrides(raw, SHORT.get(path.stem, []) +
                    [f"analysis.candidate_pairs={'true' if candidates else 'false'}"])
    try:
        return run(parse_config(raw, path), RunOptions(out=out, quiet=True))
    except (InputError, SolveError) as err:
        return {"error": type(err).__name__}


def _steps(out: Path, s: dict) -> list[dict]:
    data = []
    for st in s["steps"]:
        with h5py.File(out / f"step_{st['step']:04d}.h5") as f:
            d = {"u": f["displacement"][()]}
            if "contact" in f:
                d.update({k: f["contact"][k][()] for k in ("p_force", "q_force", "state")})
        data.append(d)
    return data


@pytest.mark.parametrize("path", ALL, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_candidate_pairs_give_the_full_lcp_answer(tmp_path, path):
    a = _run(path, tmp_path / "cand", True)
    b = _run(path, tmp_path / "full", False)
    if "error" in b:
        assert a == b
        return
    assert a["status"] == b["status"] == "completed"
    sa, sb = _steps(tmp_path / "cand", a), _steps(tmp_path / "full", b)
    assert len(sa) == len(sb)
    forces = max(float(np.abs(y.get(f, 0.0)).max(initial=0.0))  # the run's force scale
                 for y in sb for f in ("p_force", "q_force"))
    for k, (x, y) in enumerate(zip(sa, sb, strict=True)):
        for key in y:
            scale = forces if key.endswith("_force") else float(np.abs(y[key]).max(initial=0))
            if key == "state":
                np.testing.assert_array_equal(x[key], y[key])
                continue
            diff = float(np.abs(x[key] - y[key]).max(initial=0.0))
            assert diff <= REL * scale, (k + 1, key, diff / scale)
    if path.stem == "cattaneo_many":  # most pairs stay open: the LCP is much smaller
        assert a["steps"][-1]["lcp_size_solved"] < b["steps"][-1]["lcp_size_solved"] / 4
        assert a["steps"][-1]["lcp_size"] == b["steps"][-1]["lcp_size_solved"]


def _strip(m: int, seed: int = 0):
    """Compliance of m pairs along a strip (SPD), per-pair data and a curved free gap."""
    x = np.linspace(-1.0, 1.0, m)
    k = np.exp(-np.abs(x[:, None] - x[None, :]) / 0.2) / m
    c = np.block([[k + 0.02 * np.eye(m), 0.1 * k], [0.1 * k, 1.3 * k + 0.02 * np.eye(m)]])
    gap_free = 0.5 * x**2 - 0.05
    return c, x, gap_free


def test_a_pair_that_would_penetrate_joins_and_the_answer_is_the_full_one():
    m = 60
    c, x, gap_free = _strip(m)
    mu = np.full(m, 0.3)
    fr = np.ones(m, dtype=bool)
    z = np.zeros(m)
    args = (gap_free, 0.01 * x, z, z, z, mu, np.zeros(0))
    cand = CandidateLCP(c, mu, fr)
    cand.cand[:] = False
    # a predictor that misses the edge of the contact zone: the check must add it
    cand.predict = lambda g, a, cc: g < -0.04
    sol = cand.solve(*args)
    full = ContactLCP(c, mu, fr).solve(*args)
    assert sol.status == full.status == "solved"
    assert cand.candidates_added > 0 and cand.size < 3 * m
    for key in ("p", "q", "gap", "tau"):
        ref = getattr(full, key)
        np.testing.assert_allclose(getattr(sol, key), ref, rtol=0,
                                   atol=REL * np.abs(ref).max())


def test_huge_friction_coefficient_gives_full_stick(tmp_path):
    """mu = 1e9 on the patch test: full stick is an equilibrium and is found."""
    path = CONFIGS / "patch.toml"
    raw = tomllib.loads(path.read_text())
    apply_overrides(raw, ["interface.interface.mu=1e9"])
    s = run(parse_config(raw, path), RunOptions(out=tmp_path / "o", quiet=True))
    assert s["status"] == "completed"
    for st in s["steps"]:
        states = st["states"]
        assert states["slip+"] == states["slip-"] == 0, states
        assert st["lcp_residual"] < 1e-9


def test_failure_message_names_lemke_outcome(tmp_path):
    path = CONFIGS / "hard" / "squeezed.toml"
    raw = tomllib.loads(path.read_text())
    apply_overrides(raw, ["load.0.total_force=[5.0, 0.0]"])
    with pytest.raises(SolveError) as err:
        run(parse_config(raw, path), RunOptions(out=tmp_path / "o", quiet=True))
    text = str(err.value)
    assert text.startswith("no static equilibrium at step 5: Lemke ended with 'secondary ray': ")
    assert "on a inaccurate" not in text and "(inaccurate" not in text
    assert "\n" not in text


def test_mu_1e12_solves_like_mu_1e6(tmp_path):
    """configs/hard/friction.toml with mu = 1e12 (stopped 'inaccurate' at step 5 before the
    slip rows were scaled by 1/mu): it solves, with the states and forces of mu = 1e6
    (stick everywhere but at one pair, where p is almost 0)."""
    path = CONFIGS / "hard" / "friction.toml"
    out = {}
    for mu in ("1e12", "1e6"):
        raw = tomllib.loads(path.read_text())
        apply_overrides(raw, [f"interface.contact.mu={mu}"])
        out[mu] = run(parse_config(raw, path), RunOptions(out=tmp_path / mu, quiet=True))
        assert out[mu]["status"] == "completed"
    for a, b in zip(out["1e12"]["steps"], out["1e6"]["steps"], strict=True):
        assert a["states"] == b["states"]
        fa, fb = a["interfaces"]["contact"], b["interfaces"]["contact"]
        # (the last step has one slipping pair, whose bound mu p differs slightly)
        assert fa["tangential_force"] == pytest.approx(fb["tangential_force"], rel=1e-6,
                                                       abs=1e-12 * fb["normal_force"])
        assert fa["normal_force"] == pytest.approx(fb["normal_force"], rel=1e-6)
