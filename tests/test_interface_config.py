"""[[interface]] law parameters: a and c act only on a bonded interface."""

from __future__ import annotations

import copy
import tomllib

import pytest
from support import CONFIGS

from app.config import parse_config
from app.errors import InputError

BONDED = tomllib.loads((CONFIGS / "bonded.toml").read_text())


def _bond(**kw) -> dict:
    raw = copy.deepcopy(BONDED)
    raw["interface"][0].update(kw)
    for k in [k for k, v in kw.items() if v is None]:
        del raw["interface"][0][k]
    return raw


def test_strengths_of_an_unbonded_interface_are_an_error():
    """bonded = false with a = 3, c = 4: the strengths were dropped without a word (the run
    was pure Coulomb)."""
    with pytest.raises(InputError, match="bonded = false ignores"):
        parse_config(_bond(bonded=False), CONFIGS / "bonded.toml")


@pytest.mark.parametrize("kw,bonded,a,c", [
    ({"bonded": False, "a": 0.0, "c": 0.0}, False, 0.0, 0.0),
    ({"bonded": None}, True, 3.0, 4.0),  # bonded by default when a or c > 0
    ({"bonded": True, "a": 0.0, "c": 0.0, "mu": 0.0}, True, 0.0, 0.0),
])
def test_bonded_and_strengths_that_agree_pass(kw, bonded, a, c):
    itf = parse_config(_bond(**kw), CONFIGS / "bonded.toml").interfaces[0]
    assert (itf.bonded, itf.a, itf.c) == (bonded, a, c)
