"""XDMF3 + HDF5 time series that ParaView and meshio (TimeSeriesReader) open.

Layout in the output folder (rank 0 writes; other ranks pass their data to rank 0):
- mesh.h5: /points (n, 2), /quads (ne, 4), /body (ne,)
- step_0001.h5, step_0002.h5, ...: one closed file per completed load step, with
  /displacement (n, 3) (z = 0 for ParaView's warp filter), /stress (ne, 4)
  (s_xx, s_yy, s_xy, s_zz), /von_mises (ne,), /energy_density (ne,), and, with contact,
  the group /contact (see `ResultWriter.write_step`). A dataset equal to the last written
  copy of the same name is an external link to it (mesh.h5's /body for /body_id, or an
  earlier step file), and /s_xx ... are virtual columns of /stress (app/output/links.py);
  the XDMF files name the one copy itself.
- results.xdmf: temporal collection of the bulk fields (one Uniform grid per step).
- contact.xdmf: temporal collection of the contact pairs as points (when there is contact).
Both XDMF files are written whole through a temporary file and a rename at the first
step, then extended by one in-place write per step (app/output/append.py): the cost of a
step does not grow with the number of steps, and a run stopped at any moment leaves
readable files with every completed step.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import h5py
import numpy as np

from app.output.append import AppendableDocument
from app.output.links import Column, SharedArrays, column_dataset

_NUM = {np.dtype("float64"): ("Float", 8), np.dtype("int64"): ("Int", 8),
        np.dtype("int32"): ("Int", 4)}


def atomic_write_text(path: Path, text: str) -> None:
    """Write a text file through a temporary file and a rename (never half-written)."""
    atomic_write_bytes(path, text.encode())


def atomic_write_bytes(path: Path, data) -> None:
    """Write bytes through a temporary file and a rename; on an OSError (a full disk)
    the temporary file is removed and the error raised."""
    tmp = path.with_name(path.name + ".tmp")
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
    except OSError:
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, path)


def write_h5(path: Path, datasets: dict[str, object], attrs: dict | None = None) -> None:
    """An HDF5 file built in memory, then written with `atomic_write_bytes`: HDF5 never
    writes to the disk itself, so a full disk is one OSError and no half-written file.
    datasets: path inside the file ("a" or "group/a") -> array, `h5py.ExternalLink`, or
    `links.Column` (a virtual dataset on a column of another dataset of the file)."""
    buf = io.BytesIO()
    with h5py.File(buf, "w") as h5:
        for k, v in (attrs or {}).items():
            h5.attrs[k] = v
        for k, v in datasets.items():
            if not isinstance(v, Column):
                h5[k] = v if isinstance(v, h5py.ExternalLink) else np.ascontiguousarray(v)
        for k, v in datasets.items():
            if isinstance(v, Column):
                column_dataset(h5, k, v)
    atomic_write_bytes(path, buf.getbuffer())


def _item(fname: str, path: str, arr_shape: tuple, dtype: np.dtype,
          where: dict[str, tuple[str, str]] | None = None) -> str:
    """An HDF DataItem of `fname:path`, or of the one copy that `where` (dataset name
    without the leading "/" -> (file, path)) names for a linked dataset."""
    fname, path = (where or {}).get(path.lstrip("/"), (fname, path))
    kind, prec = _NUM[np.dtype(dtype)]
    dims = " ".join(str(d) for d in arr_shape)
    return (f'<DataItem Dimensions="{dims}" NumberType="{kind}" Precision="{prec}" '
            f'Format="HDF">{fname}:{path}</DataItem>')


def _attribute(name: str, center: str, fname: str, path: str, arr: np.ndarray,
               where: dict[str, tuple[str, str]] | None = None) -> str:
    kind = "Scalar" if arr.ndim == 1 else ("Vector" if arr.shape[1] == 3 else "Matrix")
    return (f'<Attribute Name="{name}" AttributeType="{kind}" Center="{center}">'
            f'{_item(fname, path, arr.shape, arr.dtype, where)}</Attribute>')


COMPONENTS = {"stress": ("s_xx", "s_yy", "s_xy", "s_zz")}
"""Cell arrays also written as one named scalar per component (for ParaView); in the
step file each is an HDF5 virtual dataset on its column of the array (`links.Column`)."""


def _column(source: str, index: int):
    """data, value -> the `Column` of `source` (when it is an (n, k) array), else value."""
    def make(data: dict, value):
        src = data.get(source)
        if isinstance(src, np.ndarray) and src.ndim == 2 and src.shape[1] > index:
            return Column(source, index, src.shape, src.dtype)
        return value
    return make


_COLUMNS = {c: _column(name, i) for name, comps in COMPONENTS.items()
            for i, c in enumerate(comps)}
VECTORS_3D = ("normal", "tangent")
"""Contact (m, 2) arrays exposed in contact.xdmf as 3-component vectors (z = 0), stored
as /contact/<name>_3d, so that ParaView's Glyph filter can orient them."""


