"""Load vectors and prescribed displacements (global numpy vectors of length 2 * n_nodes).

DOF numbering: 2 * node + component (x = 0, y = 1). Surface loads are tractions in force
per unit length of curve (per unit area of surface when multiplied by the thickness);
body forces are per unit volume. Both are multiplied by the thickness.
"""

from __future__ import annotations

import numpy as np

from app.config import Config, Load, Support, evaluate
from app.discretisation.elements import gauss_gradients, gauss_points, shape_functions
from app.errors import InputError
from app.mesh.model import Mesh, orient_boundary_edges


def _curve(mesh: Mesh, name: str, where: str) -> np.ndarray:
    if name not in mesh.curves:
        raise InputError(
            f"{where}: unknown curve '{name}' (mesh curves: {sorted(mesh.curves)})"
        )
    return mesh.curves[name]


def group_nodes(mesh: Mesh, name: str, where: str) -> np.ndarray:
    """Nodes of a named curve or point group, with a one-line error for an unknown name."""
    if name in mesh.curves:
        return np.unique(mesh.curves[name])
    if name in mesh.point_groups:
        return np.unique(mesh.point_groups[name])
    raise InputError(
        f"{where}: unknown group '{name}' (curves: {sorted(mesh.curves)}, "
        f"points: {sorted(mesh.point_groups)})"
    )


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
    where = f"load on '{load.on}'"
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


def support_dofs(mesh: Mesh, support: Support,
                 params: dict[str, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """DOFs a support prescribes and their values at factor 1."""
    where = f"support on '{support.on}'"
    nodes = group_nodes(mesh, support.on, where)
    x, y = mesh.points[nodes, 0], mesh.points[nodes, 1]
    dofs, vals = [], []
    for comp, v in support.values.items():
        dofs.append(2 * nodes + comp)
        vals.append(evaluate(v, x, y, params or {}, where))
    return np.concatenate(dofs), np.concatenate(vals)


def constrained_dofs(mesh: Mesh, cfg: Config) -> np.ndarray:
    """Sorted unique DOFs prescribed by any support."""
    if not cfg.supports:
        return np.zeros(0, dtype=np.int64)
    return np.unique(np.concatenate([support_dofs(mesh, s, cfg.parameters)[0]
                                     for s in cfg.supports]))


def rigid_modes(points: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Rigid-body modes (tx, ty, rotation about the nodes' centroid), shape (2*len, 3)."""
    xc = points[nodes] - points[nodes].mean(axis=0)
    r = np.zeros((2 * nodes.size, 3))
    r[0::2, 0] = 1.0
    r[1::2, 1] = 1.0
    r[0::2, 2] = -xc[:, 1]
    r[1::2, 2] = xc[:, 0]
    return r


MODE_NAMES = ("translation x", "translation y", "rotation")


def free_rigid_modes(mesh: Mesh, fixed: np.ndarray) -> dict[int, np.ndarray]:
    """Rigid-body modes the supports leave free, per body.

    Returns body index -> (3, r) coefficients of the free combinations of
    (tx, ty, rotation about the body centroid), for bodies with r > 0 free modes.
    """
    node_body = mesh.node_body()
    is_fixed = np.zeros(2 * mesh.n_nodes, dtype=bool)
    is_fixed[fixed] = True
    out = {}
    for b in range(len(mesh.body_names)):
        nodes = np.flatnonzero(node_body == b)
        if nodes.size == 0:
            continue
        r = rigid_modes(mesh.points, nodes)
        dofs = np.stack([2 * nodes, 2 * nodes + 1], axis=1).ravel()
        a = r[is_fixed[dofs]]
        ext = np.ptp(mesh.points[nodes], axis=0).max()
        a = a * np.array([1.0, 1.0, 1.0 / ext])
        if a.shape[0] == 0:
            out[b] = np.eye(3)
            continue
        _, s, vt = np.linalg.svd(a, full_matrices=True)
        rank = int(np.sum(s > 1e-10 * max(s[0], 1.0)))
        if rank < 3:
            out[b] = (vt[rank:].T / np.array([1.0, 1.0, ext])[:, None])
    return out


def describe_modes(modes: np.ndarray, centroid: np.ndarray | None = None) -> str:
    """Words for free rigid modes (3, r), e.g. 'translation y, rotation about (0, 1)'."""
    return ", ".join(mode_names(modes, centroid))


def mode_names(modes: np.ndarray, centroid: np.ndarray | None = None) -> list[str]:
    """One name per free rigid mode; modes are coefficients of (tx, ty, rotation about
    `centroid`), shape (3, r)."""
    if modes.shape[1] == 3:
        return ["translation x", "translation y", "rotation"]
    names = []
    for k in range(modes.shape[1]):
        tx, ty, th = modes[:, k] / np.abs(modes[:, k]).max()
        if abs(th) > 1e-6 and centroid is not None:
            x0, y0 = centroid[0] - ty / th, centroid[1] + tx / th
            names.append(f"rotation about (x={x0:.4g}, y={y0:.4g})")
        else:
            v = np.abs([tx, ty, th])
            names.append(" + ".join(MODE_NAMES[i] for i in range(3) if v[i] > 1e-6))
    return names
