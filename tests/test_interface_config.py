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


@pytest.mark.parametrize("mu,a,c", [(0.1, 3.0, 0.3), (0.1, 1.1, 0.11), (0.2, 3.0, 0.6)])
def test_c_equal_to_mu_a_is_allowed_despite_round_off(mu, a, c):
    """c = mu a is the law's edge (F = 0 at the full tension), but mu * a rounds above c
    for these decimals: `c = 0.3 < mu * a = 0.30000000000000004` refused it."""
    assert mu * a > c  # the round-off this test is about
    cfg = parse_config(_bond(mu=mu, a=a, c=c), CONFIGS / "bonded.toml")
    assert cfg.interfaces[0].c == c


def test_c_below_mu_a_is_still_an_error():
    with pytest.raises(InputError, match="need c >= mu a"):
        parse_config(_bond(mu=0.1, a=3.0, c=0.2999), CONFIGS / "bonded.toml")
