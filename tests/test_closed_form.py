"""Closed forms and the error definitions against them (app/closed_form.py)."""

import math
import warnings

import numpy as np
import pytest

from app.closed_form import (
    cattaneo_errors,
    cattaneo_traction,
    effective_moduli,
    hertz_cylinder,
    hertz_errors,
    hertz_pressure,
    interpolated_l2_rel_error,
    timoshenko_cantilever,
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


def _cattaneo_case(ratio: float, stick_all: bool = False) -> dict:
    """cattaneo_errors on Cattaneo's own traction at Q / (mu P) = `ratio` (Hertz P = 863,
    mu 0.2, R = 1, plane strain steel), numpy warnings raised as errors."""
    P, mu, e_star = 863.0, 0.2, 200e3 / (2 * 0.91)
    x = np.linspace(-0.2, 0.2, 161)
    a = math.sqrt(4 * P / (math.pi * e_star))  # Johnson 4.43, R = 1
    p0 = 2 * P / (math.pi * a)
    p = hertz_pressure(x, a, p0)
    q = cattaneo_traction(x, a, p0, mu, min(ratio, 1.0))
    c = a * math.sqrt(1.0 - ratio) if ratio < 0.99 else 0.0  # the whole contact slides
    stick = (p > 0) & (stick_all | (np.abs(x) < c))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return cattaneo_errors(x, p, q, np.full_like(x, x[1] - x[0]), stick, P=P,
                               Q=ratio * mu * P, mu=mu, R=1.0, E_star=e_star)


@pytest.mark.parametrize("ratio", [1.0, 1.0 + 4.4e-16, 1.0 - 1.3e-15])
def test_cattaneo_errors_at_gross_slip(ratio):
    """Q = mu P up to round-off (a run whose contact slides whole, e.g. the cylinder's top
    moved sideways, read 1 + 4.4e-16, 1 - 1.3e-15): no stick zone, c = 0, q = mu p. Before:
    a ZeroDivisionError at exactly 1, c = NaN with a RuntimeWarning above, c = 3.7e-9 a
    below."""
    e = _cattaneo_case(ratio)
    assert e["stick_half_width_exact"] == 0.0
    assert e["stick_half_width"] == 0.0
    assert math.isnan(e["stick_half_width_rel_error"])  # against c = 0: NaN, as documented
    assert e["traction_l2_rel_error"] < 1e-6


def test_cattaneo_errors_an_empty_stick_zone_is_a_full_error():
    """No pair sticks where Cattaneo has |x| < c: the stick half-width is 0, 100% off (NaN
    before, which reads as 'no reference' in a study's table)."""
    e = _cattaneo_case(0.5)
    assert e["stick_half_width_rel_error"] < 0.05
    x = np.linspace(-0.2, 0.2, 161)
    P, mu, e_star = 863.0, 0.2, 200e3 / (2 * 0.91)
    a = math.sqrt(4 * P / (math.pi * e_star))
    p = hertz_pressure(x, a, 2 * P / (math.pi * a))
    e = cattaneo_errors(x, p, mu * p, np.full_like(x, x[1] - x[0]), np.zeros(x.size, bool),
                        P=P, Q=0.5 * mu * P, mu=mu, R=1.0, E_star=e_star)
    assert e["stick_half_width"] == 0.0
    assert e["stick_half_width_rel_error"] == pytest.approx(1.0)


def test_cattaneo_errors_above_mu_p_has_no_closed_form():
    """|Q| > mu P (a bond's strength adds to friction): Cattaneo does not apply; NaN with a
    note, not a NaN stick zone from sqrt of a negative number with a RuntimeWarning."""
    e = _cattaneo_case(1.3, stick_all=True)
    assert math.isnan(e["stick_half_width_exact"])
    assert math.isnan(e["traction_l2_rel_error"])
    assert "mu P" in e["note"]
    # just past the gross-slip band: the note shows by how much (it read "= 1 > 1")
    assert "|Q| / (mu P) = 1 + 2e-08:" in _cattaneo_case(1.0 + 2e-8, stick_all=True)["note"]


def test_plane_names_other_than_strain_and_stress_are_refused():
    """effective_moduli (and timoshenko_cantilever through it) took any name but "strain"
    as plane stress: plane="plane_strain" gave the tip deflection 9.8% too large."""
    assert effective_moduli(1e3, 0.3, "stress") == (1e3, 0.3)
    e, n = effective_moduli(1e3, 0.3, "strain")
    assert e == pytest.approx(1e3 / 0.91) and n == pytest.approx(0.3 / 0.7)
    for bad in ("plane_strain", "Strain", "", None):
        with pytest.raises(ValueError, match="use 'strain' or 'stress'"):
            effective_moduli(1e3, 0.3, bad)
    with pytest.raises(ValueError, match="plane = 'plane_strain'"):
        timoshenko_cantilever(10.0, 0.0, P=1.0, L=10.0, D=1.0, E=1e3, nu=0.3,
                              plane="plane_strain")
