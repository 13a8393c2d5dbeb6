"""Path-dependent friction beyond the Mindlin cycle (README "Load reversal"): the normal
load removed, the normal load lowered under a held tangential load, and a bond sheared
both ways below its strength; each run also passes scripts/check_interface_law.py."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

from tests.support import CONFIGS, ROOT, mpi_env, read_summary, run_cli

sys.path.insert(0, str(ROOT / "scripts"))
from energy_balance import balance  # noqa: E402

APPROACH = "uy = -0.00030477   # normal approach: P -> 8.6316 with refinement (a = 0.0100005, " \
           "on a pair)\nramp = [1, 1]"
TANGENTIAL = "total_force = [1.104846, 0.0]\nramp = [2, 6]"


def cattaneo_path(tmp: Path, normal: list[float], tangential: list[float]) -> Path:
    """configs/cattaneo_aligned.toml (level 0) with the given histories of the normal
    approach and of Q* = 0.64 mu P."""
    src = (CONFIGS / "cattaneo_aligned.toml").read_text()
    assert APPROACH in src and TANGENTIAL in src
    src = src.replace("steps = 6", f"steps = {len(normal)}")
    src = src.replace(APPROACH, f"uy = -0.00030477\nhistory = {normal}")
    src = src.replace(TANGENTIAL, f"total_force = [1.104846, 0.0]\nhistory = {tangential}")
    path = tmp / "path.toml"
    path.write_text(src)
    return path


def audit_passes(out: Path) -> None:
    res = subprocess.run([sys.executable, "scripts/check_interface_law.py", str(out)],
                         cwd=ROOT, env=mpi_env(), capture_output=True, text=True)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr


def contact(out: Path, step: int) -> dict:
    with h5py.File(out / f"step_{step:04d}.h5") as f:
        return {k: f["contact"][k][()] for k in ("p_force", "q_force", "state")}


def test_normal_load_removed_leaves_no_force(tmp_path):
    """P, Q up and down, then the approach removed: the locked-in q of the unloaded Q goes
    with p (|q| <= mu p on the way), nothing is left at the end."""
    cfg = cattaneo_path(tmp_path, [1, 1, 1, 1, 1, 0.6, 0.3, 0.1, 0], [0, 0.5, 1, 0.5, 0, 0, 0,
                                                                        0, 0])
    out = tmp_path / "out"
    assert run_cli(["run", str(cfg), "--out", str(out)]).returncode == 0
    scale = contact(out, 3)["p_force"].max()
    assert np.abs(contact(out, 5)["q_force"]).max() > 0.05 * scale  # locked in at Q = 0
    last = contact(out, 9)
    assert np.abs(last["p_force"]).max() < 1e-12 * scale
    assert np.abs(last["q_force"]).max() < 1e-12 * scale
    audit_passes(out)


def test_gross_slip_starts_where_mu_p_falls_below_q(tmp_path):
    """Q* = 0.64 mu P1 held while the approach falls by 5% a step: P = 5.906 at step 10
    (mu P = 1.181 > Q* = 1.105) and 5.446 at step 11 (1.089 < Q*): no equilibrium there."""
    normal = [1, 1, 1, 1, 0.95, 0.9, 0.85, 0.8, 0.75, 0.7, 0.65, 0.6]
    cfg = cattaneo_path(tmp_path, normal, [0, 0.5] + [1] * 10)
    out = tmp_path / "out"
    res = run_cli(["run", str(cfg), "--out", str(out)])
    assert res.returncode != 0
    assert "no static equilibrium at step 11" in res.stderr, res.stderr
    steps = read_summary(out)["steps"]
    assert len(steps) == 10
    itf = steps[-1]["interfaces"]["contact"]
    assert 0.2 * itf["normal_force"] > abs(itf["tangential_force"])
    audit_passes(out)


def test_bond_sheared_both_ways_below_its_strength_is_elastic(tmp_path):
    """bonded.toml pressed, then sheared to +-0.2 of its top displacement and back: no
    pair debonds or slips, no dissipation, the same forces at the same displacements,
    and the supports' work equals the strain energy (scripts/energy_balance.py)."""
    ux = [0, 0, 0, 0.1, 0.2, 0.1, 0, -0.1, -0.2, -0.1, 0]
    cfg = bonded_path(tmp_path, ux, [1 / 3, 2 / 3] + [1] * 9)
    out = tmp_path / "out"
    assert run_cli(["run", str(cfg), "--out", str(out)]).returncode == 0
    summary = read_summary(out)
    assert all(s["states"]["bonded"] == s["n_pairs"] for s in summary["steps"])
    assert sum(s["dissipation"] for s in summary["steps"]) == 0.0
    scale = np.abs(contact(out, 5)["q_force"]).max()
    for a, b in ((3, 7), (3, 11), (4, 6)):
        assert np.abs(contact(out, a)["q_force"] - contact(out, b)["q_force"]).max() < \
            1e-10 * scale
    rows = balance(summary)
    work = sum(abs(r["work"]) for r in rows)
    assert max(abs(r["residual"]) for r in rows) < 1e-10 * work
    audit_passes(out)


