"""The interface-law audit of written output (app/output/law_audit.py,
scripts/check_interface_law.py): synthetic pairs with a known answer, and real runs."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
from support import CONFIGS, ROOT

from app.config import load_config
from app.output.law_audit import BONDED, OPEN, SLIP_MINUS, SLIP_PLUS, STICK, audit_step, failed
from app.run import RunOptions, run


def _pairs(**kw) -> dict:
    """Four pairs, mu = 0.5, p = 2: stick (q = 0.4), slip+ (q = -1), slip- (q = +1), open."""
    c = {"p_force": np.array([2.0, 2.0, 2.0, 0.0]), "q_force": np.array([0.4, -1.0, 1.0, 0.0]),
         "a_force": np.zeros(4), "c_force": np.zeros(4), "mu": np.full(4, 0.5),
         "state": np.array([STICK, SLIP_PLUS, SLIP_MINUS, OPEN]),
         "debonded_step": np.zeros(4, dtype=int),
         "slip_increment": np.array([0.0, 1e-3, -2e-3, 5e-3]),
         "slip": np.array([0.0, 1e-3, -2e-3, 5e-3])}
    c.update(kw)
    return c


def _audit(c, prev=None, dissipation=1e-3 + 2e-3):
    return audit_step(c, prev, dissipation, f_scale=2.0, u_scale=1e-2)


def test_consistent_pairs_pass():
    assert failed(_audit(_pairs())) == []


@pytest.mark.parametrize("change,name", [
    ({"q_force": np.array([0.4, 1.0, 1.0, 0.0])}, "slip_force"),  # slip+ with q = +F
    ({"slip_increment": np.array([0.0, -1e-3, -2e-3, 5e-3])}, "slip_sense"),
    ({"q_force": np.array([1.4, -1.0, 1.0, 0.0])}, "stick_bound"),  # |q| > mu p
    ({"p_force": np.array([2.0, 2.0, 2.0, 0.5])}, "open_force"),
    ({"a_force": np.array([0.0, 0.3, 0.0, 0.0])}, "moved_yet_bonded"),
    ({"slip": np.zeros(4)}, "slip_sum"),
])
def test_each_violation_is_named(change, name):
    assert name in failed(_audit(_pairs(**change)))


def test_dissipation_against_the_pairs_and_its_sign():
    assert "dissipation_vs_pairs" in failed(_audit(_pairs(), dissipation=1e-3))
    assert "dissipation_negative" in failed(_audit(_pairs(), dissipation=-3e-3))
    assert "dissipation_negative" not in failed(_audit(_pairs()))


def test_debonding_is_for_good():
    prev = _pairs(debonded_step=np.array([0, 2, 0, 0]), state=np.array([BONDED, SLIP_PLUS,
                                                                           SLIP_MINUS, OPEN]))
    now = _pairs(debonded_step=np.array([0, 0, 0, 0]), state=np.array([BONDED, BONDED,
                                                                         SLIP_MINUS, OPEN]),
                 slip=prev["slip"] + _pairs()["slip_increment"])
    fig = _audit(now, prev)
    assert fig["rebonded"] == 1 and "rebonded" in failed(fig)


def _script():
    spec = importlib.util.spec_from_file_location("check_interface_law",
                                                  ROOT / "scripts" / "check_interface_law.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_bonded_scene_passes_the_audit(tmp_path, capsys):
    """bonded.toml, 20 steps: bonded, debonding, sliding, pulled off."""
    out = tmp_path / "bonded"
    run(load_config(CONFIGS / "bonded.toml"), RunOptions(out=out, quiet=True))
    assert _script().main([str(out)]) == 0
    assert '"failed": []' in capsys.readouterr().out
