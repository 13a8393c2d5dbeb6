"""The mixed-integer search for a complementary basis (`app.lcp.mip`): where Lemke's method
ends on a secondary ray though the LCP has a solution (its matrix not copositive-plus, as
the frictional contact LCP with free floating-mode amplitudes), the search finds a basis,
and Lemke warm-started from it solves and checks the answer."""

from __future__ import annotations

import numpy as np

from app.lcp import lemke
from app.lcp.mip import MIP_MAX_SIZE, complementary_basis


def test_a_solution_that_lemke_misses_is_found():
    """z = (0, 2/3, 1/2) solves it (w = (0, 0, 0)); Lemke ends on a secondary ray."""
    m = np.array([[0.0, 0.0, 2.0], [3.0, -3.0, -2.0], [2.0, 3.0, -2.0]])
    q = np.array([-1.0, 3.0, -1.0])
    assert lemke(m, q).status == "secondary ray"
    basis, text = complementary_basis(m, q)
    assert basis is not None, text
    res = lemke(m, q, basis=basis, cold_start=False)
    assert res.status == "solved"
    np.testing.assert_allclose(res.z, [0.0, 2.0 / 3.0, 0.5], atol=1e-12)


def test_no_solution_is_said_so():
    """w = -z - 1 < 0 for every z >= 0: no solution, the words give the bound searched."""
    basis, text = complementary_basis(np.array([[-1.0]]), np.array([-1.0]))
    assert basis is None and "found no solution" in text and "1e+03" in text


def test_a_large_lcp_is_not_searched():
    n = MIP_MAX_SIZE + 1
    basis, text = complementary_basis(np.eye(n), np.ones(n))
    assert basis is None and f"size {n}" in text


def test_a_widened_bound_admits_a_larger_unknown_of_its_own():
    """z = 2000 solves w = z - 2000: beyond the bound 1e3, found with widen = 3 on it."""
    m, q = np.array([[1.0]]), np.array([-2000.0])
    assert complementary_basis(m, q)[0] is None
    basis, text = complementary_basis(m, q, widen=np.array([3.0]))
    assert basis is not None and basis[0], text
    assert lemke(m, q, basis=basis, cold_start=False).status == "solved"
