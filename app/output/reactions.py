"""Support reactions, the global force balance and interface resultants, per load step.

Sign conventions (2D, global axes x, y; moments about +z, counter-clockwise positive):
- every body satisfies K u = f + c + r, with f the applied nodal forces (loads and body
  forces), c = G^T lambda the contact forces and r the support reactions (non-zero on
  prescribed DOFs only). So r = (K u - f - c) on the prescribed DOFs, with K the
  stiffness before the Dirichlet elimination.
- a support's reaction is the force the support exerts on the body: (Fx, Fy) and its
  moment `Mz` about the origin (0, 0) and `Mz_centroid` about the centroid of the
  support's nodes (undeformed coordinates, small displacements).
- a prescribed DOF shared by two supports is counted in the first one (config order).
- the balance of a body: sum of (f + c + r) over its nodes = 0, force and moment about
  the origin; reported relative to the largest of the summed terms.
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from app.parallel import to_numpy_all

_BALANCE_FLOOR = 1e-300
BALANCE_FLOOR_FRACTION = 1e-6
"""The balance's force scale is at least this times max diag(K) times max |u|."""


def moment_z(points: np.ndarray, nodes: np.ndarray, fx: np.ndarray, fy: np.ndarray,
             about: np.ndarray) -> float:
    """Sum of (x - x0) Fy - (y - y0) Fx over the nodes; points (n, 2), fx, fy (k,)."""
    d = points[nodes] - about
    return float(np.sum(d[:, 0] * fy - d[:, 1] * fx))


def support_owner(support_dofs: list[np.ndarray], n_dofs: int) -> np.ndarray:
    """(n_dofs,) index of the first support prescribing each DOF, -1 where none."""
    owner = np.full(n_dofs, -1, dtype=np.int64)
    for i in reversed(range(len(support_dofs))):
        owner[support_dofs[i]] = i
    return owner


