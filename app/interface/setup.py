"""Contact set-up for a run: pairs and G, floating bodies, the LCP stepper and its output.

Distributed parts (the solves) take the PETSc objects; everything else runs on rank 0 on
small dense data (m pairs).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from petsc4py import PETSc

from app.assembly.loads import describe_modes, free_rigid_modes, mode_names, rigid_modes
from app.config import Config
from app.contact.constraints import ContactConstraints
from app.contact.discretisation import contact_discretisation
from app.contact.pairs import ContactPairs
from app.discretisation.bulk import zero_energy_modes
from app.errors import InputError, SolveError
from app.interface.candidates import CandidateLCP, candidate_pairs
from app.interface.coulomb import ContactLCP
from app.interface.steps import STATE_NAMES, InterfaceHistory, solve_step
from app.mesh.model import Mesh


@dataclass
class FloatingModes:
    """Rigid-body modes of bodies held only by contact.

    r: (2n, n_modes) displacement fields of the modes; pins: DOFs fixed to make the
    factorization regular (their reactions vanish at equilibrium); names: per mode text.
    """

    r: np.ndarray
    pins: np.ndarray
    names: list[str]


def floating_modes(mesh: Mesh, cfg: Config, fixed: np.ndarray,
                   contact: ContactSetup | None, disc=None) -> FloatingModes | None:
    """Zero-energy modes per body left by the supports; bodies without contact must have
    none. Rigid modes come from geometry; with CS-FEM-1SD the hourglass modes of bodies
    in contact are found from the body stiffness and handled the same way."""
    free = free_rigid_modes(mesh, fixed)
    in_contact = set() if contact is None else contact.bodies(mesh)
    hourglass = disc is not None and disc.hourglass
    if hourglass:
        for b in in_contact:
            free.setdefault(b, np.zeros((3, 0)))
    if not free:
        return None
    _check_held(mesh, cfg, fixed, contact)
    cols, pins, names = [], [], []
    node_body = mesh.node_body()
    for b, modes in sorted(free.items()):
        nodes = np.flatnonzero(node_body == b)
        centroid = mesh.points[nodes].mean(axis=0)
        text = describe_modes(modes, centroid)
        if b not in in_contact:
            raise SolveError(
                f"body '{mesh.body_names[b]}' is free to move ({text}): nothing holds it; "
                "add a [[support]] on one of its curves or an [[interface]] to another body"
            )
        rb = rigid_modes(mesh.points, nodes) @ modes  # (2 nb, r_b)
        labels = mode_names(modes, centroid) if modes.shape[1] else []
        if hourglass:  # rigid and hourglass modes together, from the body stiffness
            rb = zero_energy_modes(mesh, disc, b, fixed)
            labels = [f"zero-energy mode {i + 1}" for i in range(rb.shape[1])]
            if rb.shape[1] == 0:
                continue
        dofs = np.stack([2 * nodes, 2 * nodes + 1], axis=1).ravel()
        _, _, piv = sla.qr(rb.T, pivoting=True, mode="economic")
        pins.append(dofs[piv[: rb.shape[1]]])
        full = np.zeros((2 * mesh.n_nodes, rb.shape[1]))
        full[dofs] = rb
        cols.append(full)
        names += [f"{mesh.body_names[b]}: {t}" for t in labels]
    if not cols:
        return None
    return FloatingModes(np.hstack(cols), np.concatenate(pins).astype(np.int64), names)


def _check_held(mesh: Mesh, cfg: Config, fixed: np.ndarray,
                contact: ContactSetup | None) -> None:
    """Bodies linked by interfaces must include at least one support among them."""
    if contact is None:
        return
    nb = mesh.node_body()
    n_b = len(mesh.body_names)
    parent = list(range(n_b))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for s, m in zip(nb[contact.pairs.slave], nb[contact.pairs.master[:, 0]], strict=True):
        parent[find(int(s))] = find(int(m))
    supported = set(nb[np.unique(fixed // 2)].tolist()) if fixed.size else set()
    groups: dict[int, list[int]] = {}
    for b in range(n_b):
        groups.setdefault(find(b), []).append(b)
    for members in groups.values():
        if not supported.intersection(members):
            names = ", ".join(f"'{mesh.body_names[b]}'" for b in members)
            raise SolveError(f"bodies {names} are free to move together: no support holds "
                             "any of them; add a [[support]]")


class ContactSetup:
    """Pairs of every interface, the constraint matrix G and per-pair law parameters."""

    def __init__(self, cfg: Config, pairs: ContactPairs, g: sp.csr_matrix,
                 rows: ContactConstraints | None = None):
        self.cfg = cfg
        self.pairs = pairs
        self.g = g
        self.rows = rows
        it = pairs.interface
        t = cfg.thickness
        self.mu = np.array([cfg.interfaces[i].mu for i in it])
        self.a = np.array([cfg.interfaces[i].a for i in it]) * pairs.length * t
        self.c = np.array([cfg.interfaces[i].c for i in it]) * pairs.length * t
        self.bonded = np.array([cfg.interfaces[i].bonded for i in it], dtype=bool)
        self.frictional = np.array([cfg.interfaces[i].frictional for i in it], dtype=bool)

    @classmethod
    def build(cls, mesh: Mesh, cfg: Config) -> ContactSetup:
        found = []
        for i, itf in enumerate(cfg.interfaces):
            for key in ("slave", "master"):
                name = getattr(itf, key)
                if name not in mesh.curves:
                    raise InputError(f"interface '{itf.name}': {key} curve '{name}' is not in "
                                     f"the mesh (curves: {sorted(mesh.curves)})")
            build = contact_discretisation(itf.discretisation, f"interface '{itf.name}'")
            found.append(build(mesh, itf, i))
        rows = ContactConstraints.concatenate(found)
        pairs = rows.pairs
        dup, counts = np.unique(pairs.slave, return_counts=True)
        if np.any(counts > 1):
            n = int(dup[counts > 1][0])
            raise InputError(f"slave node at x={mesh.points[n, 0]:.4g}, "
                             f"y={mesh.points[n, 1]:.4g} belongs to two interfaces: a slave "
                             "curve may be slave on one interface only")
        return cls(cfg, pairs, rows.matrix(mesh.n_nodes), rows)

    def bodies(self, mesh: Mesh) -> set[int]:
        nb = mesh.node_body()
        return set(nb[self.pairs.slave].tolist()) | set(nb[self.pairs.master.ravel()].tolist())

    def compliance_route(self, solver) -> str:
        opts = PETSc.Options()
        route = opts.getString("contact_compliance", self.cfg.compliance)
        if route not in ("auto", "schur", "solve"):
            raise InputError(f"compliance route '{route}': use auto, schur or solve")
        if route == "auto":
            route = "schur" if solver.is_mumps else "solve"
        if route == "schur" and not solver.is_mumps:
            raise InputError("the schur compliance route needs MUMPS LU: use "
                             "-contact_compliance solve with other solvers")
        return route

    def stepper(self, c_mat: np.ndarray, cases, unit, rhs,
                floating: FloatingModes | None) -> ContactStepper:
        return ContactStepper(self, c_mat, cases, unit, rhs, floating)

    def displacement(self, lam: np.ndarray, solver, k: PETSc.Mat, fixed: np.ndarray,
                     to_numpy_all) -> np.ndarray:
        """K^-1 G^T lambda with the stored factorization (one solve, no refactorization)."""
        b = self.g.T @ lam
        b[fixed] = 0.0
        r0, r1 = k.getOwnershipRange()
        vec = k.createVecLeft()
        vec.setArray(b[r0:r1])
        return to_numpy_all(solver.solve(vec))

    def output_data(self, result: dict, u: np.ndarray, mesh: Mesh) -> dict:
        """Per-pair arrays for the HDF5 step file, plus the KKT check ('_kkt')."""
        pr = self.pairs
        m = pr.n_pairs
        gu = self.g @ u
        gap_u = pr.g0 + gu[:m]
        tau_u = gu[m:]
        p, q = result["lam"][:m], result["lam"][m:]
        scale_len = pr.length * self.cfg.thickness
        data = {
            "position": pr.position,
            "x": pr.position[:, 0],
            "y": pr.position[:, 1],
            "interface": pr.interface.astype(np.int64),
            "slave": pr.slave.astype(np.int64),
            "master": pr.master.astype(np.int64),
            "xi": pr.xi,
            "normal": pr.normal,
            "tangent": pr.tangent,
            "g0": pr.g0,
            "length": pr.length,
            "p": p / scale_len,
            "q": q / scale_len,
            "p_force": p,
            "q_force": q,
            "gap": gap_u,
            "tau": tau_u,
            "tau_prev": result["tau_prev"],
            "slip_increment": tau_u - result["tau_prev"],
            "slip": result["slip"],
            "state": result["state"].astype(np.int64),
            "debonded_step": result["debonded_step"].astype(np.int64),
            "mu": self.mu,
            "a_force": result["a"],
            "c_force": result["c"],
        }
        if self.rows is not None:  # the rows of G (the KKT check of tests/support.py)
            data |= {"g_cols": self.rows.cols, "g_normal": self.rows.g_normal,
                     "g_tangent": self.rows.g_tangent}
        data["_kkt"] = kkt_check(gap_u, tau_u, result["tau_prev"], p, q, self.mu,
                                 result["a"], result["c"], self.frictional,
                                 u_scale=float(np.abs(u).max(initial=0.0)),
                                 f_scale=result["f_scale"])
        return data


def kkt_check(gap, tau, tau_prev, p, q, mu, a, c, frictional, *, u_scale: float = 0.0,
              f_scale: float = 0.0) -> dict:
    """Largest violations of METHOD section 4, relative to the data's scales.

    u_scale / f_scale: displacement and force scales of the problem (the largest
    displacement of the step's field and the largest load), floors for the normalisation.
    """
    fs = max(np.abs(p).max(initial=0.0), np.abs(q).max(initial=0.0), np.abs(a).max(initial=0),
             np.abs(c).max(initial=0.0), f_scale, 1e-300)
    us = max(np.abs(gap).max(initial=0.0), np.abs(tau).max(initial=0.0), u_scale, 1e-300)
    bound = mu * p + c
    dtau = np.where(frictional, tau - tau_prev, 0.0)
    slipping = np.abs(dtau) > 1e-6 * us
    direction = np.where(slipping, np.abs(q + np.sign(dtau) * bound), 0.0)
    return {
        "gap": float(max(0.0, -gap.min(initial=0.0)) / us),
        "normal_force": float(max(0.0, -(p + a).min(initial=0.0)) / fs),
        "complementarity": float(np.abs(gap * (p + a)).max(initial=0.0) / (us * fs)),
        "friction_bound": float(max(0.0, (np.abs(q) - bound).max(initial=0.0)) / fs),
        "slip_direction": float(direction.max(initial=0.0) / fs),
    }


def mismatch(g: sp.csr_matrix, u: np.ndarray, result: dict) -> np.ndarray:
    """G u minus the LCP's (gap - g0, tau): (2m,), zero when the compliance C used by the
    LCP agrees with the factorization that recovers u. An inexact C (round-off of the
    Schur complement on an ill-conditioned K) shows here; adding it to the free gap and
    tangential displacement and solving again converges to the consistent answer."""
    return g @ u - result["kinematics"]


def split_modes(n_modes: np.ndarray, t_modes: np.ndarray,
                rel: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal bases (r, r1), (r, r0) of the floating-mode amplitudes that move some
    pair ([N; T] v != 0) and of those that move none (see `undetermined_modes`)."""
    a = np.vstack([n_modes, t_modes])
    r = a.shape[1]
    if a.shape[0] == 0:
        return np.zeros((r, 0)), np.eye(r)
    _, sv, vt = np.linalg.svd(a, full_matrices=True)
    sv = np.concatenate([sv, np.zeros(r - sv.size)])
    null = sv <= rel * max(sv.max(initial=0.0), 1e-300)
    return vt[~null].T, vt[null].T


def undetermined_modes(n_modes: np.ndarray, t_modes: np.ndarray, names: list[str],
                       rel: float = 1e-9) -> list[str]:
    """Floating-body modes (or combinations) that no contact force can resist.

    n_modes (m, r), t_modes (mf, r): normal and tangential (frictional pairs) gap change per
    unit mode amplitude. A combination v with [N; T] v = 0 moves no pair: under a load with
    no component on it, every amplitude is an equilibrium (the answer is not unique; the LCP
    returns one), and under a load with such a component there is none. Returns one text
    per such direction, naming its dominant mode.
    """
    if not names:
        return []
    a = np.vstack([n_modes, t_modes])
    if a.shape[0] == 0:
        return list(names)
    _, sv, vt = np.linalg.svd(a, full_matrices=True)
    sv = np.concatenate([sv, np.zeros(vt.shape[0] - sv.size)])
    null = vt[sv <= rel * max(sv.max(initial=0.0), 1e-300)]
    return [names[int(np.argmax(np.abs(v)))] for v in null]


class ContactStepper:
    """Rank-0 state of the contact problem over the load steps."""

    def __init__(self, setup: ContactSetup, c_mat: np.ndarray, cases, unit, rhs,
                 floating: FloatingModes | None):
        """unit: K^-1 b per load case; rhs: the load cases' right-hand sides b (forces
        with the Dirichlet lifting, zero on prescribed DOFs)."""
        self.setup = setup
        pr = setup.pairs
        m = pr.n_pairs
        self.m = m
        g = setup.g
        self.gu = [g @ uc for uc in unit]  # (2m,) per load case
        self.v_keep = self.v_null = None
        if floating is not None and floating.r.shape[1]:
            gr = g @ floating.r  # (2m, r)
            self.n_modes, self.t_modes = gr[:m], gr[m:]
            self.v_keep, self.v_null = split_modes(self.n_modes,
                                                   self.t_modes[setup.frictional])
            if self.v_null.shape[1]:  # amplitudes no pair sees: left out of the LCP
                self.n_modes = self.n_modes @ self.v_keep
                self.t_modes = self.t_modes @ self.v_keep
            else:
                self.v_keep = self.v_null = None
            self.e0 = [floating.r.T @ b for b in rhs]
            self.mode_names = floating.names
        else:
            self.n_modes = self.t_modes = None
            self.e0 = [np.zeros(0) for _ in cases]
            self.mode_names = []
        lcp_class = CandidateLCP if candidate_pairs(setup.cfg.candidate_pairs) else ContactLCP
        self.lcp = lcp_class(c_mat, setup.mu, setup.frictional, self.n_modes, self.t_modes)
        self.undetermined = [] if self.v_null is None else [
            self.mode_names[int(np.argmax(np.abs(v)))] for v in self.v_null.T]
        self.hist = InterfaceHistory(
            a=np.where(setup.bonded, setup.a, 0.0), c=np.where(setup.bonded, setup.c, 0.0),
            bonded=setup.bonded.copy(), tau_prev=np.zeros(m),
            debonded_step=np.zeros(m, dtype=np.int64),
            warm_start=setup.cfg.warm_start)
        self.slip = np.zeros(m)
        scale = max(max((np.abs(x).max(initial=0.0) for x in self.gu), default=0.0),
                    np.abs(pr.g0).max(initial=0.0), 1e-300)
        self.tol = 1e-7 * scale
        self.f_scale = max(max((np.abs(b).sum() for b in rhs), default=0.0),
                           np.abs(self.hist.a).max(initial=0.0),
                           np.abs(self.hist.c).max(initial=0.0))

    def refine(self, step: int, cases, correction: np.ndarray) -> dict | None:
        """Re-solve step `step` with a consistency correction; None (and the state of the
        last good solve kept) if that fails."""
        kept = (copy.deepcopy(self.hist), self.slip.copy())
        out = self.step(step, cases, correction)
        if out["status"] != "solved":
            self.hist, self.slip = kept
            return None
        return out

    def step(self, step: int, cases, correction: np.ndarray | None = None) -> dict:
        """Solve load step `step` (0-based). `correction` (2m,): a re-solve of the same
        step with the free gap and tangential displacement shifted by it (the consistency
        refinement, see `mismatch`); the step restarts from the history before its first
        solve, warm-started from the last basis."""
        m = self.m
        pr = self.setup.pairs
        if correction is None:
            self._saved = (copy.deepcopy(self.hist), self.slip.copy())
        else:
            basis = self.hist.basis
            self.hist, self.slip = copy.deepcopy(self._saved[0]), self._saved[1].copy()
            self.hist.basis = basis
        gap_free = pr.g0.copy()
        tau_free = np.zeros(m)
        e0 = np.zeros(len(self.mode_names))
        for case, gu, e in zip(cases, self.gu, self.e0, strict=True):
            h = case.history[step]
            gap_free += h * gu[:m]
            tau_free += h * gu[m:]
            if e.size:
                e0 += h * e
        if self.v_null is not None and self.v_null.shape[1]:
            loaded = np.abs(self.v_null.T @ e0) > 1e-9 * max(self.f_scale, 1e-300)
            if loaded.any():
                names = ", ".join(n for n, k in zip(self.undetermined, loaded, strict=True)
                                  if k)
                return {"status": "unbalanced load", "message": f"a load on {names}; the "
                        f"contact cannot resist {names}"}
            e0 = self.v_keep.T @ e0
        if correction is not None:
            gap_free += correction[:m]
            tau_free += correction[m:]
        tau_prev = self.hist.tau_prev.copy()
        res = solve_step(self.lcp, self.hist, step + 1, gap_free, tau_free, self.setup.mu,
                         e0, self.tol, self.tol)
        sol = res.solution
        out = {"status": res.status, "message": "",
               "lam": np.concatenate([sol.p, sol.q]),
               "alpha": sol.alpha if self.v_keep is None else self.v_keep @ sol.alpha,
               "kinematics": np.concatenate([sol.gap - pr.g0, sol.tau])}
        if res.status != "solved":
            out["message"] = f"Lemke ended with '{res.status}': {sol.message}"
            if self.undetermined:
                out["message"] += ("; the contact cannot resist " +
                                   ", ".join(self.undetermined))
            return out
        self.slip += sol.slip_plus - sol.slip_minus
        it = pr.interface
        counts = {name: int(np.sum(res.state == k)) for k, name in enumerate(STATE_NAMES)}
        length_t = pr.length * self.setup.cfg.thickness
        per_if = {}
        for i, itf in enumerate(self.setup.cfg.interfaces):
            sel = it == i
            per_if[itf.name] = {
                "n_pairs": int(sel.sum()),
                "normal_force": float(sol.p[sel].sum()),
                "tangential_force": float(sol.q[sel].sum()),
                "max_pressure": float((sol.p[sel] / length_t[sel]).max(initial=0.0)),
                "states": {name: int(np.sum(res.state[sel] == k))
                           for k, name in enumerate(STATE_NAMES)},
                # zone sizes (sum of pair lengths) and the intact bond (for studies)
                "state_lengths": {name: float(pr.length[sel & (res.state == k)].sum())
                                  for k, name in enumerate(STATE_NAMES)},
                "contact_length": float(pr.length[sel & (sol.p > 0)].sum()),
                "debonded_pairs": int(np.sum(res.debonded_step[sel] > 0)),
                "bond_strength_force": float(self.hist.c[sel].sum()),
            }
        info = {
            "n_pairs": m,
            "states": counts,
            "interfaces": per_if,
            "max_contact_pressure": float((sol.p / length_t).max(initial=0.0)),
            "lcp_size": getattr(self.lcp, "full_size", self.lcp.size),
            "lcp_size_solved": self.lcp.size,
            "lemke_pivots": res.pivots,
            "lcp_residual": sol.residual,
            "dependent_tangential_directions": self.lcp.dependent_tangential,
            "lcp_seconds": res.seconds,
            "lcp_solves": res.iterations,
            "debonded_this_step": int(np.sum(res.debonded_step == step + 1)),
            "dissipation": res.dissipation,
        }
        if self.mode_names:
            info["rigid_modes"] = dict(zip(self.mode_names, map(float, out["alpha"]),
                                           strict=True))
        if self.undetermined:
            info["undetermined_modes"] = self.undetermined
        out.update({"info": info, "state": res.state, "debonded_step": res.debonded_step,
                    "tau_prev": tau_prev, "slip": self.slip.copy(),
                    "a": self.hist.a.copy(), "c": self.hist.c.copy(),
                    "f_scale": self.f_scale})
        return out
