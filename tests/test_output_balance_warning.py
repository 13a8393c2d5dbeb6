"""The per-step balance warning (app/output/balance_warning.py)."""

from __future__ import annotations

from app.output.balance_warning import BALANCE_WARN, balance_warning


def _balance(**rel: float) -> dict:
    return {"bodies": {b: {"relative_residual": r} for b, r in rel.items()},
            "max_relative_residual": max(rel.values())}


def test_a_balanced_step_does_not_warn():
    assert balance_warning(_balance(top=1.2e-9, core=3e-15), 2) is None
    assert balance_warning(_balance(top=BALANCE_WARN), 2) is None


def test_an_unbalanced_body_is_named():
    text = balance_warning(_balance(top=1e-14, core=9.1e-5), 1)
    assert text.startswith("step 1: body 'core' is out of balance (relative residual 9.1e-05")
    assert "at most 1e-06 expected" in text


def test_nan_warns():
    assert balance_warning(_balance(top=float("nan")), 3) is not None


def test_loose_iterative_solves_are_named_as_the_cause():
    text = balance_warning(_balance(block=1.2e-6), 13, solve_rel=3.85e-7)
    assert "iterative linear solves (relative residual up to 3.85e-07)" in text
    assert "report it" not in text
    assert "report it" in balance_warning(_balance(block=1.2e-6), 13, solve_rel=1e-12)
