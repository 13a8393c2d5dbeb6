"""Can ParaView read a run's output? Run with ParaView's Python (Debian `python3-paraview`):

    pvpython scripts/check_xdmf.py OUT [OUT ...]

For each output folder, opens results.xdmf and contact.xdmf with ParaView's XDMF3 reader
(`Xdmf3ReaderS`) and its XDMF2 reader (`XDMFReader`) and checks, at every time step:
- the time values are the step numbers of the step_NNNN.h5 files present (and of
  `steps` in summary.json), with no step missing or extra;
- the number of points and cells and the bounds are those of mesh.h5 (results) and of
  /contact/position (contact);
- every array the README names is there with its number of components (displacement 3,
  stress 4, the named scalars 1; contact: normal, tangent, displacement 3), and its range
  equals the range of the HDF5 dataset of that step.
A step file holding contact pairs with no contact.xdmf (or any step file with no
results.xdmf) is a problem, "missing"; a folder with no step yet gets one line, no problem.
A study's or sweep's folder (`python -m app study`) stands for its run folders.
Prints one JSON line per folder and file: {"out", "file", "reader", "times", "problems"}.
Exit 1 if any folder has a problem; a path that is not a run's output folder stops with
`error:` and exit 2.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import h5py
import numpy as np

BULK = {"displacement": 3, "stress": 4, "s_xx": 1, "s_yy": 1, "s_xy": 1, "s_zz": 1,
        "von_mises": 1, "strain_energy_density": 1, "body_id": 1}
CONTACT = {"displacement": 3, "normal": 3, "tangent": 3, "p": 1, "q": 1, "gap": 1,
           "tau": 1, "state": 1, "slip": 1, "interface": 1, "p_force": 1, "q_force": 1}
H5_NAME = {"normal": "normal_3d", "tangent": "tangent_3d"}  # contact.xdmf renames


def step_files(out: Path) -> list[int]:
    return sorted(int(p.stem[5:]) for p in out.glob("step_*.h5")
                  if re.fullmatch(r"step_\d{4,}\.h5", p.name))


def _range(arr: np.ndarray, comps: int) -> tuple[float, float]:
    """ParaView's range: of the single component, or of the magnitude (-1) otherwise."""
    a = np.asarray(arr, dtype=float)
    if comps == 1:
        return float(a.min()), float(a.max())
    mag = np.sqrt((a.reshape(len(a), -1) ** 2).sum(axis=1))
    return float(mag.min()), float(mag.max())


def _close(a: tuple, b: tuple) -> bool:
    scale = max(abs(a[0]), abs(a[1]), abs(b[0]), abs(b[1]), 1e-300)
    return abs(a[0] - b[0]) <= 1e-9 * scale and abs(a[1] - b[1]) <= 1e-9 * scale


def check_file(out: Path, name: str, reader_name: str) -> dict:
    """Open OUT/name with a ParaView reader and compare it with the HDF5 data."""
    import paraview.simple as pvs

    problems: list[str] = []
    steps = step_files(out)
    prop = "FileNames" if reader_name == "XDMFReader" else "FileName"
    r = getattr(pvs, reader_name)(**{prop: [str(out / name)]})
    tv = r.TimestepValues
    times = [float(t) for t in (tv if hasattr(tv, "__len__") else [tv])]
    if [round(t) for t in times] != steps or any(t != round(t) for t in times):
        problems.append(f"times {times} but step files {steps}")
    for t, step in zip(times, steps, strict=False):  # a mismatch is reported above
        r.UpdatePipeline(t)
        data = pvs.servermanager.Fetch(r)
        if data.IsA("vtkMultiBlockDataSet"):
            data = data.GetBlock(0)
        with h5py.File(out / f"step_{step:04d}.h5", "r") as f:
            if name == "results.xdmf":
                with h5py.File(out / "mesh.h5", "r") as m:
                    pts, n_cells = m["points"][()], len(m["quads"])
                group = f
            else:
                pts, n_cells, group = f["contact/position"][()], None, f["contact"]
            problems += geometry_problems(data, pts, n_cells, t)
            problems += array_problems(data, group, name, t)
    pvs.Delete(r)
    return {"out": str(out), "file": name, "reader": reader_name, "times": times,
            "problems": problems}


def geometry_problems(data, pts: np.ndarray, n_cells: int | None, t: float) -> list[str]:
    """Differences of a ParaView dataset at time t from the HDF5 points (p, 2) and cell
    count (None: not checked): number of points and cells, bounds."""
    problems = []
    if data.GetNumberOfPoints() != len(pts):
        problems.append(f"t={t}: {data.GetNumberOfPoints()} points, not {len(pts)}")
    if n_cells is not None and data.GetNumberOfCells() != n_cells:
        problems.append(f"t={t}: {data.GetNumberOfCells()} cells, not {n_cells}")
    b = data.GetBounds()
    want = (pts[:, 0].min(), pts[:, 0].max(), pts[:, 1].min(), pts[:, 1].max())
    if len(pts) and not np.allclose(b[:4], want, rtol=0, atol=1e-12 * np.abs(want).max()):
        problems.append(f"t={t}: bounds {b[:4]} not {want}")
    return problems