def support_reactions(names: list[str], owner: np.ndarray, r: np.ndarray,
                      points: np.ndarray) -> dict[str, dict]:
    """Reaction of each support from the nodal reactions r (2n,) and the DOF owners."""
    out = {}
    for i, name in enumerate(names):
        dofs = np.flatnonzero(owner == i)
        nodes = np.unique(dofs // 2)
        fx = np.zeros(points.shape[0])
        fy = np.zeros(points.shape[0])
        xd, yd = dofs[dofs % 2 == 0], dofs[dofs % 2 == 1]
        fx[xd // 2] = r[xd]
        fy[yd // 2] = r[yd]
        centroid = points[nodes].mean(axis=0) if nodes.size else np.zeros(2)
        out[name] = {
            "Fx": float(fx[nodes].sum()), "Fy": float(fy[nodes].sum()),
            "Mz": moment_z(points, nodes, fx[nodes], fy[nodes], np.zeros(2)),
            "Mz_centroid": moment_z(points, nodes, fx[nodes], fy[nodes], centroid),
            "centroid": [float(c) for c in centroid],
        }
    return out


def body_extents(points: np.ndarray, node_body: np.ndarray, n_bodies: int) -> np.ndarray:
    """(n_bodies,) largest side of each body's bounding box (0 for a body without nodes)."""
    out = np.zeros(n_bodies)
    for b in range(n_bodies):
        p = points[node_body == b]
        if p.size:
            out[b] = float(np.ptp(p, axis=0).max())
    return out


def _body_summer(node_body: np.ndarray, nb: int):
    """A function (3, n) -> (nb, 3) of per-body row sums (nodes of no body skipped):
    contiguous slices when the nodes are numbered body by body (as the mesh builder and
    reader do), else bincount."""
    if node_body.size and np.all(np.diff(node_body) >= 0):
        bounds = np.searchsorted(node_body, np.arange(nb + 1))

        def by_slices(f: np.ndarray) -> np.ndarray:
            return np.array([f[:, bounds[b]:bounds[b + 1]].sum(axis=1) for b in range(nb)]
                            ).reshape(nb, 3)
        return by_slices
    sel = node_body >= 0
    idx = node_body[sel]

    def by_bincount(f: np.ndarray) -> np.ndarray:
        return np.stack([np.bincount(idx, f[k, sel], minlength=nb) for k in range(3)], 1)
    return by_bincount


def body_balance(points: np.ndarray, node_body: np.ndarray, body_names: list[str],
                 terms: dict[str, np.ndarray], extents: np.ndarray | None = None,
                 floor: float | np.ndarray = 0.0) -> dict:
    """Force and moment balance per body of the nodal force vectors in `terms` (2n,) each.

    Returns {"bodies": {name: {term: [Fx, Fy, Mz], ..., "residual": [..]}},
    "max_relative_residual": float}: the residual is the sum of the terms; its moment (about
    the origin) relative to the sums of |nodal moment| (or the force scale times the body's
    size), its force part relative to the larger of the sums of |Fx| and |Fy| over all
    nodal forces of all terms of the body, or `floor` (scalar or per body (nb,)) if larger
    (the run passes the largest force scale of the steps before and each body's stiffness
    x displacement, so that a step where every force is round-off is not judged against
    its own round-off). extents: `body_extents` (computed if None).
    "force_scale": the largest body force scale of this step.
    """
    nb = len(body_names)
    if extents is None:
        extents = body_extents(points, node_body, nb)
    per_body = _body_summer(node_body, nb)
    x, y = np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1])
    total = np.zeros((nb, 3))
    scale = np.zeros((nb, 3))
    per_term = {}
    for name, vec in terms.items():
        f = np.empty((3, points.shape[0]))
        f[0], f[1] = vec[0::2], vec[1::2]
        np.multiply(x, f[1], out=f[2])
        f[2] -= y * f[0]
        res = per_body(f)
        per_term[name] = res
        total += res
        np.abs(f, out=f)
        scale += per_body(f)
    step_scale = float(scale[:, :2].max(initial=0.0))
    f_scale = np.maximum(scale[:, :2].max(axis=1), floor)
    m_scale = np.maximum(scale[:, 2], f_scale * extents)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel_f = np.where(f_scale > _BALANCE_FLOOR, np.abs(total[:, :2]).max(axis=1) / f_scale,
                         0.0)
        rel_m = np.where(m_scale > _BALANCE_FLOOR, np.abs(total[:, 2]) / m_scale, 0.0)
    rel = np.maximum(rel_f, rel_m)
    bodies = {}
    for b, body in enumerate(body_names):
        row = {name: [float(v) for v in res[b]] for name, res in per_term.items()}
        row["residual"] = [float(v) for v in total[b]]
        row["relative_residual"] = float(rel[b])
        bodies[body] = row
    return {"bodies": bodies, "max_relative_residual": float(rel.max(initial=0.0)),
            "force_scale": step_scale}


def interface_resultants(contact: dict[str, np.ndarray], names: list[str],
                         swapped: set[str] | None = None) -> dict:
    """Force on each interface's configured slave side, sum of p n + q t over its pairs,
    global axes.

    The master side carries the opposite force. The interfaces named in `swapped` have
    their pairs on the configured master (`mortar-coarse-slave`), so their sum is the
    master's force and is negated: the figure does not flip with the element-size ratio.
    Returns {name: {"force": [Fx, Fy]}}.
    """
    f = (contact["p_force"][:, None] * contact["normal"]
         + contact["q_force"][:, None] * contact["tangent"])
    out = {}
    for i, name in enumerate(names):
        sel = contact["interface"] == i
        sign = -1.0 if swapped and name in swapped else 1.0
        out[name] = {"force": [float(sign * v) for v in f[sel].sum(axis=0)]}
    return out


class ReactionProbe:
    """The rows of the assembled stiffness at the prescribed DOFs, kept before the
    Dirichlet elimination so that (K u) on those DOFs can be formed at every step."""

    def __init__(self, k: PETSc.Mat, fixed: np.ndarray):
        comm = k.getComm()
        r0, r1 = k.getOwnershipRange()
        self.fixed = np.asarray(fixed, dtype=np.int64)
        own = self.fixed[(self.fixed >= r0) & (self.fixed < r1)].astype(PETSc.IntType)
        rows = PETSc.IS().createGeneral(own, comm=comm)
        cols = PETSc.IS().createStride(r1 - r0, first=r0, step=1, comm=comm)
        self.rows = k.createSubMatrix(rows, cols)
        self.range = (r0, r1)
        diag = k.getDiagonal()
        self.k_diag_max = float(diag.norm(PETSc.NormType.INFINITY))
        self.k_diag = np.abs(to_numpy_all(diag))  # (2n,) on every rank: per-body floors
        diag.destroy()
        rows.destroy()
        cols.destroy()

    def ku(self, u: np.ndarray, to_numpy_all) -> np.ndarray:
        """(2n,) with (K u) on the prescribed DOFs and 0 elsewhere (on every rank)."""
        out = np.zeros(u.size)
        if self.fixed.size == 0:
            return out
        x = self.rows.createVecRight()
        x.setArray(u[self.range[0]:self.range[1]])
        y = self.rows.createVecLeft()
        self.rows.mult(x, y)
        out[self.fixed] = to_numpy_all(y)
        x.destroy()
        y.destroy()
        return out


def _body_max(x: np.ndarray, node_body: np.ndarray, nb: int) -> np.ndarray:
    """(nb,) the largest |x| over each body's DOFs; x (2n,) by node (x, y), node_body (n,)
    (-1: a node of no body, left out). A loop over the bodies, not the nodes."""
    a = np.maximum(np.abs(x[0::2]), np.abs(x[1::2]))
    return np.array([a[node_body == b].max(initial=0.0) for b in range(nb)])


def step_reactions(probe: ReactionProbe, u: np.ndarray, applied: np.ndarray,
                   body_force: np.ndarray, contact_force: np.ndarray | None, owner: np.ndarray,
                   names: list[str], points: np.ndarray, node_body: np.ndarray,
                   body_names: list[str], to_numpy_all,
                   extents: np.ndarray | None = None, floor: float = 0.0) -> dict:
    """Reactions per support and the balance per body at one step (every rank calls).

    applied, body_force, contact_force: (2n,) nodal forces (loads, body forces, G^T lambda).
    """
    ku = probe.ku(u, to_numpy_all)
    c = contact_force if contact_force is not None else np.zeros_like(u)
    r = np.zeros_like(u)
    f = probe.fixed
    r[f] = ku[f] - applied[f] - body_force[f] - c[f]
    terms = {"loads": applied, "reactions": r}
    # forces of a node moved by 1e-6 of the largest displacement: a floor for the balance
    # when every force is round-off (a body moved rigidly by its supports); per body, its
    # own stiffness and displacement (the run's largest of each, a stiff body's diag(K)
    # times a soft one's |u|, hid an unbalanced force of 2e-3 of a stiff floating body's
    # loads: relative residual 2.1e-9 in place of 9.1e-5; hard/tangential_contrast.toml)
    floor = np.maximum(floor, BALANCE_FLOOR_FRACTION * _body_max(probe.k_diag, node_body,
                                                                len(body_names))
                       * _body_max(u, node_body, len(body_names)))
    if np.any(body_force):
        terms["body_force"] = body_force
    if contact_force is not None:
        terms["contact"] = c
    return {"supports": support_reactions(names, owner, r, points),
            "balance": body_balance(points, node_body, body_names, terms, extents, floor)}
