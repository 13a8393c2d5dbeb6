"""The per-step accuracy figure `lcp_accuracy` and its warning (app/output/
accuracy_warning.py, app/lcp/conditioning.py, `ContactLCP._accuracy`)."""

from __future__ import annotations

import numpy as np
import pytest

from app.lcp.conditioning import EPS, condition_estimate, determined_accuracy, relative_accuracy
from app.output.accuracy_warning import ACCURACY_WARN, Contrast, accuracy_warning

STIFF_SOFT = [Contrast("soft", "a", 2e3, "b", 1e3), Contrast("interface", "upper", 1e13,
                                                              "lower", 1e3)]


def test_the_condition_estimate_is_lapacks_1_norm_condition():
    rng = np.random.default_rng(0)
    k = rng.standard_normal((40, 40))
    k[:, 0] *= 1e-9  # one column of round-off's size beside the others
    est = condition_estimate(k)
    assert est == pytest.approx(np.linalg.cond(k, 1), rel=0.5)
    assert est > 1e9 and relative_accuracy(k) == pytest.approx(EPS * est)
    assert condition_estimate(np.eye(3)) == 1.0 and condition_estimate(np.zeros((0, 0))) == 1.0
    assert condition_estimate(np.ones((2, 2))) == np.inf
    assert relative_accuracy(np.ones((2, 2))) == 1.0  # (summary.json has no inf)
    assert condition_estimate(np.array([[1.0, np.nan], [0.0, 1.0]])) == np.inf


def _held_and_free_mode() -> np.ndarray:
    """The states' system [[C, N], [N^T, 0]] of 3 closed pairs (C (3, 3) SPD) and two mode
    amplitudes: mode 0 held by the pairs' gaps, mode 1 by none (its columns and rows zero:
    it slides on slipping pairs), unit diagonal where C has one."""
    c = np.array([[1.0, 0.3, 0.1], [0.3, 1.0, 0.3], [0.1, 0.3, 1.0]])
    n = np.array([[1.0, 0.0], [0.5, 0.0], [-0.2, 0.0]])
    return np.block([[c, n], [n.T, np.zeros((2, 2))]])


def test_a_mode_no_pair_holds_does_not_read_as_forces_off_by_one():
    """multibody.toml --sd 1 --mesh-size 1.2: hourglass amplitudes that only slipping pairs
    touch are not unique (the states' system singular, rank 2 and 3 short), the forces are
    (the null vectors' share on p and q 4.3e-14): `lcp_accuracy` read 1.0 and the run
    warned "its forces may be off by up to 1" (review8); the determined part's figure
    1e-12. A null space on the forces themselves still reads 1.0."""
    k = _held_and_free_mode()
    free = np.array([False, False, False, True, True])
    assert relative_accuracy(k) == 1.0
    assert determined_accuracy(k, free) < 1e-14
    assert determined_accuracy(k, np.zeros(5, dtype=bool)) == 1.0
    k[:, 1] = k[:, 0]  # two pairs alike: the split of their force is not unique
    k[1, :] = k[0, :]
    assert determined_accuracy(k, free) < 1e-14  # judged on their sum (see below)
    k[1, :] = 2.0 * k[0, :]  # twice pair 0's row: a null space that no split explains
    k[:, 1] = 2.0 * k[:, 0]
    assert np.linalg.matrix_rank(k) < 5 and determined_accuracy(k, free) == 1.0
    rng = np.random.default_rng(1)
    well = rng.standard_normal((6, 6)) + 6 * np.eye(6)
    assert determined_accuracy(well, np.ones(6, dtype=bool)) == relative_accuracy(well)


def _duplicated(c: np.ndarray, twice: int) -> np.ndarray:
    """The states' system of closed pairs with compliance c (m, m) SPD, unit diagonal, and
    pair `twice` duplicated (its row and column again: two pairs with the same
    constraint rows), with one mode amplitude that no pair holds (zero row and column)."""
    order = [*range(c.shape[0]), twice]
    k = np.zeros((len(order) + 1,) * 2)
    k[:-1, :-1] = c[np.ix_(order, order)]
    return k


