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

_BALANCE_FLOOR = 1e-300


def unique_names(names: list[str]) -> list[str]:
    """The names, with '#2', '#3' ... appended to the second, third ... repeat of one."""
    seen: dict[str, int] = {}
    out = []
    for n in names:
        seen[n] = seen.get(n, 0) + 1
        out.append(n if seen[n] == 1 else f"{n}#{seen[n]}")
    return out


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


def body_balance(points: np.ndarray, node_body: np.ndarray, body_names: list[str],
                 terms: dict[str, np.ndarray]) -> dict:
    """Force and moment balance per body of the nodal force vectors in `terms` (2n,) each.

    Returns {"bodies": {name: {term: [Fx, Fy, Mz], ..., "residual": [..]}},
    "max_relative_residual": float}: the residual is the sum of the terms; its moment (about
    the origin) relative to the sums of |nodal moment| (or the force scale times the body's
    size), its force part relative to the larger of the sums of |Fx| and |Fy| over all
    nodal forces of all terms of the body.
    """
    nb = len(body_names)
    worst = 0.0
    bodies = {}
    lever = points
    for b in range(nb):
        sel = node_body == b
        row = {}
        total = np.zeros(3)
        scale = np.zeros(3)
        for name, vec in terms.items():
            f = vec.reshape(-1, 2)[sel]
            mz = lever[sel, 0] * f[:, 1] - lever[sel, 1] * f[:, 0]
            res = np.array([f[:, 0].sum(), f[:, 1].sum(), mz.sum()])
            row[name] = [float(v) for v in res]
            total += res
            scale += [np.abs(f[:, 0]).sum(), np.abs(f[:, 1]).sum(), np.abs(mz).sum()]
        f_scale = scale[:2].max()
        extent = float(np.ptp(points[sel], axis=0).max()) if sel.any() else 0.0
        m_scale = max(scale[2], f_scale * extent)
        rel = max(np.abs(total[:2]).max() / f_scale if f_scale > _BALANCE_FLOOR else 0.0,
                  abs(total[2]) / m_scale if m_scale > _BALANCE_FLOOR else 0.0)
        row["residual"] = [float(v) for v in total]
        row["relative_residual"] = float(rel)
        worst = max(worst, float(rel))
        bodies[body_names[b]] = row
    return {"bodies": bodies, "max_relative_residual": worst}


def interface_resultants(contact: dict[str, np.ndarray], names: list[str]) -> dict:
    """Force on each interface's slave side, sum of p n + q t over its pairs, global axes.

    The master side carries the opposite force. Returns {name: {"force": [Fx, Fy]}}.
    """
    f = (contact["p_force"][:, None] * contact["normal"]
         + contact["q_force"][:, None] * contact["tangent"])
    out = {}
    for i, name in enumerate(names):
        sel = contact["interface"] == i
        out[name] = {"force": [float(v) for v in f[sel].sum(axis=0)]}
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


def step_reactions(probe: ReactionProbe, u: np.ndarray, applied: np.ndarray,
                   body_force: np.ndarray, contact_force: np.ndarray | None, owner: np.ndarray,
                   names: list[str], points: np.ndarray, node_body: np.ndarray,
                   body_names: list[str], to_numpy_all) -> dict:
    """Reactions per support and the balance per body at one step (every rank calls).

    applied, body_force, contact_force: (2n,) nodal forces (loads, body forces, G^T lambda).
    """
    ku = probe.ku(u, to_numpy_all)
    c = contact_force if contact_force is not None else np.zeros_like(u)
    r = np.zeros_like(u)
    f = probe.fixed
    r[f] = ku[f] - applied[f] - body_force[f] - c[f]
    terms = {"loads": applied, "reactions": r}
    if np.any(body_force):
        terms["body_force"] = body_force
    if contact_force is not None:
        terms["contact"] = c
    return {"supports": support_reactions(names, owner, r, points),
            "balance": body_balance(points, node_body, body_names, terms)}
