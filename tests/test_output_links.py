"""Arrays repeated from step to step are written once (app/output/links.py): later step
files link to the one copy, read the same arrays, and a step whose data changed holds
its own copy."""

from __future__ import annotations

import errno
import os
import shutil
import xml.etree.ElementTree as ET

import h5py
import meshio
import numpy as np
import pytest

import app.output.xdmf as xdmf
from app.output.links import LINK_MIN_BYTES
from app.output.xdmf import ResultWriter, restore_steps

N = LINK_MIN_BYTES // 8 + 8  # elements and pairs: every float array is above the threshold


def _mesh():
    """A strip of N quads (two bodies) and its 2 (N + 1) points."""
    x = np.arange(N + 1, dtype=float)
    points = np.concatenate([np.c_[x, 0 * x], np.c_[x, 0 * x + 1]])
    i = np.arange(N)
    quads = np.c_[i, i + 1, N + 2 + i, N + 1 + i]
    return points, quads, (i >= N // 2).astype(np.int64)


def _step(w: ResultWriter, step: int, rows: np.ndarray, body: np.ndarray) -> None:
    """One step: fields that change with the step, contact rows `rows` (m, 3) that do not
    unless the caller changes them."""
    n = len(w.points)
    disp = np.zeros((n, 3))
    disp[:, 1] = -0.01 * step * w.points[:, 0]
    stress = np.arange(4.0 * N).reshape(N, 4) * step
    contact = {"position": w.points[:N], "x": w.points[:N, 0], "slave": np.arange(N),
               "interface": np.zeros(N, dtype=np.int64),
               "p": np.linspace(0, 1, N) * step,
               "normal": np.tile([0.0, 1.0], (N, 1)), "tangent": np.tile([1.0, 0.0], (N, 1)),
               "g_cols": rows.astype(np.int64), "g_normal": rows * 0.5}
    w.write_step(step, float(step), {"displacement": disp},
                 {"stress": stress, "von_mises": stress[:, 0] + 1, "body_id": body}, contact)


def _link(path, name):
    with h5py.File(path) as f:
        return f.get(name, getlink=True)


def test_repeated_arrays_are_links_that_read_like_the_first_steps(tmp_path):
    points, quads, body = _mesh()
    w = ResultWriter(tmp_path, points, quads, body)
    rows = np.arange(3.0 * N).reshape(N, 3)
    for step in (1, 2, 3):
        _step(w, step, rows, body)
    with h5py.File(tmp_path / "step_0001.h5") as f:
        first = {k: f[f"/contact/{k}"][()] for k in ("g_cols", "g_normal", "normal_3d")}
    for step in (2, 3):
        path = tmp_path / f"step_{step:04d}.h5"
        for k in ("g_cols", "g_normal", "normal_3d", "x"):  # x: a strided view
            link = _link(path, f"/contact/{k}")
            assert isinstance(link, h5py.ExternalLink)
            assert (link.filename, link.path) == ("step_0001.h5", f"/contact/{k}")
        with h5py.File(path) as f:
            for k, v in first.items():
                np.testing.assert_array_equal(f[f"/contact/{k}"][()], v)
            np.testing.assert_array_equal(f["/body_id"][()], body)
            np.testing.assert_array_equal(f["/contact/p"][()], np.linspace(0, 1, N) * step)
        assert isinstance(_link(path, "/contact/p"), h5py.HardLink)  # changed: its own
    link = _link(tmp_path / "step_0001.h5", "/body_id")  # the mesh's /body
    assert (link.filename, link.path) == ("mesh.h5", "/body")
    grid = ET.parse(tmp_path / "contact.xdmf").getroot().find(".//Grid[@Name='contact_3']")
    items = {a.get("Name"): a[0].text for a in grid.iter("Attribute")}
    assert items["g_cols"] == "step_0001.h5:/contact/g_cols"  # the one copy itself
    assert items["p"] == "step_0003.h5:/contact/p"
    assert (os.path.getsize(tmp_path / "step_0002.h5")
            < os.path.getsize(tmp_path / "step_0001.h5") - 3 * N * 8)


def test_a_step_after_the_data_changed_holds_its_own_copy(tmp_path):
    points, quads, body = _mesh()
    w = ResultWriter(tmp_path, points, quads, body)
    rows = np.arange(3.0 * N).reshape(N, 3)
    _step(w, 1, rows, body)
    rows[5, 1] = -1.0  # in place, as a caller's array could change: a copy was kept
    other = body.copy()
    other[0] = 1
    _step(w, 2, rows, other)
    _step(w, 3, rows, other)
    for name in ("/contact/g_normal", "/body_id"):
        assert isinstance(_link(tmp_path / "step_0002.h5", name), h5py.HardLink)
        assert _link(tmp_path / "step_0003.h5", name).filename == "step_0002.h5"
    with h5py.File(tmp_path / "step_0001.h5") as f1, h5py.File(tmp_path / "step_0003.h5") as f3:
        assert f1["/contact/g_normal"][5, 1] == 0.5 * 16
        assert f3["/contact/g_normal"][5, 1] == -0.5
        np.testing.assert_array_equal(f1["/body_id"][()], body)
        np.testing.assert_array_equal(f3["/body_id"][()], other)
    zero = rows.copy()  # -0.0 and 0.0 are equal numbers but not the same bits
    zero[0, 0] = -0.0
    _step(w, 4, zero, other)
    assert isinstance(_link(tmp_path / "step_0004.h5", "/contact/g_normal"), h5py.HardLink)
    _step(w, 5, zero[:-1], other)  # fewer rows (a pair set that changed): its own copy
    with h5py.File(tmp_path / "step_0005.h5") as f:
        assert f["/contact/g_normal"].shape == (N - 1, 3)


def test_the_folder_moved_elsewhere_still_reads(tmp_path, monkeypatch):
    points, quads, body = _mesh()
    w = ResultWriter(tmp_path / "run", points, quads, body)
    rows = np.arange(3.0 * N).reshape(N, 3)
    for step in (1, 2):
        _step(w, step, rows, body)
    moved = tmp_path / "elsewhere" / "copy"
    shutil.copytree(tmp_path / "run", moved)
    shutil.rmtree(tmp_path / "run")
    monkeypatch.chdir(tmp_path)  # a relative path from another folder
    with h5py.File("elsewhere/copy/step_0002.h5") as f:
        np.testing.assert_array_equal(f["/contact/g_cols"][()], rows.astype(np.int64))
    with meshio.xdmf.TimeSeriesReader(str(moved / "results.xdmf")) as reader:
        reader.read_points_cells()
        _, _, cells = reader.read_data(1)
        np.testing.assert_array_equal(cells["body_id"][0], body)
    (moved / "step_0001.h5").unlink()  # a step file alone: an error, never other data
    with h5py.File(moved / "step_0002.h5") as f, pytest.raises(KeyError, match="external"):
        f["/contact/g_cols"][()]


def test_stress_components_are_virtual_columns_of_stress(tmp_path):
    points, quads, body = _mesh()
    w = ResultWriter(tmp_path, points, quads, body)
    rows = np.arange(3.0 * N).reshape(N, 3)
    _step(w, 1, rows, body)
    _step(w, 2, rows, body)
    with h5py.File(tmp_path / "step_0002.h5") as f:
        stress = f["/stress"][()]
        for i, c in enumerate(("s_xx", "s_yy", "s_xy", "s_zz")):
            assert f[c].is_virtual
            np.testing.assert_array_equal(f[c][()], stress[:, i])
        with h5py.File(tmp_path / "alone.h5", "w") as g:  # copied without its source
            f.copy("s_yy", g)
            assert np.isnan(g["s_yy"][()]).all()  # NaN, not zeros


def test_no_link_to_a_step_file_that_failed_or_was_removed(tmp_path, monkeypatch):
    points, quads, body = _mesh()
    w = ResultWriter(tmp_path, points, quads, body)
    rows = np.arange(3.0 * N).reshape(N, 3)
    _step(w, 1, rows, body)
    rows = rows + 1  # new rows from step 2 on

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(xdmf.os, "fsync", full)
    with pytest.raises(OSError):
        _step(w, 2, rows, body)  # step_0002.h5 never complete
    monkeypatch.undo()
    _step(w, 2, rows, body)
    assert isinstance(_link(tmp_path / "step_0002.h5", "/contact/g_normal"), h5py.HardLink)
    _step(w, 3, rows + 1, body)
    restore_steps(w, 2)  # step 3 removed (e.g. its XDMF entry failed)
    _step(w, 3, rows + 1, body)
    assert isinstance(_link(tmp_path / "step_0003.h5", "/contact/g_normal"), h5py.HardLink)
    with h5py.File(tmp_path / "step_0003.h5") as f:
        np.testing.assert_array_equal(f["/contact/g_normal"][()], (rows + 1) * 0.5)


def test_step_datasets_and_a_standalone_copy_read_through_the_links(tmp_path):
    from app.output.read import read_pairs, standalone_copy, step_datasets

    points, quads, body = _mesh()
    w = ResultWriter(tmp_path / "run", points, quads, body)
    rows = np.arange(3.0 * N).reshape(N, 3)
    for step in (1, 2):
        _step(w, step, rows, body)
    one, two = (step_datasets(tmp_path / "run" / f"step_{k:04d}.h5") for k in (1, 2))
    assert one.keys() == two.keys() and {"contact/g_cols", "body_id", "s_xx"} <= one.keys()
    np.testing.assert_array_equal(two["contact/g_cols"], one["contact/g_cols"])
    np.testing.assert_array_equal(read_pairs(tmp_path / "run" / "step_0002.h5")["g_cols"],
                                  rows.astype(np.int64))
    standalone_copy(tmp_path / "run" / "step_0002.h5", tmp_path / "alone.h5")
    shutil.rmtree(tmp_path / "run")  # the copy needs none of the folder's files
    alone = step_datasets(tmp_path / "alone.h5")
    assert alone.keys() == two.keys()
    for k, v in two.items():
        np.testing.assert_array_equal(alone[k], v)
    with h5py.File(tmp_path / "alone.h5") as f:
        assert f.attrs["step"] == 2
        assert isinstance(f.get("contact/g_cols", getlink=True), h5py.HardLink)
        assert not f["s_xx"].is_virtual