def test_a_duplicated_pair_is_judged_on_its_determined_forces():
    """Two pairs with the same constraint rows (a duplicated pair; the run's input refuses
    a slave node on two pairs, so no run builds one): both closed, the states' system is
    singular in p itself, along p_i - p_j, and only p_i + p_j is fixed. It read 1.0 (warned
    "its forces may be off by up to 1"); now the split gets a unit tie and the
    determined forces' figure: eps x the condition of the rest, 1e-16 here, as without
    the duplicate. A null space that no split explains still reads 1.0, and its warning
    says the forces are not unique, not that they are off by up to 1."""
    c = np.array([[1.0, 0.3, 0.1], [0.3, 1.0, 0.3], [0.1, 0.3, 1.0]])
    k = _duplicated(c, 1)
    free = np.array([False] * 4 + [True])
    assert relative_accuracy(k) == 1.0
    alone = relative_accuracy(c)
    assert determined_accuracy(k, free) < 10 * alone
    assert determined_accuracy(k, np.zeros(5, dtype=bool)) == 1.0  # the mode's null too
    text = accuracy_warning(1.0, 3, STIFF_SOFT[:1])
    assert text.startswith("step 3: the pair states' system does not fix the contact forces")
    assert "off by up to" not in text and "one of them" in text


@pytest.mark.parametrize("fric", [False, True])
def test_lemkes_basis_holds_one_of_two_duplicated_pairs(fric):
    """A duplicated pair through the LCP (pair 2 a copy of pair 1, both pressed alike):
    Lemke's basis cannot hold both (two equal columns), so one carries p_1 + p_2 and the
    other reads p = 0 outside the basis; the states' system is that of two pairs, not
    singular: `lcp_accuracy` 5e-16 (this and the input's refusal of a slave node on two
    pairs are why no run reaches the singular system above)."""
    from app.interface.candidates import CandidateLCP

    base = np.array([[1.0, 0.3, 0.1, 0.05], [0.3, 1.0, 0.05, 0.1],
                     [0.1, 0.05, 1.0, 0.2], [0.05, 0.1, 0.2, 1.0]])  # (n0, n1, t0, t1)
    order = [0, 1, 1, 2, 3, 3]
    z, mu = np.zeros(3), np.full(3, 0.3)
    lcp = CandidateLCP(base[np.ix_(order, order)], mu, np.full(3, fric))
    sol = lcp.solve(np.full(3, -1.0), z, z, z, z, mu, np.zeros(0))
    two = CandidateLCP(base, mu[:2], np.full(2, fric))
    ref = two.solve(np.full(2, -1.0), z[:2], z[:2], z[:2], z[:2], mu[:2], np.zeros(0))
    assert sol.status == "solved" and min(sol.p[1], sol.p[2]) == 0.0
    assert sol.p[1] + sol.p[2] == pytest.approx(ref.p[1], rel=1e-12)
    assert sol.accuracy < 100 * EPS


def test_an_accurate_step_does_not_warn():
    assert accuracy_warning(7.4e-6, 2, STIFF_SOFT) is None
    assert accuracy_warning(ACCURACY_WARN, 2, STIFF_SOFT) is None
    assert accuracy_warning(float("nan"), 2, STIFF_SOFT) is not None


def test_the_stiffest_contrast_is_named_as_the_cause():
    text = accuracy_warning(2.4e-3, 1, STIFF_SOFT)
    assert text.startswith("step 1: round-off limits the contact answer: its forces may be "
                           "off by up to 0.0024 of the largest")
    assert "contrast 1e+10 between bodies 'upper' (E = 1e+13) and 'lower' (E = 1000) at " \
           "interface 'interface'" in text
    assert "Lower its E" in text
    other = accuracy_warning(2.4e-3, 1, STIFF_SOFT[:1])
    assert "not a stiffness contrast" in other and "'a'" not in other


