"""Load vectors and prescribed displacements (global numpy vectors of length 2 * n_nodes).

DOF numbering: 2 * node + component (x = 0, y = 1). Surface loads are tractions in force
per unit length of curve (per unit area of surface when multiplied by the thickness);
body forces are per unit volume. Both are multiplied by the thickness.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from app.assembly.shared_supports import first_support_values
from app.config import Config, Load, Support, evaluate
from app.discretisation.elements import gauss_gradients, gauss_points, shape_functions
from app.errors import InputError
from app.mesh.model import Mesh, orient_boundary_edges
from app.scene.parse import listed


def _curve(mesh: Mesh, name: str, where: str) -> np.ndarray:
    """The edges (k, 2) of a named curve; a point group or an unknown name is a one-line
    error (a point group read `unknown curve 'tip'` before, though [points] named it)."""
    if name in mesh.point_groups and name not in mesh.curves:
        raise InputError(
            f"{where}: '{name}' is a point group, and a [[load]] acts on a curve (traction, "
            f"pressure or total_force over its length): name a curve ({_names(mesh.curves)}),"
            " or prescribe the point's displacement with a [[support]]")
    if name not in mesh.curves:
        raise InputError(
            f"{where}: unknown curve {name!r} (mesh curves: {_names(mesh.curves)})"
        )
    return mesh.curves[name]


def _names(groups) -> str:
    """The sorted names of `groups`, quoted, as a list cut as `listed` cuts it (before, all:
    10,000 curves of 5000 bodies made a 111 kB error line)."""
    return f"[{listed([repr(n) for n in sorted(groups)])}]"


def group_nodes(mesh: Mesh, name: str, where: str) -> np.ndarray:
    """Nodes of a named curve or point group, with a one-line error for an unknown name."""
    if name in mesh.curves:
        return np.unique(mesh.curves[name])
    if name in mesh.point_groups:
        return np.unique(mesh.point_groups[name])
    raise InputError(
        f"{where}: unknown group {name!r} (curves: {_names(mesh.curves)}, "
        f"points: {_names(mesh.point_groups)})"
    )


def check_groups_before_meshing(cfg: Config) -> None:
    """The supports' and loads' groups against the scene's own names ([body.curves] and
    [points]), with the errors `group_nodes` and `_curve` give after meshing: a misspelled
    name is found before gmsh runs (5000 bodies: 47 s of meshing and set-up before). A
    mesh.file's groups are known only once it is read: checked then."""
    scene = cfg.scene
    if scene.file is not None:
        return
    curves = {s.curve for b in scene.bodies for s in b.sides if s.curve is not None}
    names = SimpleNamespace(curves=dict.fromkeys(curves, np.zeros((0, 2), dtype=np.int64)),
                            point_groups=dict.fromkeys(scene.points,
                                                       np.zeros(0, dtype=np.int64)))
    for support in cfg.supports:
        group_nodes(names, support.on, f"support on {support.on!r}")
    for load in cfg.loads:
        _curve(names, load.on, f"load on {load.on!r}")


def traction_vector(mesh: Mesh, edges: np.ndarray, traction) -> np.ndarray:
    """Consistent nodal forces of a traction on edges (k, 2), by 2-point Gauss per edge.

    traction: a function (x (k,), y (k,)) -> (k, 2) traction at points of the edges.
    """
    f = np.zeros(2 * mesh.n_nodes)
    xa, xb = mesh.points[edges[:, 0]], mesh.points[edges[:, 1]]
    length = np.linalg.norm(xb - xa, axis=1)
    for s in (0.5 - 0.5 / np.sqrt(3.0), 0.5 + 0.5 / np.sqrt(3.0)):
        xg = (1.0 - s) * xa + s * xb
        t = traction(xg[:, 0], xg[:, 1])
        for k, n in ((0, 1.0 - s), (1, s)):
            for comp in range(2):
                np.add.at(f, 2 * edges[:, k] + comp, 0.5 * length * n * t[:, comp])
    return f


