"""The output's element fields in a run of several steps form the strain matrices once
(`element_operators`), not at every step: the same fields, bitwise, at 0.27-0.31 x the
per-step cost (scripts/bench_element_fields.py)."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from support import CONFIGS

import app.discretisation.bulk as bulk
from app.config import parse_config
from app.run import RunOptions, build_scene_mesh, make_discretisation, run


@pytest.mark.parametrize(("config", "steps"), [("hertz.toml", 1), ("hard/initial_gap.toml", 4)])
def test_strain_matrices_are_formed_once_per_run(tmp_path, monkeypatch, config, steps):
    calls = []
    formed = bulk.strain_matrices
    monkeypatch.setattr(bulk, "strain_matrices", lambda *a, **k: calls.append(1) or formed(*a,
                                                                                         **k))
    path = CONFIGS / config
    s = run(parse_config(tomllib.loads(path.read_text()), path),
            RunOptions(out=tmp_path / "o", quiet=True))
    assert s["status"] == "completed" and len(s["steps"]) == steps
    assert len(calls) == 1


def test_fields_with_operators_are_the_fields_formed_each_time():
    path = CONFIGS / "cattaneo.toml"
    cfg = parse_config(tomllib.loads(path.read_text()), path)
    opts = RunOptions(quiet=True)
    mesh, disc = build_scene_mesh(cfg, opts), make_discretisation(cfg, opts)
    el = np.arange(1, mesh.n_elements, 2)
    u = np.random.default_rng(1).standard_normal(2 * mesh.n_nodes)
    for chunk in (200_000, 97):
        ops = bulk.element_operators(mesh, disc, el, chunk)
        a = bulk.element_fields(mesh, disc, u, el, chunk)
        b = bulk.element_fields(mesh, disc, u, el, chunk, operators=ops)
        for k in a:
            np.testing.assert_array_equal(a[k], b[k])
