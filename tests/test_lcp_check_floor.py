"""Lemke's final check with a round-off diagonal: the column of a floating body's mode
has M_jj = 0 in exact arithmetic and ~1e-28 in floating point. Its round-off floor must
not grow with 1 / sqrt(M_jj) (it let a warm-start basis with w = -0.09 pass as solved:
a load step of a floating cylinder, its scene turned by 90 deg, penetrating by 5e-4)."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

LM = importlib.import_module("app.lcp.lemke")

M = np.array([[1.0, 0.5, 1.0],
              [0.5, 1.0, 0.0],
              [1.0, 0.0, 1e-28]])
Q = np.array([-2.0, -3.0, 0.0])
Z = np.array([0.0, 3.0, 0.0])  # w = M z + q = (-0.5, 0, 0): row 0 violated by 0.5


@pytest.mark.parametrize("diag", [1e-28, 0.0, -1e-28])
def test_check_rejects_a_violation_beside_a_round_off_diagonal(diag):
    m = M.copy()
    m[2, 2] = diag
    w, ok, _, worst = LM._check(m, Q, Z, 1e-9)
    assert w[0] == pytest.approx(-0.5)
    assert not ok and worst > 0.01


def test_check_still_accepts_the_round_off_of_a_solution():
    z = np.array([0.0, 3.0, 0.5])  # w = (0, 0, 0) up to round-off
    m = M.copy()
    m[1, 1] = 1.0 + 1e-16
    assert LM._check(m, Q, z, 1e-9)[1]


@pytest.mark.parametrize("basis", [None, [False, True, False], [True, True, False]])
def test_lemke_answer_is_a_solution(basis):
    res = LM.lemke(M, Q, basis=None if basis is None else np.array(basis))
    assert res.status == "solved"
    w = M @ res.z + Q
    assert res.z.min() >= 0 and w.min() >= -1e-9
    assert np.abs(res.z * w).max() <= 1e-9
