"""The level mesh of a study (app/studies/level_mesh.py): its progress line tells the truth."""

from __future__ import annotations

import math

from support import CONFIGS

from app.config import load_config
from app.errors import InputError
from app.studies import level_mesh


def test_a_level_mesh_that_cannot_be_built_prints_no_ready_line(tmp_path, monkeypatch, capsys):
    import app.mesh.build

    def fail(*args, **kwargs):
        raise InputError("body 'cylinder': too many boundary elements")

    monkeypatch.setattr(app.mesh.build, "build_mesh", fail)
    cfg = load_config(CONFIGS / "hertz.toml", [])
    seconds = level_mesh.build_level_mesh(cfg, 1.0, tmp_path / "mesh_cache", "level 0 of 0..0")
    assert math.isnan(seconds)  # the runs report the error themselves
    # (before: "level 0/0: gmsh mesh ready in nan s", then the runs' error)
    assert "ready" not in capsys.readouterr().out


def test_a_built_level_mesh_prints_its_seconds(tmp_path, monkeypatch, capsys):
    import app.mesh.build

    monkeypatch.setattr(app.mesh.build, "build_mesh", lambda *a, **k: None)
    cfg = load_config(CONFIGS / "hertz.toml", [])
    seconds = level_mesh.build_level_mesh(cfg, 1.0, tmp_path / "mesh_cache", "level 0 of 0..0")
    assert seconds >= 0
    assert "level 0 of 0..0: gmsh mesh ready in" in capsys.readouterr().out
