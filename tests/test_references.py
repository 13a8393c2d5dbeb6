"""The closed-form reference registry (app/references): keys, errors, study columns."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.closed_form import cattaneo_traction, hertz_cylinder, hertz_pressure
from app.errors import InputError
from app.references import REFERENCES, ContactProfile, RunFigures, reference


def _figures(mu: float, q_scale: float = 0.5) -> RunFigures:
    h = hertz_cylinder(863.0, 1.0, 200e3, 0.3, 200e3, 0.3)
    x = np.linspace(-0.2, 0.2, 401)
    length = np.full_like(x, x[1] - x[0])
    p = hertz_pressure(x, h["a"], h["p0"])
    q = cattaneo_traction(x, h["a"], h["p0"], mu, q_scale) if mu else np.zeros_like(x)
    prof = ContactProfile(x=x, p=p, q=q, length=length, p_force=p * length,
                          q_force=q * length, stick=np.abs(x) < h["a"] * math.sqrt(1 - q_scale),
                          mu=mu, E_star=h["E_star"], interface="contact")
    return RunFigures(E=200e3, nu=0.3, plane="strain", thickness=1.0, strain_energy=1.0,
                      point_values={}, contact=prof)


def test_every_reference_has_columns_that_its_errors_produce():
    fig = _figures(0.2)
    tables = {"hertz": {"type": "hertz", "radius": 1.0},
              "cattaneo": {"type": "cattaneo", "radius": 1.0}}
    for name, table in tables.items():
        out = reference(name).compare(table, fig)
        for path, _ in REFERENCES[name].columns:
            v = out
            for key in path:
                v = v[key]
            assert isinstance(v, float) and v < 0.05, (name, path, v)


def test_unknown_type_and_keys_are_one_line_errors():
    with pytest.raises(InputError, match="use one of 'timoshenko', 'hertz', 'cattaneo'"):
        reference("hertzz")
    with pytest.raises(InputError, match=r"unknown key\(s\) \['radios'\]"):
        reference("hertz").params({"type": "hertz", "radios": 1.0})
    with pytest.raises(InputError, match="needs radius"):
        reference("cattaneo").params({"type": "cattaneo"})
    with pytest.raises(InputError, match="needs an \\[\\[interface\\]\\]"):
        reference("hertz").compare({"radius": 1.0}, RunFigures(1.0, 0.3, "strain", 1.0, 1.0,
                                                                {}))


def test_cattaneo_without_friction_reports_nan_not_a_crash():
    out = reference("cattaneo").compare({"type": "cattaneo", "radius": 1.0}, _figures(0.0))
    assert math.isnan(out["cattaneo"]["traction_l2_rel_error"])
    assert out["hertz"]["p_max_rel_error"] < 1e-3


def test_overlay_reproduces_the_closed_form():
    fig = _figures(0.2)
    out = reference("cattaneo").compare({"type": "cattaneo", "radius": 1.0}, fig)
    curves = REFERENCES["cattaneo"].overlay(out, 0.2)
    x = fig.contact.x
    h = out["hertz"]
    np.testing.assert_allclose(curves["p"][1](x), hertz_pressure(x, h["a_hertz"], h["p0_hertz"]))
    assert np.abs(curves["p"][1](x) - fig.contact.p).max() < 0.02 * fig.contact.p.max()
    assert curves["q"][0] == "Cattaneo-Mindlin"


def test_hertz_centre_off_the_interface_is_an_input_error():
    """reference.center_x = 1e308 overflowed the contact edges to -inf in a completed
    summary (scripts/fuzz_inputs.py); any centre outside the pairs is meaningless."""
    import numpy as np
    import pytest

    from app.errors import InputError
    from app.references.base import ContactProfile, RunFigures
    from app.references.hertz import pressure_errors

    x = np.linspace(-0.2, 0.2, 21)
    p = np.maximum(0.0, 1.0 - (x / 0.1) ** 2)
    c = ContactProfile(x=x, p=p, q=0 * x, length=np.full(21, 0.02), p_force=p * 0.02,
                       q_force=0 * x, stick=np.zeros(21, bool), mu=0.0, E_star=1e3,
                       interface="contact")
    run = RunFigures(E=1e3, nu=0.3, plane="strain", thickness=1.0, strain_energy=1.0,
                     point_values={}, contact=c)
    assert pressure_errors({"radius": 1.0, "center_x": 0.05}, run)["center_x"] == 0.05
    for x0 in (1e308, 0.3, -0.21):
        with pytest.raises(InputError, match="lies outside interface 'contact'"):
            pressure_errors({"radius": 1.0, "center_x": x0}, run)


def test_a_hertz_centre_on_a_single_pair_at_round_off_is_on_the_interface():
    """hertz.toml with search_distance = 1e-9 has one pair, at x = -1.8e-16 (the arc's
    bottom node): reference.center_x = 0 read as outside it, and the run failed after its
    last step (`... pairs span x = -1.837e-16 to -1.837e-16`). Round-off is inside now."""
    from app.references.hertz import pressure_errors

    x = np.array([-1.8369701987210297e-16])
    c = ContactProfile(x=x, p=np.array([4.6e4]), q=0 * x, length=np.array([0.019]),
                       p_force=np.array([863.0]), q_force=0 * x, stick=np.zeros(1, bool),
                       mu=0.0, E_star=1.1e5, interface="contact")
    run = RunFigures(E=2e5, nu=0.3, plane="strain", thickness=1.0, strain_energy=1.0,
                     point_values={}, contact=c)
    assert pressure_errors({"radius": 1.0, "center_x": 0.0}, run)["center_x"] == 0.0
    with pytest.raises(InputError, match="lies outside interface 'contact'"):
        pressure_errors({"radius": 1.0, "center_x": 1e-6}, run)


@pytest.mark.parametrize("thickness", [0.5, 1.0, 2.0])
def test_timoshenko_load_is_per_unit_thickness_like_the_configs_loads(thickness):
    """cantilever.toml's traction integrates to P per unit thickness and the run multiplies
    it by the thickness, so the beam's tip deflection does not depend on the thickness and
    its energy is proportional to it. The reference took reference.P as the total force:
    at thickness 2 it halved both (tip error 98%, energy error 295% on a right answer)."""
    from app.closed_form import timoshenko_cantilever

    one = timoshenko_cantilever(10.0, 0.0, P=1.0, L=10.0, D=1.0, E=1e3, nu=0.3)
    run = RunFigures(E=1e3, nu=0.3, plane="strain", thickness=thickness,
                     strain_energy=one["strain_energy"] * thickness,
                     point_values={"tip": {"ux": 0.0, "uy": one["tip_deflection"]}})
    out = reference("timoshenko").compare({"type": "timoshenko", "P": 1.0, "L": 10.0,
                                           "D": 1.0, "point": "tip"}, run)
    assert out["tip_deflection_rel_error"] < 1e-12
    assert out["strain_energy_rel_error"] < 1e-12


def test_a_hertz_reference_on_an_interface_along_y_is_an_input_error():
    """The hertz scene turned by 90 deg: p is a function of y, and x is the distance from
    the flat across it (0 to 0.05 on the arc's pairs), so center_x = 0 lay on the
    interface and p(x) was compared with Hertz at the wrong coordinate, without a word."""
    from app.references.hertz import pressure_errors

    fig = _figures(0.0)
    c = fig.contact
    s = c.x  # the pairs' positions along the flat, now along y
    c.x, c.y = 1.0 - np.sqrt(1.0 - s**2), s  # the arc turned: x across, from 0 to 0.02
    with pytest.raises(InputError, match="runs along y"):
        pressure_errors({"radius": 1.0, "center_x": 0.0}, fig)
    c.x, c.y = s, c.x  # as shipped: along x
    assert pressure_errors({"radius": 1.0, "center_x": 0.0}, fig)["hertz"][
        "p_max_rel_error"] < 1e-3


def test_timoshenko_compares_the_point_where_it_is():
    """[points] tip = [5, 0.5] (mid-span, top fibre): its uy is compared with the closed
    form's uy there (before: with the tip's, a 69% error on a right answer); a point off
    the beam is a one-line InputError."""
    from app.closed_form import timoshenko_cantilever

    kw = dict(P=1.0, L=10.0, D=1.0, E=1e3, nu=0.3)
    mid = timoshenko_cantilever(5.0, 0.5, **kw)
    energy = mid["strain_energy"]
    table = {"type": "timoshenko", "P": 1.0, "L": 10.0, "D": 1.0, "point": "tip"}

    def compare(x, y, uy):
        run = RunFigures(E=1e3, nu=0.3, plane="strain", thickness=1.0, strain_energy=energy,
                         point_values={"tip": {"x": x, "y": y, "ux": 0.0, "uy": uy}})
        return reference("timoshenko").compare(table, run)

    out = compare(5.0, 0.5, float(mid["uy"]))
    assert out["tip_deflection_rel_error"] < 1e-12
    assert out["tip_deflection_exact"] == pytest.approx(float(mid["uy"]), rel=1e-15)
    tip = timoshenko_cantilever(10.0, 0.0, **kw)["tip_deflection"]
    assert compare(10.0, 0.0, tip)["tip_deflection_rel_error"] < 1e-12
    for x, y in ((12.0, 0.0), (5.0, 0.6), (-1.0, 0.0)):
        with pytest.raises(InputError, match="is not on the beam"):
            compare(x, y, tip)


def test_cattaneo_overlay_left_out_where_the_errors_have_no_closed_form():
    """|Q| > mu P (a bond's strength added to friction): the errors are NaN with a `note`
    (no Cattaneo-Mindlin closed form), and the picture draws no Cattaneo q either (it drew
    mu p as "Cattaneo-Mindlin" before); at gross slip up to round-off it draws mu p."""
    import dataclasses

    fig = _figures(0.2)
    for scale, drawn in ((1.3, False), (1.0 + 1e-12, True)):
        c = fig.contact
        prof = dataclasses.replace(c, q=scale * 0.2 * c.p, q_force=scale * 0.2 * c.p_force)
        out = reference("cattaneo").compare({"type": "cattaneo", "radius": 1.0},
                                            dataclasses.replace(fig, contact=prof))
        assert ("note" in out["cattaneo"]) is not drawn
        curves = REFERENCES["cattaneo"].overlay(out, 0.2)
        assert ("q" in curves) is drawn, scale
        if drawn:
            h = out["hertz"]
            np.testing.assert_allclose(curves["q"][1](c.x),
                                       0.2 * hertz_pressure(c.x, h["a_hertz"], h["p0_hertz"]))


def test_an_interface_along_y_is_named_before_a_centre_off_its_x_span():
    """The scene turned by 90 deg and moved to x = 5: center_x = 0 is off the pairs' x span
    (5 to 5.02), but the cause is that the contact runs along y: that is the message (it
    said "the contact centre must be on the interface", and center_x = 5 then met the
    along-y error)."""
    from app.references.hertz import pressure_errors

    fig = _figures(0.0)
    c = fig.contact
    c.x, c.y = 5.0 + 1.0 - np.sqrt(1.0 - c.x**2), c.x.copy()
    with pytest.raises(InputError, match="runs along y"):
        pressure_errors({"radius": 1.0, "center_x": 0.0}, fig)