def array_problems(data, group, name: str, t: float) -> list[str]:
    """Differences of the arrays of a ParaView dataset at time t from the HDF5 group of
    that step: every array of BULK (results.xdmf) or CONTACT that the group holds is
    there, with its number of components and the range of its HDF5 dataset."""
    expected = BULK if name == "results.xdmf" else CONTACT
    attrs = {}
    for fd in (data.GetPointData(), data.GetCellData()):
        for i in range(fd.GetNumberOfArrays()):
            a = fd.GetArray(i)
            attrs[a.GetName()] = a
    problems = []
    for arr, comps in expected.items():
        if arr not in attrs:
            if arr in group or H5_NAME.get(arr, arr) in group:
                problems.append(f"t={t}: array {arr} missing")
            continue
        a = attrs[arr]
        if a.GetNumberOfComponents() != comps:
            problems.append(f"t={t}: {arr} has {a.GetNumberOfComponents()} "
                            f"components, not {comps}")
            continue
        h5 = group[H5_NAME.get(arr, arr) if name == "contact.xdmf" else arr][()]
        if len(h5) == 0:
            continue
        pv_range = tuple(a.GetRange(0 if comps == 1 else -1))
        if not _close(pv_range, _range(h5, comps)):
            problems.append(f"t={t}: {arr} range {pv_range} vs HDF5 "
                            f"{_range(h5, comps)}")
    return problems


def _has_contact(out: Path) -> bool:
    """Does the first step file of OUT hold contact pairs (so contact.xdmf is due)?"""
    with h5py.File(out / f"step_{step_files(out)[0]:04d}.h5", "r") as f:
        return "contact" in f


def check(out: Path):
    """Every XDMF file of an output folder with both readers, plus the summary's steps:
    yields one row (dict) per finding group, as soon as it is known."""
    summary = out / "summary.json"
    if summary.exists():
        listed = [s["step"] for s in json.loads(summary.read_text()).get("steps", [])]
        if listed != step_files(out):
            yield {"out": str(out), "file": "summary.json", "problems": [
                f"summary steps {listed} but step files {step_files(out)}"]}
    if not any((out / n).exists() for n in ("results.xdmf", "contact.xdmf")) \
            and not step_files(out):
        yield {"out": str(out), "file": None, "times": [], "problems": []}  # no step yet
    for name in ("results.xdmf", "contact.xdmf"):
        if not (out / name).exists():
            if step_files(out) and (name == "results.xdmf" or _has_contact(out)):
                yield {"out": str(out), "file": name, "problems": ["missing"]}
            continue
        for reader in ("Xdmf3ReaderS", "XDMFReader"):
            try:
                yield check_file(out, name, reader)
            except Exception as exc:  # a reader that throws is a finding, not a crash
                yield {"out": str(out), "file": name, "reader": reader,
                       "problems": [f"{type(exc).__name__}: {exc}"]}


def _study_runs(out: Path) -> list[Path]:
    """The run folders (OUT/*/summary.json) of a study's or sweep's folder OUT (its own
    summary.json says `"command": "study"`), sorted; [] for any other path."""
    try:
        study = json.loads((out / "summary.json").read_text()).get("command") == "study"
    except (OSError, ValueError, AttributeError):
        return []
    return sorted(p.parent for p in out.glob("*/summary.json")) if study else []


def parse_args(argv: list[str]) -> argparse.Namespace:
    """The output folders; a path that is not a folder, or a folder without summary.json,
    results.xdmf or a step file, stops with `error:` and exit 2 (before, it printed
    nothing and exited 0: no problem found)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path, nargs="+", help="output folders of `python -m app run`")
    ap.add_argument("--one", action="store_true", help=argparse.SUPPRESS)  # the child's
    a = ap.parse_args(argv)
    a.out = [run for out in a.out for run in (_study_runs(out) or [out])]
    for out in a.out:
        if not out.is_dir():
            ap.error(f"{out} is not a folder: give a run's --out folder")
        if not ((out / "summary.json").exists() or (out / "results.xdmf").exists()
                or step_files(out)):
            ap.error(f"{out} holds no run output (no summary.json, results.xdmf or "
                     "step_NNNN.h5): give a run's --out folder")
    return a


def main() -> None:
    """Check each folder in a child pvpython: a reader that aborts (a step file listed in
    the XDMF but missing makes ParaView 5.11's XDMF3 reader call abort()) is reported."""
    import shutil
    import subprocess

    a = parse_args(sys.argv[1:])
    if a.one:
        for row in check(a.out[0]):
            print(json.dumps(row), flush=True)
        return
    bad = 0
    for arg in map(str, a.out):
        res = subprocess.run([shutil.which("pvpython") or "pvpython", __file__, "--one", arg],
                             capture_output=True, text=True)
        rows = [json.loads(x) for x in res.stdout.splitlines() if x.startswith("{")]
        if res.returncode != 0:
            last = [x for x in res.stderr.splitlines() if "what()" in x or "Error" in x]
            rows.append({"out": arg, "file": "?", "problems": [
                f"pvpython exit {res.returncode}: {last[-1].strip() if last else ''}"]})
        for row in rows:
            bad += bool(row["problems"])
            print(json.dumps(row), flush=True)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