def load_vector(mesh: Mesh, cfg: Config, load: Load) -> np.ndarray:
    """Nodal force vector of one load at factor 1 (including the thickness)."""
    where = f"load on {load.on!r}"
    edges = orient_boundary_edges(mesh, _curve(mesh, load.on, where), where)
    d = mesh.points[edges[:, 1]] - mesh.points[edges[:, 0]]
    length = np.linalg.norm(d, axis=1)
    if load.kind == "traction":
        def t(x, y):
            return np.stack([evaluate(v, x, y, cfg.parameters, f"{where}: traction")
                             for v in load.value], axis=1)
    elif load.kind == "total_force":
        def t(x, y):
            return np.broadcast_to(np.array(load.value) / length.sum(), (x.size, 2))
    else:  # pressure pushes against the outward normal
        normal = np.stack([d[:, 1], -d[:, 0]], axis=1) / length[:, None]

        def t(x, y):
            return -load.value[0] * normal
    return cfg.thickness * traction_vector(mesh, edges, t)


def body_force_vector(mesh: Mesh, cfg: Config) -> np.ndarray:
    """Nodal forces of the bodies' body forces (2x2 Gauss, exact on any Q4)."""
    f = np.zeros(2 * mesh.n_nodes)
    bf = cfg.body_force[mesh.body]  # (ne, 2)
    if not np.any(bf):
        return f
    xe = mesh.points[mesh.quads]
    for xi, eta in gauss_points():
        _, _, det = gauss_gradients(xe, xi, eta)
        n = shape_functions(xi, eta)  # (4,)
        w = cfg.thickness * det[:, None] * n[None, :]  # (ne, 4)
        for comp in range(2):
            np.add.at(f, 2 * mesh.quads + comp, w * bf[:, comp : comp + 1])
    return f


