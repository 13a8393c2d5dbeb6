"""Do two output folders look the same in ParaView? Run with ParaView's Python:

    xvfb-run -a pvpython scripts/compare_xdmf.py OUT_A OUT_B [--times 1,2,50,100]

Opens results.xdmf and contact.xdmf of both folders with ParaView's XDMF3
(`Xdmf3ReaderS`) and XDMF2 (`XDMFReader`) readers and, at each time (default: every time
of OUT_A), fetches the points, the cell count and every point and cell array, and
compares them. Prints one JSON line per file, reader and time: {"file", "reader", "time",
"arrays" (their number), "max_abs_diff", "problems"}, then {"max_abs_diff"} over all;
exit 1 if the arrays or times differ. Used to check that a change of the writer (links to
one copy, virtual stress components) leaves what ParaView reads unchanged. A folder
without results.xdmf, or --times that are not numbers, stops with `error:` and exit 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


def fetch(reader, t: float) -> dict[str, np.ndarray]:
    """The dataset of `reader` at time t: points, cell count and arrays ("P:" / "C:")."""
    import paraview.simple as pvs
    from vtk.util.numpy_support import vtk_to_numpy

    reader.UpdatePipeline(t)
    d = pvs.servermanager.Fetch(reader)
    if d.IsA("vtkMultiBlockDataSet"):
        d = d.GetBlock(0)
    out = {"points": vtk_to_numpy(d.GetPoints().GetData()),
           "n_cells": np.array([d.GetNumberOfCells()])}
    for kind, fd in (("P", d.GetPointData()), ("C", d.GetCellData())):
        for i in range(fd.GetNumberOfArrays()):
            arr = fd.GetArray(i)
            out[f"{kind}:{arr.GetName()}"] = vtk_to_numpy(arr)
    return out


def compare(a: str, b: str, times: list[float] | None):
    """Yield one row per file, reader and time, comparing folders a and b."""
    import paraview.simple as pvs

    for name in ("results.xdmf", "contact.xdmf"):
        for reader in ("Xdmf3ReaderS", "XDMFReader"):
            prop = "FileNames" if reader == "XDMFReader" else "FileName"
            rs = [getattr(pvs, reader)(**{prop: [f"{d}/{name}"]}) for d in (a, b)]
            tv = [[float(t) for t in np.atleast_1d(r.TimestepValues)] for r in rs]
            if tv[0] != tv[1]:
                yield {"file": name, "reader": reader, "problems": [f"times {tv[0]} vs {tv[1]}"]}
            for t in times or tv[0]:
                da, db = (fetch(r, t) for r in rs)
                problems = [f"array {k} in one only" for k in sorted(da.keys() ^ db.keys())]
                diff = 0.0
                for k in sorted(da.keys() & db.keys()):
                    if da[k].shape != db[k].shape:
                        problems.append(f"{k}: shape {da[k].shape} vs {db[k].shape}")
                        continue
                    d = np.abs(da[k].astype(float) - db[k].astype(float))
                    diff = max(diff, float(d.max(initial=0.0)))
                yield {"file": name, "reader": reader, "time": t, "arrays": len(da) - 2,
                       "max_abs_diff": diff, "problems": problems}
            for r in rs:
                pvs.Delete(r)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--times", help="comma-separated times (default: every time of A)")
    args = ap.parse_args()
    for out in (args.a, args.b):
        if not (Path(out) / "results.xdmf").is_file():
            ap.error(f"{out} has no results.xdmf: give two --out folders of runs")
    try:
        times = [float(t) for t in args.times.split(",")] if args.times else None
    except ValueError:
        ap.error(f"--times {args.times}: give comma-separated numbers, e.g. 1,2,50")
    worst, bad = 0.0, False
    for row in compare(args.a, args.b, times):
        print(json.dumps(row), flush=True)
        worst = max(worst, row.get("max_abs_diff", 0.0))
        bad = bad or bool(row["problems"]) or row.get("max_abs_diff", 0.0) > 0.0
    print(json.dumps({"max_abs_diff": worst}))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
