"""[reference] numbers are checked when the config is loaded: finite, and the lengths
positive (radius, L, D) and the Timoshenko load non-zero. Before, `radius = 0` ran the
whole scene and then stopped in a ZeroDivisionError traceback (exit 1); a negative or NaN
value gave meaningless errors with exit 0."""

import pytest
from support import CONFIGS

from app.config import load_config
from app.errors import InputError


@pytest.mark.parametrize("config, override, needle", [
    ("hertz", "reference.radius=0", "radius must be > 0"),
    ("hertz", "reference.radius=-1", "radius must be > 0"),
    ("cattaneo", "reference.radius=nan", "radius must be > 0"),
    ("hertz", "reference.center_x=inf", "center_x must be a finite number"),
    ("cantilever", "reference.P=0", "P must be a finite non-zero number"),
    # before: "P must be non-zero (got nan)"
    ("cantilever", "reference.P=nan", r"P must be a finite non-zero number \(got nan\)"),
    ("cantilever", "reference.L=-10", "L must be > 0"),
    ("cantilever", "reference.D=inf", "D must be > 0"),
    # before: a TypeError traceback after the whole run, exit 1 (scripts/fuzz_inputs.py)
    ("cantilever", "reference.point=[1e300, 0]", r"point must be a name \(got \[1e\+300, 0\]"),
    ("cantilever", 'reference.point=""', "point must be a name"),
    # before: found only after the whole run
    ("cantilever", "reference.point=nope", r"'nope' is not a name in \[points\] \(tip\)"),
])
def test_bad_reference_numbers_are_refused_at_load(config, override, needle):
    with pytest.raises(InputError, match=needle):
        load_config(CONFIGS / f"{config}.toml", [override])


@pytest.mark.parametrize("config, override", [
    ("hertz", "reference.center_x=-0.5"), ("cantilever", "reference.P=-2.0")])
def test_ordinary_reference_numbers_pass(config, override):
    assert load_config(CONFIGS / f"{config}.toml", [override]).reference is not None