def paraview_extras(point_data: dict, cell_data: dict, contact: dict | None
                    ) -> tuple[dict, dict, dict]:
    """Derived arrays for ParaView: named stress components; the contact points' slave
    displacement (m, 3) so that contact.xdmf warps with the mesh; 3-component normal and
    tangent. Returns (cell_data additions, contact additions, contact XDMF renames)."""
    cells = {}
    for name, comps in COMPONENTS.items():
        arr = cell_data.get(name)
        if arr is not None and arr.ndim == 2 and arr.shape[1] == len(comps):
            cells |= {c: arr[:, i] for i, c in enumerate(comps)}
    extra, renames = {}, {}
    if contact is not None:
        disp = point_data.get("displacement")
        if disp is not None and "slave" in contact and "displacement" not in contact:
            extra["displacement"] = np.asarray(disp)[np.asarray(contact["slave"])]
        for name in VECTORS_3D:
            v = contact.get(name)
            if v is not None and v.ndim == 2 and v.shape[1] == 2:
                v3 = np.zeros((v.shape[0], 3))
                v3[:, :2] = v
                extra[f"{name}_3d"] = v3
                renames[f"{name}_3d"] = name
    return cells, extra, renames


def _information(load_factors: dict[str, float] | None) -> str:
    """The step's load factors as XDMF Information elements (ParaView: field data)."""
    from xml.sax.saxutils import quoteattr

    return "".join(f"<Information Name={quoteattr('load_factor ' + k)} "
                   f"Value=\"{v:.17g}\"/>" for k, v in (load_factors or {}).items())


class ResultWriter:
    """Writes the mesh once and one HDF5 file per step; keeps the XDMF index current."""

    def __init__(self, out_dir: Path, points: np.ndarray, quads: np.ndarray, body: np.ndarray):
        self.out = Path(out_dir)
        self.out.mkdir(parents=True, exist_ok=True)
        self.points = np.ascontiguousarray(points, dtype=np.float64)
        self.quads = np.ascontiguousarray(quads, dtype=np.int64)
        body = np.asarray(body, dtype=np.int64)
        write_h5(self.out / "mesh.h5", {"points": self.points, "quads": self.quads,
                                        "body": body})
        self.shared = SharedArrays()  # the steps' /body_id links to mesh.h5's /body
        self.shared.seed("body_id", "mesh.h5", "/body", body)
        self.bulk_grids: list[str] = []
        self.contact_grids: list[str] = []
        self.bulk_doc = AppendableDocument(self.out / "results.xdmf")
        self.contact_doc = AppendableDocument(self.out / "contact.xdmf")

    def write_step(self, step: int, time: float, point_data: dict[str, np.ndarray],
                   cell_data: dict[str, np.ndarray],
                   contact: dict[str, np.ndarray] | None = None,
                   load_factors: dict[str, float] | None = None) -> Path:
        """Write one completed step and refresh the XDMF index files.

        time: the XDMF time value (the run uses the step number).
        point_data / cell_data: name -> (n,) or (n, k) arrays on nodes / elements.
        contact: name -> (m,) or (m, k) arrays per contact pair; must hold "position" (m, 2).
        load_factors: load case name -> factor at this step (/load_factor in the HDF5 file,
        with the names in its attribute "names"; Information elements in the XDMF).
        """
        fname = f"step_{step:04d}.h5"
        more_cells, more_contact, renames = paraview_extras(point_data, cell_data, contact)
        cell_data = {**cell_data, **more_cells}
        if contact is not None:
            contact = {**contact, **more_contact}
        data, attrs = _step_datasets(step, time, point_data, cell_data, contact, load_factors)
        data = {k: _COLUMNS.get(k, lambda d, v: v)(data, v) for k, v in data.items()}
        linked, where = self.shared.split(data)
        write_h5(self.out / fname, linked, attrs)
        self.shared.written(fname, step, {k: v for k, v in data.items() if k not in where})
        self.bulk_grids.append(self._bulk_grid(fname, step, time, point_data, cell_data,
                                               load_factors, where))
        _extend(self.bulk_doc, self.bulk_grids)
        if contact is not None and "position" in contact:
            self.contact_grids.append(_contact_grid(fname, step, time, contact, renames,
                                                    load_factors, where))
            _extend(self.contact_doc, self.contact_grids)
        return self.out / fname

    def _bulk_grid(self, fname: str, step: int, time: float, point_data: dict[str, np.ndarray],
                   cell_data: dict[str, np.ndarray],
                   load_factors: dict[str, float] | None,
                   where: dict[str, tuple[str, str]] | None = None) -> str:
        """The results.xdmf Grid of one step: the mesh of mesh.h5 and the node and cell
        arrays of the step file `fname` (of their one copy for those `where` names)."""
        attrs = [_attribute(k, "Node", fname, f"/{k}", np.asarray(v), where)
                 for k, v in point_data.items()]
        attrs += [_attribute(k, "Cell", fname, f"/{k}", np.asarray(v), where)
                  for k, v in cell_data.items()]
        geo = _item("mesh.h5", "/points", self.points.shape, self.points.dtype)
        topo = _item("mesh.h5", "/quads", self.quads.shape, self.quads.dtype)
        return (
            f'<Grid Name="step_{step}" GridType="Uniform">'
            f'<Time Value="{time:.17g}"/>{_information(load_factors)}'
            f'<Topology TopologyType="Quadrilateral" NumberOfElements="{self.quads.shape[0]}">'
            f"{topo}</Topology>"
            f'<Geometry GeometryType="XY">{geo}</Geometry>' + "".join(attrs) + "</Grid>"
        )


