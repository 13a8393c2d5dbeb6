"""Size of a scene's mesh and run, estimated from the geometry and element sizes alone.

Used before meshing to refuse, in one line, a run that the machine cannot hold (for
example `--mesh-size 1e-4` on a 2 x 2 scene: about 10^9 elements). An unstructured body
of area A and element size h has about A / h^2 quadrilaterals; a `[[mesh.refine]]` entry
(size s, constant within `flat` f, growing linearly to h over `distance` D) adds about
L (f / s^2 + D / (s h)) near curves of total length L and pi f^2 / s^2 +
2 pi D^2 / (h - s)^2 (ln(h / s) + s / h - 1) near each point (the integral of 1 / size^2
over the zone), capped at A / s^2; a `[[mesh.patch]]` of size s adds the box's overlap
with the body's bounding box times 1 / s^2 (an upper bound: the elements the patch
replaces are not taken off). A structured rectangle has exactly nx ny elements.
Nodes are about the elements, and DOFs twice that. The memory figure is the measured
peak of MUMPS LU runs here (about 4 kB per DOF, see README).
"""

from __future__ import annotations

import math
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.errors import InputError
from app.scene import BodySpec, Refine, Scene

BYTES_PER_DOF = 4000.0
"""Peak memory per DOF of a run with MUMPS LU (the Hertz scene at 1.12 M DOFs needed
4.1 GB through the factorization and 6.7 GB with 751 contact pairs)."""


@dataclass
class SizeEstimate:
    """Estimated elements, DOFs and peak memory (bytes) of a run."""

    elements: float
    dofs: float
    memory: float

    def text(self) -> str:
        """The estimate in words (elements, DOFs, memory in GB) for a message."""
        if not math.isfinite(self.memory):
            return "an unbounded number of elements (the element sizes underflow)"
        return (f"about {self.elements:.2g} elements, {self.dofs:.2g} DOFs and "
                f"{self.memory / 1e9:.3g} GB")


def machine_memory() -> float:
    """Physical memory of this machine in bytes (inf if unknown)."""
    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return math.inf


def body_area(spec: BodySpec) -> float:
    """Area of a body shape (config units squared)."""
    s = spec.shape
    if s["type"] == "rectangle":
        return float(s["width"] * s["height"])
    if s["type"] == "disk":
        return math.pi * s["radius"] ** 2
    if s["type"] == "half_disk":
        return 0.5 * math.pi * s["radius"] ** 2
    p = np.asarray(s["points"], float)
    return 0.5 * abs(float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1)
                                  * p[:, 1])))