def test_energy_balance_refuses_loads(tmp_path):
    out = tmp_path / "out"
    assert run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out)]).returncode == 0
    res = subprocess.run([sys.executable, "scripts/energy_balance.py", str(out)], cwd=ROOT,
                         env=mpi_env(), capture_output=True, text=True)
    assert res.returncode == 2 and res.stderr.startswith("error: ") and \
        res.stderr.count("\n") == 1, res.stderr


def bonded_path(tmp: Path, ux: list[float], uy: list[float]) -> Path:
    """configs/bonded.toml with the histories of its top's ux and uy."""
    src = (CONFIGS / "bonded.toml").read_text()
    for head, end, hist in (("history = [0, 0, 0, 0.2", "[[support]]", ux),
                            ("history = [0.333333333333", "[[interface]]", uy)):
        start = src.index(head)
        src = src[:start] + f"history = {hist}\n\n" + src[src.index(end, start):]
    cfg = tmp / "bond.toml"
    cfg.write_text(src.replace("steps = 20", f"steps = {len(ux)}"))
    return cfg


def test_debonded_pairs_stay_coulomb_on_reversal(tmp_path):
    """Sheared until every pair debonds, then back and forth: the block slides at
    |Fx| = mu Fy both ways (strength c gone), and no pair is bonded again."""
    ux = [0, 0, 0, 0.2, 0.3, 0.4, 0.2, 0, -0.2, -0.4, -0.2, 0, 0.2, 0.4]
    out = tmp_path / "out"
    cfg = bonded_path(tmp_path, ux, [1 / 3, 2 / 3] + [1] * 12)
    assert run_cli(["run", str(cfg), "--out", str(out)]).returncode == 0
    steps = read_summary(out)["steps"]
    assert steps[5]["interfaces"]["bond"]["debonded_pairs"] == steps[5]["n_pairs"]
    for k in range(6, 14):
        fx, fy = steps[k]["interfaces"]["bond"]["force"]
        assert abs(abs(fx) - 0.3 * fy) < 1e-10 * fy, (k, fx, fy)
        assert steps[k]["states"]["bonded"] == 0
    # the sense of the sliding force follows the sense of the top's motion
    assert steps[6]["interfaces"]["bond"]["force"][0] > 0 > \
        steps[10]["interfaces"]["bond"]["force"][0]
    audit_passes(out)


def test_opened_pairs_lose_their_adhesion_for_good(tmp_path):
    """Pressed, pulled until the two end pairs open (and debond), pressed again, pulled
    again: the same tension as the first time (the end pairs carry none: no re-bonding),
    then pulled off completely."""
    uy = [1 / 3, 2 / 3, 1, 0.5, 0, -1, 0, 1, 0.5, 0, -1, -2]
    out = tmp_path / "out"
    cfg = bonded_path(tmp_path, [0] * len(uy), uy)
    assert run_cli(["run", str(cfg), "--out", str(out)]).returncode == 0
    steps = read_summary(out)["steps"]
    first, second = (steps[k]["interfaces"]["bond"] for k in (5, 10))
    assert first["states"]["open"] == 2 and first["debonded_pairs"] == 2
    assert second["debonded_pairs"] == 2 and second["states"]["open"] == 2
    assert first["normal_force"] < 0  # tension held by the bonded pairs' adhesion
    assert abs(second["normal_force"] - first["normal_force"]) < 1e-9 * abs(
        first["normal_force"])
    c = contact(out, 8)
    assert c["p_force"][c["state"] != 0].min() >= -1e-12 * c["p_force"].max()
    assert steps[11]["interfaces"]["bond"]["normal_force"] == 0.0
    audit_passes(out)
