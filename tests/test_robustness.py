"""Nothing lost: a run killed mid-way keeps readable results; broken configs get a
one-line error, never a traceback."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import tomllib

import meshio
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from support import CONFIGS, ROOT, mpi_env

from app.config import parse_config
from app.errors import InputError, SolveError
from app.run import RunOptions, run


def test_kill_9_keeps_completed_steps(tmp_path):
    out = tmp_path / "o"
    cmd = [sys.executable, "-m", "app", "run", str(CONFIGS / "cattaneo.toml"), "--out",
           str(out), "--quiet", "--mesh-size", "0.25"]
    proc = subprocess.Popen(cmd, cwd=ROOT, env=mpi_env())
    deadline = time.time() + 300
    while not (out / "step_0004.h5").exists():
        assert proc.poll() is None, "the run ended before it could be killed"
        assert time.time() < deadline
        time.sleep(0.01)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    done = sorted(p.name for p in out.glob("step_*.h5"))
    assert len(done) >= 4
    summary = json.loads((out / "summary.json").read_text())  # never half-written
    assert summary["status"] == "running" and len(summary["steps"]) >= 3
    with meshio.xdmf.TimeSeriesReader(out / "results.xdmf") as reader:
        reader.read_points_cells()
        assert reader.num_steps >= 3
        for k in range(reader.num_steps):
            t, point_data, _ = reader.read_data(k)
            assert point_data["displacement"].shape[1] == 3
    with meshio.xdmf.TimeSeriesReader(out / "contact.xdmf") as reader:
        reader.read_points_cells()
        _, pd, _ = reader.read_data(reader.num_steps - 1)
        assert "p" in pd


BASE = tomllib.loads((CONFIGS / "patch.toml").read_text())
PATHS = [("analysis", "plane"), ("analysis", "sd"), ("analysis", "steps"), ("mesh", "size"),
         ("body", 0, "E"), ("body", 0, "nu"), ("body", 1, "name"), ("body", 0, "shape", "width"),
         ("body", 1, "shape", "type"), ("body", 0, "curves", "top"), ("support", 0, "on"),
         ("support", 0, "ux"), ("load", 0, "pressure"), ("load", 0, "on"),
         ("interface", 0, "slave"), ("interface", 0, "mu"), ("interface", 0, "search_distance"),
         ("interface", 0, "c")]
VALUES = st.one_of(st.none(), st.integers(-5, 5), st.floats(allow_nan=True),
                   st.text(max_size=5), st.booleans(), st.lists(st.integers(), max_size=3),
                   st.just({}))


def _mutate(raw: dict, path: tuple, value) -> dict:
    import copy

    out = copy.deepcopy(raw)
    node = out
    for key in path[:-1]:
        node = node[key]
    if value is None:
        node.pop(path[-1], None)
    else:
        node[path[-1]] = value
    return out


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(path=st.sampled_from(PATHS), value=VALUES)
@example(path=("support", 0, "on"), value="\n")  # once printed a line break in the name
def test_broken_configs_give_one_line_errors(tmp_path, path, value):
    raw = _mutate(BASE, path, value)
    try:
        cfg = parse_config(raw, CONFIGS / "patch.toml")
        run(cfg, RunOptions(out=tmp_path / "fuzz", quiet=True, mesh_scale=2.0))
    except (InputError, SolveError) as exc:
        msg = str(exc)
        assert msg and "\n" not in msg and "Traceback" not in msg


@pytest.mark.parametrize("text", ["[mesh\nsize = 1", "mesh = 3", "[[body]]\nname = 1",
                                  "[analysis]\nsteps = -1\n[mesh]\nsize = 1.0",
                                  "[mesh]\nsize = -1.0\n[[body]]\nname='b'\nE=1.0\nnu=0.3"])
def test_broken_toml_files(tmp_path, text):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    res = subprocess.run([sys.executable, "-m", "app", "run", str(p), "--out",
                          str(tmp_path / "o")], cwd=ROOT, env=mpi_env(), capture_output=True,
                         text=True)
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1 and lines[0].startswith("error: "), res.stderr