def _bbox(spec: BodySpec) -> tuple[np.ndarray, np.ndarray]:
    pts = np.array([q for side in spec.sides for pc in side.pieces for q in (pc.p0, pc.p1)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    for side in spec.sides:  # arcs bulge beyond their end points
        for pc in side.pieces:
            if pc.kind == "arc":
                lo = np.minimum(lo, pc.center - pc.radius)
                hi = np.maximum(hi, pc.center + pc.radius)
    return lo, hi


def _refined(spec: BodySpec, r: Refine, bodies: list[BodySpec], h: float, scale: float,
             area: float) -> float:
    """Extra elements of one refinement entry in one unstructured body."""
    s = r.size * scale
    if s >= h:
        return 0.0
    reach = r.flat + r.distance
    lo, hi = _bbox(spec)
    lo, hi = lo - reach, hi + reach
    length = 0.0
    for c in r.curves:
        for other in bodies:
            for pc in other.curve_pieces(c):
                ends = np.array([pc.p0, pc.p1])
                if np.all(ends.max(axis=0) >= lo) and np.all(ends.min(axis=0) <= hi):
                    length += pc.length
    n = length * (r.flat / s**2 + r.distance / (s * h))
    k = (h - s) / max(r.distance, 1e-300)
    for x, y in r.points:
        if lo[0] <= x <= hi[0] and lo[1] <= y <= hi[1]:
            n += math.pi * np.float64(r.flat) ** 2 / s**2  # (a float's ** raises on overflow)
            n += 2 * math.pi / k**2 * (math.log(h / s) + s / h - 1) if r.distance else 0.0
    return min(n, area / s**2)


def estimate(scene: Scene, scale: float = 1.0) -> SizeEstimate | None:
    """Estimated size of the mesh a scene builds at this size scale; None for mesh.file."""
    if scene.file is not None:
        return None
    with np.errstate(all="ignore"):  # a tiny scale gives inf, which is refused
        elements = float(sum(_body_elements(spec, scene, np.float64(scale))
                             for spec in scene.bodies))
    if not math.isfinite(elements):  # inf, or nan from inf - inf
        elements = math.inf
    dofs = 2.0 * elements
    return SizeEstimate(elements, dofs, BYTES_PER_DOF * dofs)


def _body_elements(spec: BodySpec, scene, scale: np.float64) -> float:
    """Estimated elements of one body (inf when the sizes underflow)."""
    h = spec.size * scale
    if not h > 0:
        return math.inf
    if spec.structured:
        if "divisions" in spec.shape:
            nx, ny = (max(1.0, k / scale) for k in spec.shape["divisions"])
        else:
            nx = max(1.0, spec.shape["width"] / h)
            ny = max(1.0, spec.shape["height"] / h)
        return nx * ny
    area = body_area(spec)
    if any(not r.size * scale > 0 for r in scene.refine + scene.patches):
        return math.inf
    return (area / h**2 + sum(_refined(spec, r, scene.bodies, h, scale, area)
                              for r in scene.refine)
            + sum(_patched(spec, p, scale) for p in scene.patches))


def _patched(spec: BodySpec, patch, scale: np.float64) -> float:
    """Elements of one [[mesh.patch]] in one unstructured body: the overlap of its box
    with the body's bounding box over size^2 (an upper bound; inf when the size
    underflows). Before, patches were not counted: `size = 1e-5` passed the check and
    gmsh meshed until the memory ran out."""
    lo, hi = _bbox(spec)
    w = min(hi[0], patch.box[2]) - max(lo[0], patch.box[0])
    d = min(hi[1], patch.box[3]) - max(lo[1], patch.box[1])
    if w <= 0 or d <= 0:
        return 0.0
    s = patch.size * scale
    return w * d / s**2 if s > 0 else math.inf


def file_estimate(path: str | Path, times: int) -> SizeEstimate:
    """Size of the mesh of a .msh file after `times` uniform splits: 4^times its quads,
    and two DOFs per node, nodes also about 4^times as many."""
    from app.mesh.read import _load_msh

    m = _load_msh(Path(path))
    elements = float(sum(len(b.data) for b in m.cells if b.type == "quad")) * 4.0**times
    dofs = 2.0 * len(m.points) * 4.0**times
    return SizeEstimate(elements, dofs, BYTES_PER_DOF * dofs)


def check_size(scene: Scene, scale: float = 1.0, *, allow_large: bool = False,
               option: str = "--allow-large", base_dir: str | Path | None = None,
               refine: int = 0) -> SizeEstimate | None:
    """Refuse (InputError, one line) a run whose estimated memory exceeds this machine's.

    A mesh.file (relative to base_dir) is read and its nodes counted (the build reads it
    again): before, `--refine 8` on a read mesh went on to 65536 times its elements, and
    an unsplit file had no estimate, so no disk check."""
    est = estimate(scene, scale)
    if scene.file is not None:
        path = Path(scene.file)
        est = file_estimate(path if base_dir is None or path.is_absolute()
                            else Path(base_dir) / path, refine)
    available = machine_memory()
    if est is not None and not allow_large and est.memory > available:
        fix = "fewer splits" if scene.file is not None else "a larger --mesh-size or mesh.size"
        raise InputError(f"the run would need {est.text()}, more than this machine's "
                         f"{available / 1e9:.3g} GB of memory: use {fix}, or {option} to run "
                         "anyway")
    return est


STEP_FILE_BYTES = 43e3
STEP_BYTES_PER_DOF = 50.0
"""Disk bytes of one step, about STEP_FILE_BYTES + STEP_BYTES_PER_DOF per estimated DOF:
the step file (about 30 kB of HDF5 structure plus the fields) and the growth of the
XDMF files and summary.json (about 13 kB per step), calibrated on `du -sb OUT` of runs of
patch, hertz, multibody and cattaneo (README "Input checks"). The mesh file counts as one
more step. Contact datasets scale with the contact nodes, fewer than the DOFs: they are
in the per-DOF figure (the estimate has no pair count before meshing). A step whose
fields do not change is written as a small file (8.3 kB on cantilever.toml): such runs
are overstated, as the check does not see the loads."""


def check_disk(est: SizeEstimate | None, n_steps: int, folder: str | Path, *,
               allow_large: bool = False, option: str = "--allow-large",
               runs: list[float] | None = None) -> None:
    """Refuse (InputError, one line) a run whose step files would not fit on the disk of
    `folder` (or of its nearest existing parent). Before, only memory was estimated:
    `analysis.steps = 100000` (the largest allowed) on a mesh that fits in memory went on
    writing step files until the disk was full. `runs`: a study's runs, each as its DOFs
    over `est`'s (a convergence study's level l of L: 4^(l - L)); before, a study counted
    its finest run only."""
    if est is None or allow_large:
        return
    runs = [1.0] if runs is None else runs
    need = (n_steps + 1) * sum(STEP_FILE_BYTES + STEP_BYTES_PER_DOF * est.dofs * r for r in runs)
    path = Path(folder).absolute()
    try:
        while not path.exists() and path != path.parent:
            path = path.parent
        free = float(shutil.disk_usage(path).free)
    except OSError:  # a name too long, no access: the --out check names it
        return
    if need > free:
        whose = "the run's" if len(runs) == 1 else f"the study's {len(runs)} runs'"
        each = "each" if max(runs) == min(runs) else "each at the finest level"
        raise InputError(f"{whose} {n_steps} step files would need about {need / 1e9:.3g} "
                         f"GB ({est.dofs:.2g} DOFs {each}), more than the {free / 1e9:.3g} GB "
                         f"free on the disk of {folder}: use fewer analysis.steps or a larger "
                         f"--mesh-size, or {option} to run anyway")


def check_resolution(scene: Scene, scale: float = 1.0, option: str = "--mesh-size",
                     given: float | None = None) -> None:
    """Refuse (InputError, one line) a size scale at which no element size of the scene
    (a body's own, a `[[mesh.refine]]`'s, a `[[mesh.patch]]`'s, all times `scale`) is
    as small as the radius of a body's arc: gmsh then draws the arc as a polygon of one
    segment per quarter circle at most. `scale` includes the splits of `--refine` or a
    study's finest level (2^-splits: they put their new nodes on the arcs). Before,
    `--mesh-size 1e300` on hertz.toml ran a 7-element mesh (2 contact pairs, p_max 90%
    off Hertz, a contact width of 0) and completed without a word. `given`: the
    option's value, for the message."""
    if scene.file is not None:
        return
    zone_sizes = [r.size for r in scene.refine] + [p.size for p in scene.patches]
    for spec in scene.bodies:
        radii = [pc.radius for side in spec.sides for pc in side.pieces if pc.kind == "arc"]
        if spec.structured or not radii:
            continue
        smallest = min([spec.size, *zone_sizes])
        radius = min(radii)
        if smallest * scale > radius:
            what = f"{option} {given:g}" if given is not None else f"a size scale of {scale:g}"
            largest = (given if given is not None else scale) * radius / (smallest * scale)
            raise InputError(
                f"{what} leaves body '{spec.name}' unresolved: its smallest element size "
                f"would be {smallest * scale:.3g}, more than its arc's radius {radius:g}, so "
                f"the arc would be a polygon of a few sides; use {option} at most "
                f"{largest:.3g}")


def one_element_bodies(scene: Scene, scale: float = 1.0) -> list[str]:
    """Warnings for unstructured bodies whose element sizes (their own and every
    refinement zone's, times `scale`) all exceed their own extent (the larger side of
    their bounding box): gmsh meshes them with the fewest elements it makes (a few), and
    any larger size gives the same mesh of them. The geometry is exact (no arc: see
    check_resolution), and a coarse mesh may be meant, so a warning, not an error."""
    out = []
    zone_sizes = [r.size for r in scene.refine] + [p.size for p in scene.patches]
    for spec in scene.bodies:
        lo, hi = _bbox(spec)
        extent = float(np.max(hi - lo))
        smallest = min([spec.size, *zone_sizes]) * scale
        if not spec.structured and smallest > extent:
            out.append(f"body '{spec.name}': its smallest element size {smallest:.3g} is "
                       f"larger than the body ({extent:g} across): gmsh meshes it with the "
                       "fewest elements it makes, the same mesh at any larger size")
    return out
