"""`app.lcp.lemke` as a library: its inputs refused with a clear ValueError (or, for a
sparse M, accepted), and the statuses and warm_start values it documents are the ones it
returns."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.sparse as sp

from app.lcp import STATUSES, lemke
from app.lcp.result import WARM_STARTS

M2 = np.array([[2.0, 1.0], [1.0, 2.0]])
Q2 = np.array([-1.0, -1.0])


def test_warm_start_failed_is_a_documented_status():
    """Before: STATUSES lacked "warm start failed", which cold_start=False returns."""
    M = np.array([[4.49, -1.58, 2.8, 0.54, -3.03], [-1.24, 9.48, -0.78, -1.07, 3.99],
                  [2.07, -0.28, 2.89, 3.3, -1.08], [0.53, -0.56, 3.1, 4.21, 1.07],
                  [-3.79, 3.87, -1.78, 1.18, 16.3]])  # (tests/test_lemke.py's case)
    q = np.array([0.35, -0.59, -0.35, -0.5, 2.11])
    bad = np.array([True, False, True, True, True])
    res = lemke(M, q, basis=bad, cold_start=False, crash=False)
    assert res.status == "warm start failed" and res.warm_start == "failed"
    assert res.status in STATUSES and res.warm_start in WARM_STARTS
    full = lemke(M, q, basis=bad, crash=False)
    assert full.warm_start == "cold" and full.warm_start in WARM_STARTS


@pytest.mark.parametrize("kwargs, q, expected", [
    ({}, Q2, "crash"),
    ({"crash": False}, Q2, "none"),
    ({}, -Q2, "none"),
    ({"basis": np.array([True, True])}, Q2, "accepted"),
    ({"basis": np.array([True, False]), "crash": False}, Q2, "lemke"),
])
def test_warm_start_values_are_documented(kwargs, q, expected):
    res = lemke(M2, q, **kwargs)
    assert res.ok and res.warm_start == expected and res.warm_start in WARM_STARTS


def test_sparse_matrix_is_densified():
    """Before: ValueError 'setting an array element with a sequence'."""
    res = lemke(sp.csr_matrix(M2), Q2)
    ref = lemke(M2, Q2)
    assert res.ok and res.pivots == ref.pivots
    np.testing.assert_array_equal(res.z, ref.z)


@pytest.mark.parametrize("q", [np.full((2, 2), -1.0), np.full((1, 4), -1.0),
                               np.full((4, 1, 1), -1.0)])
def test_q_not_a_vector_is_refused(q):
    """Before: q of shape (2, 2) was flattened and the error read 'M must be (4, 4)'."""
    M = np.eye(q.size)
    with pytest.raises(ValueError, match=r"q must be 1-D.*got shape"):
        lemke(M, q)


def test_q_column_is_accepted():
    res = lemke(M2, Q2.reshape(2, 1))
    assert res.ok and res.z.shape == (2,)
    np.testing.assert_allclose(res.z, [1 / 3, 1 / 3])


@pytest.mark.parametrize("M, q", [(M2 + 1e-3j, Q2), (M2, Q2 + 0j)])
def test_complex_input_is_refused(M, q):
    """Before: the imaginary part dropped with only numpy's ComplexWarning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match="must be real"):
            lemke(M, q)


@pytest.mark.parametrize("max_pivots", [-1, 1.5, 2.0, True, "10"])
def test_bad_max_pivots_is_refused(max_pivots):
    """Before: -1 and 1.5 were accepted silently (int(1.5) = 1)."""
    with pytest.raises(ValueError, match="max_pivots must be an integer >= 0"):
        lemke(M2, Q2, max_pivots=max_pivots)


def test_integer_max_pivots_still_accepted():
    assert lemke(M2, Q2, max_pivots=np.int64(0), crash=False).status == "pivot limit"
    assert lemke(M2, Q2, max_pivots=10).ok


@pytest.mark.parametrize("basis", [[0.5, 0.5], np.array([2, 0]), ["a", "b"]])
def test_basis_not_bool_is_refused(basis):
    """Before: [0.5, 0.5] read as [True, True] silently."""
    with pytest.raises(ValueError, match="basis must be an \\(n,\\) bool array"):
        lemke(M2, Q2, basis=basis)


def test_basis_of_zeros_and_ones_is_accepted():
    res = lemke(M2, Q2, basis=[1, 1])
    assert res.ok and res.warm_start == "accepted"
    assert lemke(M2, Q2, basis=np.array([1.0, 0.0]), crash=False).ok
