"""The per-pair `slip` of the step files: the accumulated slip, the sum of the steps'
slip increments (tau - tau_prev), on frictionless and frictional interfaces alike."""

from __future__ import annotations

import tomllib

import h5py
import numpy as np
import pytest
from support import CONFIGS

from app.config import parse_config
from app.interface.steps import SLIP_MINUS, SLIP_PLUS
from app.run import RunOptions, run


@pytest.mark.parametrize("mu", [0.0, 0.2])
def test_slip_accumulates_the_slip_increments(tmp_path, mu):
    raw = tomllib.loads((CONFIGS / "hertz.toml").read_text())
    raw["analysis"]["steps"] = 2
    raw["load"][0]["ramp"] = [1, 2]
    raw["interface"][0]["mu"] = mu
    out = tmp_path / "out"
    run(parse_config(raw, CONFIGS / "hertz.toml"), RunOptions(out=out, quiet=True))
    total = 0.0
    for step in (1, 2):
        with h5py.File(out / f"step_{step:04d}.h5") as f:
            c = {k: f["contact"][k][()] for k in ("slip", "slip_increment", "state", "tau")}
        total = total + c["slip_increment"]
        scale = np.abs(c["tau"]).max()
        if mu == 0.0:  # frictionless pairs slide (slip+/-): before, their slip stayed 0
            assert np.isin(c["state"], [SLIP_PLUS, SLIP_MINUS]).any()
        np.testing.assert_allclose(c["slip"], total, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(c["slip"], c["tau"], rtol=0, atol=1e-9 * scale)
