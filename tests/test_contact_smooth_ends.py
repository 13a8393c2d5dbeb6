"""A mortar-smooth contact that reaches its smoothed master's end warns
(app/contact/smooth_ends.py): the patch test fails there (two_blocks, master 10x the slave:
17% of p = 10), and before, nothing said so."""

from __future__ import annotations

import h5py
import numpy as np

from tests.support import CONFIGS, read_summary, run_cli

FINE_SLAVE = ["--set", "body.lower.shape.divisions=[80,8]",
              "--set", "body.upper.shape.divisions=[8,4]",
              "--set", 'interface.interface.slave="lower_top"',
              "--set", 'interface.interface.master="upper_bottom"']


def _run(tmp_path, name: str, discretisation: str) -> tuple[dict, np.ndarray]:
    out = tmp_path / name
    res = run_cli(["run", str(CONFIGS / "two_blocks.toml"), "--out", str(out), "--quiet",
                   *FINE_SLAVE, "--set", f'interface.interface.discretisation="{discretisation}"'])
    assert res.returncode == 0, res.stderr
    with h5py.File(out / "step_0001.h5") as f:
        p = f["contact/p"][()]
    return read_summary(out), p


def test_smoothed_master_end_in_contact_warns(tmp_path):
    s, p = _run(tmp_path, "smooth", "mortar-smooth")
    assert s["contact_interfaces"]["interface"]["master_interpolation"] == "quadratic B-spline"
    assert np.abs(p - 10.0).max() / 10.0 > 0.1  # what the warning is about
    hits = [w for w in s.get("warnings", []) if "smoothed master 'upper_bottom'" in w]
    assert len(hits) == 1 and "reaches an end" in hits[0] and '"mortar"' in hits[0]


def test_linear_master_passes_and_does_not_warn(tmp_path):
    s, p = _run(tmp_path, "mortar", "mortar")
    assert np.abs(p - 10.0).max() / 10.0 < 1e-9
    assert not [w for w in s.get("warnings", []) if "smoothed master" in w]