def _step_datasets(step: int, time: float, point_data: dict[str, np.ndarray],
                   cell_data: dict[str, np.ndarray], contact: dict[str, np.ndarray] | None,
                   load_factors: dict[str, float] | None) -> tuple[dict, dict]:
    """(datasets, attributes) of a step's HDF5 file: the node and cell arrays, the load
    factors (/load_factor, names in the attribute "load_factor_names"), and the contact
    arrays under /contact with /contact/vertices 0..m-1 for the Polyvertex topology."""
    data = {**point_data, **cell_data}
    if load_factors:
        data["load_factor"] = np.array(list(load_factors.values()), dtype=np.float64)
    if contact is not None:
        data |= {f"contact/{k}": v for k, v in contact.items()}
        if "position" in contact:
            data["contact/vertices"] = np.arange(len(contact["position"]), dtype=np.int64)
    attrs = {"step": step, "time": time}
    if load_factors:
        attrs["load_factor_names"] = list(load_factors)
    return data, attrs


def _contact_grid(fname: str, step: int, time: float, contact: dict[str, np.ndarray],
                  renames: dict[str, str], load_factors: dict[str, float] | None,
                  where: dict[str, tuple[str, str]] | None = None) -> str:
    """The contact.xdmf Grid of one step: the pairs of the step file `fname` as points
    (contact["position"] (m, 2)), the other contact arrays as node attributes; a key of
    `renames` (e.g. "normal_3d") shows under its value ("normal"), which it replaces.
    where: linked datasets -> (file, path) of their one copy."""
    pos = np.asarray(contact["position"], dtype=np.float64)
    m = pos.shape[0]
    hidden = {"position", *renames.values()}
    cattrs = [_attribute(renames.get(k, k), "Node", fname, f"/contact/{k}", np.asarray(v),
                         where)
              for k, v in contact.items() if k not in hidden]
    verts = _item(fname, "/contact/vertices", (m,), np.dtype("int64"), where)
    return (
        f'<Grid Name="contact_{step}" GridType="Uniform">'
        f'<Time Value="{time:.17g}"/>{_information(load_factors)}'
        f'<Topology TopologyType="Polyvertex" NumberOfElements="{m}" '
        f'NodesPerElement="1">{verts}</Topology>'
        f'<Geometry GeometryType="XY">'
        f"{_item(fname, '/contact/position', pos.shape, pos.dtype, where)}</Geometry>"
        + "".join(cattrs) + "</Grid>"
    )


def restore_steps(writer: ResultWriter, n_steps: int) -> None:
    """After a failed write (a full disk can cut an in-place append short): step files
    after `n_steps` (the steps summary.json lists) removed, and the XDMF indexes rewritten
    whole with the first n_steps steps."""
    import re

    for p in writer.out.glob("step_*.h5"):
        m = re.fullmatch(r"step_(\d+)\.h5", p.name)
        if m and int(m.group(1)) > n_steps:
            p.unlink(missing_ok=True)
    writer.shared.forget_after(n_steps)
    writer.bulk_grids = writer.bulk_grids[:n_steps]
    writer.contact_grids = writer.contact_grids[:n_steps]
    for doc, grids in ((writer.bulk_doc, writer.bulk_grids),
                       (writer.contact_doc, writer.contact_grids)):
        if grids:
            doc.rewrite(_HEAD, grids, _TAIL)
        elif doc.path.exists():
            doc.path.unlink()


_HEAD = ('<?xml version="1.0"?>\n<Xdmf Version="3.0" '
         'xmlns:xi="http://www.w3.org/2001/XInclude"><Domain>'
         '<Grid Name="TimeSeries" GridType="Collection" CollectionType="Temporal">\n')
_TAIL = "\n</Grid></Domain></Xdmf>\n"


def _extend(doc: AppendableDocument, grids: list[str]) -> None:
    """Bring the XDMF index up to `grids`, the newest one last: one in-place write when the
    file holds all the others, else a whole atomic rewrite."""
    if doc.current() and doc.n_entries == len(grids) - 1:
        doc.append(grids[-1:], _TAIL)
    else:
        doc.rewrite(_HEAD, grids, _TAIL)
