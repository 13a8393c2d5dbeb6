"""Reading a written step's pairs back (app/output/read.py)."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from app.output.read import last_step_file, read_pairs


def _write(path: Path) -> None:
    with h5py.File(path, "w") as f:
        c = f.create_group("contact")
        c["interface"] = np.array([1, 0, 0, 1, 0])
        c["x"] = np.array([0.5, 0.3, -0.2, -0.1, 0.1])
        c["p"] = np.array([5.0, 3.0, -2.0, -1.0, 1.0])
        c["normal"] = np.arange(10.0).reshape(5, 2)
        c["vertices"] = np.zeros((7, 2))  # not per pair: left out


def test_read_pairs_selects_one_interface_sorted_by_x(tmp_path: Path) -> None:
    _write(tmp_path / "step_0002.h5")
    c = read_pairs(tmp_path / "step_0002.h5", 0)
    np.testing.assert_array_equal(c["x"], [-0.2, 0.1, 0.3])
    np.testing.assert_array_equal(c["p"], [-2.0, 1.0, 3.0])
    np.testing.assert_array_equal(c["normal"], [[4, 5], [8, 9], [2, 3]])
    assert "vertices" not in c
    only = read_pairs(tmp_path / "step_0002.h5", 1, ("x", "p"))
    assert set(only) == {"x", "p"} and list(only["x"]) == [-0.1, 0.5]


def test_last_step_file(tmp_path: Path) -> None:
    assert last_step_file(tmp_path) is None
    for k in (1, 10, 2):
        _write(tmp_path / f"step_{k:04d}.h5")
    (tmp_path / "step_0011.h5.tmp").write_text("")
    assert last_step_file(tmp_path).name == "step_0010.h5"


def test_last_step_file_counts_past_step_9999(tmp_path: Path) -> None:
    """analysis.steps may be up to 100000: step_10000.h5 comes after step_9999.h5."""
    assert last_step_file(tmp_path) is None
    for k in (2, 9999, 10000, 10001):
        (tmp_path / f"step_{k:04d}.h5").touch()
    (tmp_path / "step_99999.h5.tmp").touch()  # a write in progress is no step
    assert last_step_file(tmp_path).name == "step_10001.h5"


def test_read_pairs_by_name_and_wrong_interfaces(tmp_path: Path) -> None:
    """An interface by its name (summary.json beside the file, config order); a name, a
    negative index or a float without a match, or a key the file lacks, is a ValueError
    naming what there is (before: a name or -1 read 0 pairs, silently; a key, h5py's
    KeyError 'Unable to open object')."""
    path = tmp_path / "step_0002.h5"
    _write(path)
    with pytest.raises(ValueError, match="no interface names beside"):
        read_pairs(path, "upper")
    (tmp_path / "summary.json").write_text(json.dumps(
        {"contact_interfaces": {"lower": {}, "upper": {}}}))
    np.testing.assert_array_equal(read_pairs(path, "upper")["x"], [-0.1, 0.5])
    np.testing.assert_array_equal(read_pairs(path, np.int64(0))["x"], [-0.2, 0.1, 0.3])
    for bad in ("contact", -1, 1.0, True, 2):
        with pytest.raises(ValueError, match="interface"):
            read_pairs(path, bad)
    with pytest.raises(ValueError, match=r"no /contact dataset \['q'\]"):
        read_pairs(path, 0, ("x", "q"))


def test_read_pairs_by_index_does_not_parse_the_summary(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """An index that selects pairs reads the step file alone: the summary.json beside it
    (which grows with every step) is parsed for a name, or for an index without pairs (to
    refuse one past the interfaces). Before, every call parsed it: a loop over the 35 steps
    of mindlin_cycle.toml (181 kB summary) took 7 ms a call against 1 ms, and a loop over
    the steps of a longer run grows with the square of their number."""
    path = tmp_path / "step_0002.h5"
    _write(path)
    (tmp_path / "summary.json").write_text(json.dumps(
        {"contact_interfaces": {"lower": {}, "upper": {}, "side": {}}}))
    parsed = []
    loads = json.loads
    monkeypatch.setattr(json, "loads", lambda s, *a, **k: parsed.append(1) or loads(s, *a, **k))
    np.testing.assert_array_equal(read_pairs(path, 1, ("x",))["x"], [-0.1, 0.5])
    assert parsed == []
    assert read_pairs(path, 2, ("x",))["x"].size == 0  # an interface without pairs
    with pytest.raises(ValueError, match="3 interfaces"):
        read_pairs(path, 3)
    np.testing.assert_array_equal(read_pairs(path, "upper", ("x",))["x"], [-0.1, 0.5])
    assert len(parsed) == 3
