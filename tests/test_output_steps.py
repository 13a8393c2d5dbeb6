"""Output whose cost per step does not grow with the steps; every second in a phase."""

from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET

import pytest
from support import CONFIGS, read_summary, run_cli

import app.output.append as append_mod
from app.output.append import AppendableDocument
from app.output.summary import SummaryWriter


def _record_writes(monkeypatch) -> list[int]:
    sizes: list[int] = []
    real = os.pwrite

    def pwrite(fd, data, offset):
        sizes.append(len(data))
        return real(fd, data, offset)

    monkeypatch.setattr(append_mod.os, "pwrite", pwrite)
    return sizes


def test_appending_writes_only_the_new_entry_and_keeps_the_document_valid(tmp_path,
                                                                          monkeypatch):
    path = tmp_path / "doc.xml"
    doc = AppendableDocument(path)
    doc.rewrite("<r>\n", [], "\n</r>\n")
    inode = path.stat().st_ino
    sizes = _record_writes(monkeypatch)
    for i in range(200):
        doc.append([f"<e i='{i:04d}'/>"], "\n</r>\n")
        root = ET.parse(path).getroot()
        assert len(root) == i + 1 and root[-1].get("i") == f"{i:04d}"
    assert path.stat().st_ino == inode  # in place, never rewritten
    assert len(set(sizes[1:])) == 1  # the same bytes per step at step 2 and at step 200


def test_a_shorter_tail_is_padded_and_a_changed_file_is_rewritten(tmp_path):
    path = tmp_path / "doc.json"
    doc = AppendableDocument(path, sep=", ")
    doc.rewrite("[", ["1"], ', "a long tail"]\n')
    size = path.stat().st_size
    doc.append(["2"], "]\n")
    assert json.loads(path.read_text()) == [1, 2]
    assert path.stat().st_size == size  # padded with spaces, nothing of the old tail left
    assert doc.current()
    path.write_text("something else")
    assert not doc.current()


def test_summary_writer_appends_steps_and_rewrites_on_other_changes(tmp_path, monkeypatch):
    path = tmp_path / "summary.json"
    w = SummaryWriter(path)
    s = {"config": "c", "n_steps": 300, "steps": [], "status": "running"}
    sizes = _record_writes(monkeypatch)
    for i in range(300):
        s["steps"].append({"step": i + 1, "energy": 1.0 / (i + 1), "states": {"open": i}})
        s["strain_energy"] = 1.0 / (i + 1)
        s["timings"] = {"output": 0.001 * i, "x" * (1 + i % 7): 1}
        w.write(s)
        assert json.loads(path.read_text()) == s
    assert max(sizes) < 400  # one step's text and the trailing keys, whatever the step
    s["status"] = "completed"
    s["reference"] = {"err": 0.1}
    w.write(s)
    assert json.loads(path.read_text()) == s
    other = {"config": "d", "steps": [{"step": 1}], "status": "running"}
    SummaryWriter(path).write(other)
    assert json.loads(path.read_text()) == other


def test_many_steps_stay_readable_and_complete(tmp_path):
    meshio = pytest.importorskip("meshio")
    n = 30
    r = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(tmp_path), "--quiet",
                 "--set", f"analysis.steps={n}", "--set", f"load.0.ramp=[1,{n}]"])
    assert r.returncode == 0, r.stderr
    s = read_summary(tmp_path)
    assert s["status"] == "completed" and [st["step"] for st in s["steps"]] == list(
        range(1, n + 1))
    ends = [st["elapsed_seconds"] for st in s["steps"]]
    assert ends == sorted(ends) and ends[-1] <= s["timings"]["total"]
    with meshio.xdmf.TimeSeriesReader(str(tmp_path / "results.xdmf")) as reader:
        reader.read_points_cells()
        assert reader.num_steps == n
        t, point_data, _ = reader.read_data(n - 1)
        assert t == float(n) and point_data["displacement"].shape[1] == 3
    grids = ET.parse(tmp_path / "contact.xdmf").getroot().find("Domain/Grid")
    assert len(grids) == n
    assert not list(tmp_path.glob("*.tmp"))


SCENES = [(p.name, []) for p in sorted(CONFIGS.glob("*.toml"))] + [
    ("hertz.toml", ["--sd", "1"]), ("hard/friction.toml", []), ("hard/squeezed.toml", [])]


@pytest.mark.parametrize("config, extra", SCENES, ids=[" ".join([c, *e]) for c, e in SCENES])
def test_the_phases_add_up_to_the_total(tmp_path, config, extra):
    r = run_cli(["run", str(CONFIGS / config), "--out", str(tmp_path), "--quiet", *extra])
    assert r.returncode == 0, r.stderr
    t = read_summary(tmp_path)["timings"]
    phases = sum(v for k, v in t.items() if k != "total")
    assert abs(phases - t["total"]) <= 0.05 * t["total"], t
    if extra == ["--sd", "1"]:
        assert t["floating_modes"] > 0.0  # the hourglass eigen-solve has its own phase
