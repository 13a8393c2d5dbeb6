"""Closed forms and the error definitions against them (app/closed_form.py)."""

import numpy as np
import pytest

from app.closed_form import (
    cattaneo_traction,
    hertz_cylinder,
    hertz_errors,
    hertz_pressure,
    interpolated_l2_rel_error,
)


def test_interpolated_l2_zero_and_unit():
    a, p0 = 0.1, 100.0
    x = np.linspace(-0.2, 0.2, 401)
    exact = lambda s: hertz_pressure(s, a, p0)  # noqa: E731
    assert interpolated_l2_rel_error(x, np.zeros_like(x), exact, 1.5 * a) == pytest.approx(1.0)
    fine = interpolated_l2_rel_error(x, exact(x), exact, 1.5 * a)
    coarse = interpolated_l2_rel_error(x[::8], exact(x[::8]), exact, 1.5 * a)
    assert fine < 5e-3 and coarse > 4 * fine  # interpolation error falls with spacing


def test_interpolated_l2_is_order_independent():
    a, p0 = 0.1, 100.0
    rng = np.random.default_rng(0)
    x = rng.uniform(-0.2, 0.2, 50)
    p = hertz_pressure(x, a, p0) * (1 + 0.01 * rng.standard_normal(50))
    exact = lambda s: hertz_pressure(s, a, p0)  # noqa: E731
    o = rng.permutation(50)
    assert interpolated_l2_rel_error(x, p, exact, 0.15) == \
        interpolated_l2_rel_error(x[o], p[o], exact, 0.15)


def test_hertz_errors_on_sampled_closed_form():
    h = hertz_cylinder(863.0, 1.0, 200e3, 0.3, 200e3, 0.3)
    x = np.linspace(-0.3, 0.3, 1201)
    p = hertz_pressure(x, h["a"], h["p0"])
    length = np.full_like(x, x[1] - x[0])
    e = hertz_errors(x, p, length, P=863.0, R=1.0, E_star=h["E_star"])
    assert e["p_max_rel_error"] < 1e-3
    assert e["pressure_l2_rel_error"] < 1e-9
    assert e["pressure_l2_interp_rel_error"] < 2e-3
    # sampled exactly: the error is all the definition's own interpolation floor
    assert e["pressure_l2_interp_floor"] == e["pressure_l2_interp_rel_error"]
    coarse = hertz_errors(x[::8], p[::8], 8 * length[::8], P=863.0, R=1.0,
                          E_star=h["E_star"])
    assert coarse["pressure_l2_interp_floor"] > 2 * e["pressure_l2_interp_floor"]


def test_cattaneo_traction_limits():
    a, p0, mu = 0.1, 100.0, 0.2
    x = np.linspace(-0.12, 0.12, 25)
    assert np.allclose(cattaneo_traction(x, a, p0, mu, 1.0), mu * hertz_pressure(x, a, p0))
    assert np.allclose(cattaneo_traction(x, a, p0, mu, 0.0), 0.0, atol=1e-12)
