"""Shared test helpers: run the CLI in a subprocess (optionally under mpiexec -n 2)."""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"


def mpi_env() -> dict[str, str]:
    env = dict(os.environ)
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
               OMPI_MCA_rmaps_base_oversubscribe="1")
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def run_cli(args: list[str], ranks: int = 1, timeout: float = 600) -> subprocess.CompletedProcess:
    """Run `python -m app ARGS` (under `mpiexec -n ranks` when ranks > 1)."""
    cmd = [sys.executable, "-m", "app", *args]
    if ranks > 1:
        mpiexec = shutil.which("mpiexec")
        if mpiexec is None:
            pytest.fail("mpiexec not found: install openmpi-bin (scripts/setup.sh does)")
        cmd = [mpiexec, "-n", str(ranks), *cmd]
    return subprocess.run(cmd, cwd=ROOT, env=mpi_env(), capture_output=True, text=True,
                          timeout=timeout)


def read_csv(path: Path) -> list[dict]:
    """The rows of a CSV file written by a study or sweep, as dicts of strings."""
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def read_summary(out: Path) -> dict:
    return json.loads((Path(out) / "summary.json").read_text())


def kkt_violations(out: Path, step: int, f_scale: float = 0.0) -> dict:
    """Recompute gap, slip, p and q of one step from the written displacement field and
    pair geometry, and return the largest violations of METHOD section 4, relative to the
    displacement scale and to max(f_scale, the step's largest pair force)."""
    import h5py
    import numpy as np

    with h5py.File(Path(out) / f"step_{step:04d}.h5") as f:
        u = f["displacement"][()][:, :2]
        c = {k: f["contact"][k][()] for k in f["contact"]}
    if "g_cols" in c:  # the written rows of G (any discretisation)
        uc = u.ravel()[c["g_cols"]]
        gap = c["g0"] + np.sum(c["g_normal"] * uc, axis=1)
        tau = np.sum(c["g_tangent"] * uc, axis=1)
    else:  # node-to-segment files without G rows: from the pair geometry
        s, (a_, b_), xi = c["slave"], c["master"].T, c["xi"]
        d = u[s] - (1 - xi)[:, None] * u[a_] - xi[:, None] * u[b_]
        gap = c["g0"] + np.sum(c["normal"] * d, axis=1)
        tau = np.sum(c["tangent"] * d, axis=1)
    p, q = c["p_force"], c["q_force"]
    a, cc, mu = c["a_force"], c["c_force"], c["mu"]
    bound = mu * p + cc
    fs = max(np.abs(p).max(), np.abs(q).max(), np.abs(a).max(initial=0), f_scale, 1e-300)
    us = max(np.abs(u).max(), 1e-300)
    dtau = tau - c["tau_prev"]
    slipping = np.abs(dtau) > 1e-7 * us
    return {
        "gap": max(0.0, -gap.min()) / us,
        "normal_force": max(0.0, -(p + a).min()) / fs,
        "complementarity": np.abs(gap * (p + a)).max() / (us * fs),
        "friction_bound": max(0.0, (np.abs(q) - bound).max()) / fs,
        "slip_direction": (np.abs(q + np.sign(dtau) * bound)[slipping].max(initial=0.0)
                           / fs),
        "stick": np.abs(dtau[~slipping]).max(initial=0.0) / us,
        "gap_vs_written": np.abs(gap - c["gap"]).max() / us,
    }


def rectangle_body(name: str, origin: tuple[float, float], width: float = 1.0,
                   height: float = 1.0, curves: dict[str, str] | None = None,
                   extra: str = "") -> str:
    """The TOML of one `[[body]]`: a structured rectangle of E = 1000, nu = 0.3, `extra`
    lines (e.g. 'size = 0.5') among its keys and `curves` (side -> curve name)."""
    text = (f'[[body]]\nname = "{name}"\nE = 1000.0\nnu = 0.3\n{extra}'
            f'[body.shape]\ntype = "rectangle"\norigin = [{origin[0]}, {origin[1]}]\n'
            f"width = {width}\nheight = {height}\nstructured = true\n")
    if curves:
        text += "[body.curves]\n" + "".join(f'{k} = "{v}"\n' for k, v in curves.items())
    return text


def cleared_petsc_options(keys: tuple[str, ...]):
    """Generator for a fixture: PETSc's options database with `keys` cleared, yielded,
    and the earlier values put back afterwards."""
    from petsc4py import PETSc

    o = PETSc.Options()
    saved = {k: o.getString(k) for k in keys if o.hasName(k)}
    for k in keys:
        o.delValue(k)
    yield o
    for k in keys:
        o.delValue(k)
    for k, v in saved.items():
        o.setValue(k, v)


def signal_when_ready(cmd: list[str], sig: int, readies: int = 1, env=None,
                      settle: float = 0.3, timeout: float = 60
                      ) -> tuple[subprocess.CompletedProcess, str, float]:
    """Start cmd (cwd ROOT), send sig once `readies` "ready" lines have come (mpiexec may
    forward two ranks' lines interleaved: "readyready" then an empty line) and `settle`
    seconds passed; (the finished process, the stdout seen before the signal, seconds from
    the signal to its end)."""
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env or mpi_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    seen = ""
    while seen.count("ready") < readies:
        line = proc.stdout.readline()
        assert line, f"ended before {readies} x ready: {seen!r}"
        seen += line
    time.sleep(settle)
    t0 = time.time()
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=timeout)
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err), seen, time.time() - t0