@pytest.mark.parametrize("young, warns", [(1e6, False), (1e13, True)])
def test_a_stiff_floating_block_says_how_wrong_its_forces_may_be(tmp_path, young, warns):
    """two_blocks.toml, the upper block floating at E = 1e13 on 1e3 (mu = 0.3): its forces
    are off those of E = 1e10 by up to 5.7e-5 over a tangential cycle (README "Hard
    cases"), round-off of C that the law checks do not see. `lcp_accuracy` says 2.4e-3
    at step 1 (eps x cond ~ 34 x the contrast) and the run warns, naming both bodies;
    at E = 1e6 it says 2.4e-10 and nothing warns."""
    from support import CONFIGS, read_summary, run_cli

    sets = ["--set", f"body.upper.E={young:g}", "--set", "interface.interface.mu=0.3",
            "--set", 'support=[{on="lower_base",ux=0.0,uy=0.0}]']
    res = run_cli(["run", str(CONFIGS / "two_blocks.toml"), "--out", str(tmp_path / "o"),
                   "--quiet", *sets], timeout=120)
    assert res.returncode == 0, res.stderr
    summary = read_summary(tmp_path / "o")
    accuracy = summary["steps"][0]["lcp_accuracy"]
    warnings = [w for w in summary.get("warnings", []) if "round-off limits" in w]
    if warns:
        assert 1e-3 < accuracy < 1e-2
        assert len(warnings) == 1 and "'upper' (E = 1e+13) and 'lower'" in warnings[0]
    else:
        assert 1e-11 < accuracy < 1e-9 and not warnings


def test_a_step_with_every_pair_open_is_exact():
    """All pairs open (no candidate: an LCP of size 0, configs/hard/initial_gap.toml's
    first step): `lcp_accuracy` 0 (the branch failed there on an empty system at first);
    one closed pair of a well-conditioned C: eps x a small condition number."""
    from app.interface.candidates import CandidateLCP

    m = 3
    c = np.eye(2 * m) + 0.1 * np.ones((2 * m, 2 * m))
    lcp = CandidateLCP(c, np.full(m, 0.3), np.ones(m, bool))
    z = np.zeros(m)
    sol = lcp.solve(np.full(m, 1.0), z, z, z, z, np.full(m, 0.3), np.zeros(0))
    assert sol.status == "solved" and lcp.size == 0 and sol.accuracy == 0.0
    sol = lcp.solve(np.array([-1.0, 1.0, 1.0]), z, z, z, z, np.full(m, 0.3), np.zeros(0))
    assert sol.status == "solved" and sol.p[0] > 0 and 0.0 < sol.accuracy < 100 * EPS


def test_duplicate_pairs_are_judged_on_their_determined_forces(tmp_path):
    """configs/hard/duplicate_pairs.toml: 3 dependent tangential directions (two slave
    nodes on one master point, all sticking): the state system is singular along them
    (their force split is not unique; `lcp_accuracy` read 1.1e21 and warned) and is judged
    with a unit tie there: 5.6e-14, no warning."""
    from support import CONFIGS, read_summary, run_cli

    res = run_cli(["run", str(CONFIGS / "hard" / "duplicate_pairs.toml"), "--out",
                   str(tmp_path / "o"), "--quiet"], timeout=120)
    assert res.returncode == 0, res.stderr
    summary = read_summary(tmp_path / "o")
    step = summary["steps"][0]
    assert step["dependent_tangential_directions"] == 3
    assert step["lcp_accuracy"] < 1e-12
    assert not [w for w in summary.get("warnings", []) if "round-off limits" in w]


def test_no_svd_where_no_null_space_can_be_explained(monkeypatch):
    """An ill-conditioned states' system (relative_accuracy above SVD_FROM) without mode
    amplitudes or alike pairs: no null space can lie in free unknowns or splits, so its
    figure is relative_accuracy's without an SVD (at n = 1500 the SVD took 6 s beside the
    LU's 0.3 s; it ran whatever the system since the alike pairs came in)."""
    from app.lcp.conditioning import SVD_FROM

    calls = []
    svd = np.linalg.svd
    monkeypatch.setattr(np.linalg, "svd", lambda a, *r, **kw: calls.append(1) or svd(a, *r, **kw))
    rng = np.random.default_rng(3)
    q, _ = np.linalg.qr(rng.standard_normal((8, 8)))
    k = q @ np.diag(np.logspace(0, -12, 8)) @ q.T  # SPD, condition 1e12
    assert relative_accuracy(k) > SVD_FROM
    assert determined_accuracy(k, np.zeros(8, dtype=bool)) == relative_accuracy(k)
    assert calls == []
    free = np.zeros(8, dtype=bool)
    free[-1] = True  # a mode amplitude: the SVD judges where the null space lies
    assert determined_accuracy(k, free) == relative_accuracy(k)
    assert calls == [1]
