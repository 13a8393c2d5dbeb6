"""The XDMF/HDF5 writer (app/output/xdmf.py): what ParaView and meshio read back."""

from __future__ import annotations

import h5py
import meshio
import numpy as np

from app.output.xdmf import ResultWriter, atomic_write_text


def _square_mesh():
    points = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [2.0, 0.0], [2.0, 1.0]])
    quads = np.array([[0, 1, 2, 3], [1, 4, 5, 2]])
    return points, quads, np.array([0, 1])


def test_steps_read_back_with_meshio_and_h5py(tmp_path):
    points, quads, body = _square_mesh()
    w = ResultWriter(tmp_path, points, quads, body)
    for step in (1, 2):
        disp = np.zeros((6, 3))
        disp[:, 1] = -0.01 * step * points[:, 0]
        contact = {"position": points[:2], "p": np.array([1.0, 2.0]) * step,
                   "state": np.array([1, 4], dtype=np.int64)}
        w.write_step(step, float(step), {"displacement": disp},
                     {"von_mises": np.array([3.0, 4.0]) * step}, contact)
    with meshio.xdmf.TimeSeriesReader(str(tmp_path / "results.xdmf")) as reader:
        pts, cells = reader.read_points_cells()
        assert pts.shape[0] == 6 and cells[0].type == "quad"
        assert reader.num_steps == 2
        t, pdata, cdata = reader.read_data(1)
        assert t == 2.0
        np.testing.assert_allclose(pdata["displacement"][:, 1], -0.02 * points[:, 0])
        np.testing.assert_allclose(cdata["von_mises"][0], [6.0, 8.0])
    with h5py.File(tmp_path / "step_0002.h5") as f:
        np.testing.assert_allclose(f["contact"]["p"][()], [2.0, 4.0])
        assert f.attrs["step"] == 2
    assert not list(tmp_path.glob("*.tmp"))
    text = (tmp_path / "contact.xdmf").read_text()
    assert text.count("<Grid Name=\"contact_") == 2 and 'Name="state"' in text


def test_atomic_write_replaces_whole_file(tmp_path):
    target = tmp_path / "summary.json"
    atomic_write_text(target, "first\n")
    atomic_write_text(target, "second\n")
    assert target.read_text() == "second\n"
    assert not list(tmp_path.glob("*.tmp"))
