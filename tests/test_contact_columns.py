"""The force recovery's kept columns S^-1 G_c^T (app/condensation/contact_columns.py)."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from app.condensation.contact_columns import ContactColumns


def _problem(n_c: int = 40, m: int = 12, seed: int = 0):
    """An SPD S (n_c, n_c), a sparse G_c (2m, n_c) and a counting S^-1."""
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n_c, n_c))
    s = a @ a.T + n_c * np.eye(n_c)
    gc = sp.random(2 * m, n_c, density=0.15, random_state=seed, format="csr")
    fac = sla.cho_factor(s)
    calls = []

    def solve(b):
        calls.append(b.shape)
        return sla.cho_solve(fac, b)

    return s, gc, solve, calls


def test_apply_equals_the_solve_with_s_and_fills_each_pair_once():
    s, gc, solve, calls = _problem()
    cols = ContactColumns(gc, solve)
    m = gc.shape[0] // 2
    lam = np.zeros(2 * m)
    lam[[2, 3]] = [1.5, 0.7]  # two normal rows
    want = np.linalg.solve(s, gc.T @ lam)
    assert np.allclose(cols.apply(lam), want, rtol=1e-12, atol=1e-14)
    assert cols.solves == 1 and cols.count == 4  # both rows of pairs 2 and 3
    lam[m + 2] = -0.3  # pair 2's tangential row: already kept
    assert np.allclose(cols.apply(lam), np.linalg.solve(s, gc.T @ lam), rtol=1e-12)
    assert cols.solves == 1
    lam[5] = 2.0  # a new pair: one more fill
    assert np.allclose(cols.apply(lam), np.linalg.solve(s, gc.T @ lam), rtol=1e-12)
    assert cols.solves == 2 and len(calls) == 2


def test_zero_forces_give_zero_and_no_solve():
    _, gc, solve, calls = _problem()
    out = ContactColumns(gc, solve).apply(np.zeros(gc.shape[0]))
    assert out.shape == (gc.shape[1],) and not out.any() and not calls


def test_past_the_column_budget_apply_defers_to_the_caller():
    _, gc, solve, _ = _problem()
    lam = np.zeros(gc.shape[0])
    lam[1] = 1.0
    cols = ContactColumns(gc, solve, max_columns=1)
    assert cols.apply(lam) is not None and cols.count == 1  # without its partner row
    cols = ContactColumns(gc, solve, max_columns=3)
    assert cols.apply(lam) is not None and cols.count == 2  # row 1 and its partner
    lam[[4, 7, 9]] = 1.0
    assert cols.apply(lam) is None and cols.count == 2


def test_prefill_keeps_the_first_pairs_columns_and_saves_their_fill():
    s, gc, solve, calls = _problem()
    m = gc.shape[0] // 2
    y = np.linalg.solve(s, gc.T.toarray())
    cols = ContactColumns(gc, solve, max_columns=6)
    cols.prefill(y, np.array([5, 1, 9, 0]))  # room for pairs 5, 1 and 9
    assert cols.count == 6 and cols.pos[[5, 1, 9, 5 + m]].min() >= 0 and cols.pos[0] < 0
    lam = np.zeros(2 * m)
    lam[[5, 9 + m]] = [1.0, -0.5]
    assert np.allclose(cols.apply(lam), np.linalg.solve(s, gc.T @ lam), rtol=1e-12)
    assert not calls  # no solve with S: the columns were kept


def test_by_default_every_row_fits_and_the_compliance_columns_are_kept_without_a_copy():
    # before, the cap was n_c / 4 columns: with more rows in contact (cattaneo.toml: 110
    # rows of 150, 77 columns) every step fell back to the solve with S
    s, gc, solve, calls = _problem(n_c=400, m=60)
    y = np.asfortranarray(np.linalg.solve(s, gc.T.toarray()))
    cols = ContactColumns(gc, solve)
    cols.prefill(y, np.arange(60))
    assert cols.y is y and cols.count == 120
    lam = np.random.default_rng(1).standard_normal(120)
    lam[::7] = 0.0
    got = cols.apply(lam)
    assert got is not None and not calls
    assert np.allclose(got, np.linalg.solve(s, gc.T @ lam), rtol=1e-12, atol=1e-14)
