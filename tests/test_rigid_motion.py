"""steps[k].rigid_motion: the least-squares rigid motion of each floating body (the
`rigid_modes` amplitudes ride on a solution with DOFs pinned and are not the motion)."""

from __future__ import annotations

import h5py
import numpy as np

from app.output.rigid_motion import rigid_motion
from tests.support import CONFIGS, read_summary, run_cli


def test_kernel_recovers_a_rigid_motion_under_a_deformation_orthogonal_to_it():
    rng = np.random.default_rng(1)
    pts = rng.uniform(-1.0, 2.0, (40, 2))
    node_body = np.repeat([0, 1], 20)
    c = pts[20:].mean(axis=0)
    xc = pts[20:] - c
    t, theta = np.array([0.3, -0.2]), 0.01
    u = np.zeros((40, 2))
    u[20:] = t + theta * np.c_[-xc[:, 1], xc[:, 0]]
    d = rng.standard_normal((20, 2)) * 1e-3  # a deformation with no rigid part
    a = np.zeros((40, 3))
    a[0::2, 0], a[1::2, 1] = 1.0, 1.0
    a[0::2, 2], a[1::2, 2] = -xc[:, 1], xc[:, 0]
    d = d.ravel() - a @ np.linalg.lstsq(a, d.ravel(), rcond=None)[0]
    u[20:] += d.reshape(-1, 2)
    out = rigid_motion(pts, node_body, ["a", "b"], ["b"], u.ravel())["b"]
    assert np.allclose(out["translation"], t, atol=1e-14)
    assert abs(out["rotation"] - theta) < 1e-14
    assert np.allclose(out["centroid"], c)


def test_floating_block_under_gravity_moves_down_without_turning(tmp_path):
    out = tmp_path / "out"
    res = run_cli(["run", str(CONFIGS / "hard" / "floating_gravity.toml"), "--out", str(out)])
    assert res.returncode == 0, res.stderr
    step = read_summary(out)["steps"][0]
    rm = step["rigid_motion"]["block"]
    with h5py.File(out / "step_0001.h5") as f:
        u = f["displacement"][()][:, :2]
    with h5py.File(out / "mesh.h5") as f:
        quads, body = f["quads"][()], f["body"][()]
    block = np.unique(quads[body == 1])
    # the scene is symmetric about x = 0: no sideways motion, no turn
    assert abs(rm["translation"][0]) < 1e-9 * abs(rm["translation"][1])
    assert abs(rm["rotation"]) < 1e-9
    assert rm["translation"][1] < 0 and abs(rm["translation"][1] - u[block, 1].mean()) < 1e-12
