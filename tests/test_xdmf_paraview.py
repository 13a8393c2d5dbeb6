"""Output for ParaView: named stress components, contact points that warp with the mesh,
3-component normal and tangent, load factors per step; meshio and (when installed)
ParaView open both XDMF files."""

from __future__ import annotations

import os
import shutil
import subprocess
import xml.etree.ElementTree as ET

import h5py
import meshio
import numpy as np
import pytest
from support import CONFIGS, ROOT, run_cli

from app.output.xdmf import ResultWriter


def _write_two_steps(tmp_path):
    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [2, 0], [2, 1]], dtype=float)
    quads = np.array([[0, 1, 2, 3], [1, 4, 5, 2]])
    w = ResultWriter(tmp_path, pts, quads, np.zeros(2, dtype=np.int64))
    for step in (1, 2):
        disp = np.zeros((6, 3))
        disp[:, 1] = -0.1 * step * np.arange(6)
        stress = np.arange(8.0).reshape(2, 4) * step
        contact = {"position": pts[[1, 2]], "slave": np.array([1, 2]),
                   "normal": np.array([[0.0, 1.0], [0.0, 1.0]]),
                   "tangent": np.array([[1.0, 0.0], [1.0, 0.0]]), "p": np.array([1.0, 2.0])}
        w.write_step(step, float(step), {"displacement": disp}, {"stress": stress}, contact,
                     load_factors={"load:top": 0.5 * step, "support:left": 1.0,
                                   "support:left#2": -step})
    return w


def test_writer_adds_the_paraview_arrays(tmp_path):
    _write_two_steps(tmp_path)
    with h5py.File(tmp_path / "step_0002.h5") as f:
        np.testing.assert_array_equal(f["s_xy"][()], [4.0, 12.0])
        np.testing.assert_array_equal(f["stress"][()][:, 2], f["s_xy"][()])
        np.testing.assert_array_equal(f["contact/displacement"][()][:, 1], [-0.2, -0.4])
        assert f["contact/normal"].shape == (2, 2)  # kept for scripts
        np.testing.assert_array_equal(f["contact/normal_3d"][()], [[0, 1, 0], [0, 1, 0]])
        np.testing.assert_array_equal(f["load_factor"][()], [1.0, 1.0, -2.0])
        assert list(f.attrs["load_factor_names"]) == ["load:top", "support:left",
                                                      "support:left#2"]
    grid = ET.parse(tmp_path / "contact.xdmf").getroot().find(".//Grid[@Name='contact_2']")
    attrs = {a.get("Name"): a for a in grid.iter("Attribute")}
    assert attrs["normal"].get("AttributeType") == "Vector"
    assert attrs["normal"][0].text.endswith("/contact/normal_3d")
    assert attrs["displacement"].get("AttributeType") == "Vector"
    info = {i.get("Name"): i.get("Value") for i in grid.iter("Information")}
    assert info == {"load_factor load:top": "1", "load_factor support:left": "1",
                    "load_factor support:left#2": "-2"}


def test_meshio_still_reads_both_files(tmp_path):
    _write_two_steps(tmp_path)
    with meshio.xdmf.TimeSeriesReader(tmp_path / "results.xdmf") as r:
        r.read_points_cells()
        t, pd, cd = r.read_data(1)
    assert t == 2.0 and {"s_xx", "s_yy", "s_xy", "s_zz", "stress"} <= set(cd)
    with meshio.xdmf.TimeSeriesReader(tmp_path / "contact.xdmf") as r:
        r.read_points_cells()
        t, pd, cd = r.read_data(0)
    assert pd["normal"].shape == (2, 3) and pd["displacement"].shape == (2, 3)


PV_SCRIPT = r"""
import sys
from paraview.simple import *
out = sys.argv[1]
for name, arrays in (("results.xdmf", ["s_xx", "s_yy", "s_xy", "s_zz", "stress"]),
                     ("contact.xdmf", ["displacement", "normal", "tangent", "p"])):
    r = Xdmf3ReaderS(FileName=[out + "/" + name])
    tv = r.TimestepValues
    tv = list(tv) if hasattr(tv, "__len__") else [tv]
    print(name, "times", tv)
    r.UpdatePipeline(max(tv))
    have = {a.GetName(): a.GetNumberOfComponents()
            for a in list(r.PointData) + list(r.CellData)}
    print(name, sorted(have.items()), "field", [a.GetName() for a in r.FieldData])
    for a in arrays:
        assert a in have, (name, a, have)
    if name == "contact.xdmf":
        assert have["normal"] == 3 and have["displacement"] == 3
        warp = WarpByVector(Input=r, Vectors=["POINTS", "displacement"])
        warp.UpdatePipeline()
view = CreateView("RenderView")
view.ViewSize = [800, 500]
res = Xdmf3ReaderS(FileName=[out + "/results.xdmf"])
disp = Show(WarpByVector(Input=res, Vectors=["POINTS", "displacement"]), view)
ColorBy(disp, ("CELLS", "s_yy"))
cont = WarpByVector(Input=Xdmf3ReaderS(FileName=[out + "/contact.xdmf"]),
                    Vectors=["POINTS", "displacement"])
Show(Glyph(Input=cont, OrientationArray=["POINTS", "normal"], ScaleArray=["POINTS", "p"],
           ScaleFactor=1e-4, GlyphType="Arrow"), view)
ResetCamera(view)
SaveScreenshot(out + "/paraview.png", view)
print("ok")
"""


def _xvfb():
    """Start an X server of our own (Xvfb -displayfd); returns (process, DISPLAY)."""
    r, w = os.pipe()
    proc = subprocess.Popen(["Xvfb", "-displayfd", str(w), "-screen", "0", "1024x768x24",
                             "-nolisten", "tcp"], pass_fds=(w,), stderr=subprocess.DEVNULL)
    os.close(w)
    with os.fdopen(r) as fh:
        number = fh.readline().strip()
    return proc, f":{number}"


@pytest.mark.slow
def test_paraview_opens_contact_and_results(tmp_path):
    """ParaView (Debian's pvbatch) opens both files with the arrays and renders a PNG."""
    pvbatch = shutil.which("pvbatch")
    if pvbatch is None or shutil.which("Xvfb") is None:
        pytest.skip("ParaView (pvbatch) or Xvfb is not installed")
    out = tmp_path / "hertz"
    res = run_cli(["run", str(CONFIGS / "hertz.toml"), "--out", str(out), "--quiet",
                   "--set", "analysis.steps=3"])
    assert res.returncode == 0, res.stderr
    script = tmp_path / "pv.py"
    script.write_text(PV_SCRIPT)
    xvfb, display = _xvfb()
    try:
        pv = subprocess.run([pvbatch, str(script), str(out)], cwd=ROOT, capture_output=True,
                            text=True, timeout=300, env={**os.environ, "DISPLAY": display})
    finally:
        xvfb.terminate()
        xvfb.wait(timeout=30)
    assert pv.returncode == 0 and "ok" in pv.stdout, pv.stdout + pv.stderr
    assert "times [1.0, 2.0, 3.0]" in pv.stdout
    assert (out / "paraview.png").stat().st_size > 10_000