def support_dofs(mesh: Mesh, support: Support, params: dict[str, float] | None = None,
                 size: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """DOFs a support prescribes and their values at factor 1; `size` is
    `scene_size(mesh)` when the caller has it (see `all_support_dofs`)."""
    where = f"support on {support.on!r}"
    nodes = group_nodes(mesh, support.on, where)
    size = scene_size(mesh) if size is None else size
    # coordinates within round-off of an axis are on it (a node gmsh put at y = 1e-17 on
    # y = 0 made `y**-1` 1e17 there, finite, and the run completed with U = 1.6e26)
    xy = np.where(np.abs(mesh.points[nodes]) <= ROUND_OFF * size, 0.0, mesh.points[nodes])
    dofs, vals = [], []
    for comp, v in support.values.items():
        dofs.append(2 * nodes + comp)
        vals.append(_support_values(v, nodes, xy, support, "xy"[comp], size, params or {}))
    return np.concatenate(dofs), np.concatenate(vals)


def all_support_dofs(mesh: Mesh, supports: list[Support],
                     params: dict[str, float] | None = None
                     ) -> list[tuple[np.ndarray, np.ndarray]]:
    """`support_dofs` of every support, the scene's size computed once: per support it
    cost O(nodes) each, 22 s of set-up per pass at 5000 one-element bodies with a
    support each."""
    size = scene_size(mesh)
    return [support_dofs(mesh, s, params, size) for s in supports]


ROUND_OFF = 1e-12
"""Coordinates within this fraction of the scene's size of zero are zero for expressions."""
MAX_PRESCRIBED = 10.0
"""Largest prescribed displacement from an expression, in scene sizes, over the steps."""


def scene_size(mesh: Mesh) -> float:
    """The diagonal of the mesh's bounding box (length units)."""
    return float(np.hypot(*np.ptp(mesh.points[:, :2], axis=0))) if mesh.n_nodes else 1.0


def _support_values(value: float | str, nodes: np.ndarray, xy: np.ndarray,
                    support: Support, comp: str, size: float,
                    params: dict[str, float]) -> np.ndarray:
    """The u<comp> values at the support's nodes (factor 1). An expression that is not
    finite at a node, or whose largest value over the steps exceeds MAX_PRESCRIBED scene
    sizes (singular near a node: `1/y` at y = 1e-9), is an InputError naming the support,
    the node and its value; a number is the user's own and is taken as written."""
    where = f"support on {support.on!r}, u{comp}"
    try:
        vals = evaluate(value, xy[:, 0], xy[:, 1], params, where)
    except InputError as exc:
        bad = next((i for i in range(len(nodes)) if not _finite_at(value, xy[i], params)),
                   None)
        if bad is None:
            raise
        raise InputError(f"{exc} (first at node {nodes[bad]}, x = {xy[bad, 0]:.6g}, "
                         f"y = {xy[bad, 1]:.6g})") from None
    if not isinstance(value, str) or not len(vals):
        return vals
    peak = np.abs(vals) * float(np.max(np.abs(support.history), initial=0.0))
    i = int(np.argmax(peak))
    if peak[i] > MAX_PRESCRIBED * size:
        raise InputError(
            f"{where}: expression {value!r} prescribes {vals[i]:.3g} at node {nodes[i]} "
            f"(x = {xy[i, 0]:.6g}, y = {xy[i, 1]:.6g}), more than {MAX_PRESCRIBED:g} times "
            f"the scene's size {size:.3g}: is it singular near that node? Write it so that "
            "it stays finite on the support's curve")
    return vals


def _finite_at(value: str | float, point: np.ndarray, params: dict[str, float]) -> bool:
    """Whether the expression evaluates (finite) at one point (the error path only)."""
    try:
        evaluate(value, point[:1], point[1:], params, "")
    except InputError:
        return False
    return True


def constrained_dofs(mesh: Mesh, cfg: Config) -> np.ndarray:
    """Sorted unique DOFs prescribed by any support."""
    if not cfg.supports:
        return np.zeros(0, dtype=np.int64)
    return np.unique(np.concatenate([d for d, _ in all_support_dofs(mesh, cfg.supports,
                                                                     cfg.parameters)]))


def unique_names(names: list[str]) -> list[str]:
    """The names, with '#2', '#3' ... appended to the second, third ... repeat of one."""
    seen: dict[str, int] = {}
    out = []
    for n in names:
        seen[n] = seen.get(n, 0) + 1
        out.append(n if seen[n] == 1 else f"{n}#{seen[n]}")
    return out


@dataclass
class LoadCase:
    """One load or support with its history; u is its unit solution K^-1 b."""

    name: str
    history: np.ndarray
    rhs: np.ndarray  # (2n,) forces at factor 1
    prescribed: np.ndarray  # (2n,) prescribed displacement values at factor 1


def load_cases(mesh: Mesh, cfg: Config) -> list[LoadCase]:
    """Every load, body force and non-zero support of the config as a load case."""
    n2 = 2 * mesh.n_nodes
    cases = []
    names = unique_names([f"load:{ld.on}" for ld in cfg.loads]
                         + [f"support:{s.on}" for s in cfg.supports])
    names = dict(zip([id(x) for x in cfg.loads + cfg.supports], names, strict=True))
    for ld in cfg.loads:
        cases.append(LoadCase(names[id(ld)], ld.history, load_vector(mesh, cfg, ld),
                              np.zeros(n2)))
    bf = body_force_vector(mesh, cfg)
    if np.any(bf):
        cases.append(LoadCase("body_force", np.ones(cfg.n_steps), bf, np.zeros(n2)))
    held = all_support_dofs(mesh, cfg.supports, cfg.parameters)
    kept = first_support_values([d for d, _ in held], [v for _, v in held],
                                [s.history for s in cfg.supports],
                                [f"support #{i + 1} ({s.on})"
                                 for i, s in enumerate(cfg.supports)], mesh.points)
    for s, (dofs, _), vals in zip(cfg.supports, held, kept, strict=True):
        if np.any(vals):  # a DOF of two supports counts in the first one's case only
            ud = np.zeros(n2)
            ud[dofs] = vals
            cases.append(LoadCase(names[id(s)], s.history, np.zeros(n2), ud))
    return cases
