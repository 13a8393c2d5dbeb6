"""The contact constraints of a run: every interface's rows of G from its contact
discretisation (app/contact registry), and the per-pair law parameters (mu, adhesion and
strength forces, bonded, frictional)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from app.config import Config
from app.contact.constraints import ContactConstraints
from app.contact.discretisation import DEFAULT, contact_discretisation
from app.contact.pairs import ContactPairs, constraint_matrix, tributary_length
from app.contact.unpaired import paired_sides
from app.errors import InputError
from app.interface.floating import FloatingModes
from app.interface.steps import ContactStepper
from app.mesh.model import Mesh


class ContactSetup:
    """Pairs of every interface, the constraint matrix G and per-pair law parameters."""

    def __init__(self, cfg: Config, pairs: ContactPairs, g: sp.csr_matrix,
                 rows: ContactConstraints | None = None, described: dict | None = None):
        self.cfg = cfg
        self.pairs = pairs
        self.g = g
        self.rows = rows
        self.described = described or {}  # per interface: discretisation, master, n_pairs
        it = pairs.interface
        t = cfg.thickness
        self.mu = np.array([cfg.interfaces[i].mu for i in it])
        self.a = np.array([cfg.interfaces[i].a for i in it]) * pairs.length * t
        self.c = np.array([cfg.interfaces[i].c for i in it]) * pairs.length * t
        self.bonded = np.array([cfg.interfaces[i].bonded for i in it], dtype=bool)
        self.frictional = np.array([cfg.interfaces[i].frictional for i in it], dtype=bool)
        self.warnings: list[str] = []  # setup warnings (`split_slave_edge_warnings`)
        self.held_n = np.zeros(pairs.n_pairs, dtype=bool)  # (m,) set by `hold`
        self.node_g0, self.node_rows = np.zeros(pairs.n_pairs), None

    @classmethod
    def build(cls, mesh: Mesh, cfg: Config) -> ContactSetup:
        """The contact rows of every `[[interface]]` of cfg on the mesh (each by its
        discretisation's builder) and what the summary records of each interface;
        InputError when a node is the slave of two pairs."""
        found, described = [], {}
        for i, itf in enumerate(cfg.interfaces):  # the builders check the curves exist
            build = contact_discretisation(itf.discretisation, f"interface '{itf.name}'")
            found.append(build(mesh, itf, i))
            slave, _ = paired_sides(mesh, itf.slave, itf.master, found[-1].pairs.slave)
            described[itf.name] = {"discretisation": itf.discretisation or DEFAULT,
                                   "master_interpolation": found[-1].master_interpolation,
                                   "n_pairs": found[-1].n_pairs, "pairs_on": slave}
        # a slave corner just past two masters' joint: once, on the deepest of its pairs
        rows = ContactConstraints.concatenate(found).one_pair_per_node(
            mesh.points, _slave_tributaries(mesh, cfg))
        pairs = rows.pairs
        for i, itf in enumerate(cfg.interfaces):
            described[itf.name]["n_pairs"] = int(np.sum(pairs.interface == i))
        dup, counts = np.unique(pairs.slave, return_counts=True)
        if np.any(counts > 1):
            raise InputError(_shared_slave_message(mesh, cfg, pairs, int(dup[counts > 1][0])))
        setup = cls(cfg, pairs, rows.matrix(mesh.n_nodes), rows, described)
        setup.warnings = split_slave_edge_warnings(mesh, cfg, pairs)
        return setup

    def hold(self, mesh: Mesh, fixed: np.ndarray) -> None:
        """`held_n` (m,) bool: the pairs whose slave node and the master nodes of its
        projection (those of nonzero weight) the supports hold along the pair's normal
        (every DOF with a normal component of at least 1e-12 among the prescribed ones,
        fixed: sorted DOF indices, 2 x node + component). Whatever a pair's row weights
        (mortar-standard's end row reaches the free neighbour, so its compliance is not
        round-off), the overlap at such a pair's node is the supports' to keep. A free
        master node counts as held when the projection lies within the node's overlap
        depth of the other, held one (weight x segment length <= -node_g0): removing the
        overlap would move it at least a segment's length. A clamped fit tilted by 0.02
        put the projection 4e-4 into the end segment and ran, max p 1.66e8 with
        node-to-segment and mortar, 117 with mortar-standard (reviewer `review11`).
        With it the node's own normal gap: `node_g0` (m,) n . (x_s - x_p) and
        `node_rows` (m, 2 n_nodes) sparse, n . (u_s - (1 - xi) u_A - xi u_B) (length)."""
        pr, m = self.pairs, self.pairs.n_pairs
        held = np.zeros(2 * mesh.n_nodes, dtype=bool)
        held[fixed] = True
        along = np.abs(pr.normal) >= 1e-12  # (m, 2) the DOFs that carry the normal

        def normal_held(nodes: np.ndarray) -> np.ndarray:
            return np.all(held[2 * nodes[:, None] + np.arange(2)] | ~along, axis=1)

        a, b, xi = pr.master[:, 0], pr.master[:, 1], pr.xi
        x = mesh.points
        self.node_g0 = np.einsum("ij,ij->i", pr.normal,
                                 x[pr.slave] - (1 - xi)[:, None] * x[a] - xi[:, None] * x[b])
        near = np.linalg.norm(x[b] - x[a], axis=1) * np.minimum(xi, 1.0 - xi) \
            <= np.maximum(-self.node_g0, 0.0)  # the projection within the overlap of an end
        held_a, held_b = normal_held(a), normal_held(b)
        self.held_n = (normal_held(pr.slave) & (held_a | (xi >= 1.0) | (held_b & near))
                       & (held_b | (xi <= 0.0) | (held_a & near)))
        self.node_rows = constraint_matrix(pr, mesh.n_nodes)[:m]  # node-to-segment's rows

    def bodies(self, mesh: Mesh) -> set[int]:
        """Ids of the bodies that own a slave or master node of some pair."""
        nb = mesh.node_body()
        return set(nb[self.pairs.slave].tolist()) | set(nb[self.pairs.master.ravel()].tolist())

    def stepper(self, c_mat: np.ndarray, cases, unit, rhs,
                floating: FloatingModes | None) -> ContactStepper:
        """The rank-0 `ContactStepper` of these pairs over the load steps (c_mat: the
        (2m, 2m) compliance; see `ContactStepper`)."""
        return ContactStepper(self, c_mat, cases, unit, rhs, floating)


def _slave_tributaries(mesh: Mesh, cfg: Config) -> np.ndarray:
    """(n_nodes,) each slave-curve node's tributary length (half its curve edges, the
    largest over the interfaces' slave curves; 0 elsewhere): what a node's pairs may
    cover at most (`ContactConstraints.one_pair_per_node`). The builders checked the
    curves exist."""
    out = np.zeros(mesh.n_nodes)
    for itf in cfg.interfaces:
        nodes, length = tributary_length(np.asarray(mesh.points, dtype=float),
                                         np.asarray(mesh.curves[itf.slave]))
        out[nodes] = np.maximum(out[nodes], length)
    return out


def _shared_slave_message(mesh: Mesh, cfg: Config, pairs: ContactPairs, node: int) -> str:
    """One-line error for a node on the slave side of two interfaces (a corner shared by
    two slave curves, or one slave curve used twice), naming the interfaces and curves."""
    its = sorted(set(pairs.interface[pairs.slave == node].tolist()))
    body = mesh.body_names[int(mesh.node_body()[node])]
    where = " and ".join(f"'{cfg.interfaces[i].name}' (slave '{cfg.interfaces[i].slave}')"
                         for i in its)
    return (f"slave node at x={mesh.points[node, 0]:.4g}, y={mesh.points[node, 1]:.4g} of "
            f"body '{body}' is on the slave side of interfaces {where}: a node may be slave "
            "on one interface only, so two slave curves may not share a corner node; make "
            f"'{body}' the master on all but one of them (README \"Interfaces meeting at a "
            "corner\")")


def _node_to_segment(cfg: Config, i: int) -> bool:
    """Whether interface i (config order) uses node-to-segment rows."""
    return (cfg.interfaces[i].discretisation or DEFAULT) == "node-to-segment"


def split_slave_edge_warnings(mesh: Mesh, cfg: Config, pairs: ContactPairs) -> list[str]:
    """One warning per interface pair (i, j) whose slave curve has an edge with one node
    paired in i and the other in j: one slave curve on two masters that meet inside that
    edge (a block straddling two blocks, no slave node over the joint). Each interface
    counts only its own part of the edge, so the contact there is not consistent: a
    patch test (uniform p = 10) read 9.39-10.11 with node-to-segment. Swapping the roles
    (the straddling body as master of both) is exact. The mortar rows are exact there too
    (each interface's multiplier of the edge takes the covered part of the edge,
    app.contact.mortar.covered_tests; they read 9.96-10.05 before, mortar-standard
    9.0-12.2), so only a pair of interfaces where one is node-to-segment warns.
    """
    node_itf = np.full(mesh.n_nodes, -1, dtype=np.int64)
    node_itf[pairs.slave] = pairs.interface
    seen, out = set(), []
    for itf in cfg.interfaces:
        e = np.asarray(mesh.curves.get(itf.slave, np.zeros((0, 2))), dtype=np.int64)
        a, b = node_itf[e[:, 0]], node_itf[e[:, 1]]
        split = np.flatnonzero((a >= 0) & (b >= 0) & (a != b))
        if split.size == 0:
            continue
        i, j = sorted((int(a[split[0]]), int(b[split[0]])))
        if (i, j) in seen or not (_node_to_segment(cfg, i) or _node_to_segment(cfg, j)):
            continue
        seen.add((i, j))
        x = 0.5 * (mesh.points[e[split[0], 0]] + mesh.points[e[split[0], 1]])
        body = mesh.body_names[int(mesh.node_body()[e[split[0], 0]])]
        ni, nj = cfg.interfaces[i].name, cfg.interfaces[j].name
        out.append(f"interfaces '{ni}' and '{nj}': {split.size} edge(s) of the slave "
                   f"'{itf.slave}' have one node paired in each (first near x={x[0]:.4g}, "
                   f"y={x[1]:.4g}): their masters meet inside a slave edge and each "
                   "interface counts only its own part of it, so the contact there is off "
                   "(a patch test read p 6.1% off with node-to-segment, exact with mortar); make "
                   f"'{body}' the master of both (README \"Interfaces meeting at a "
                   "corner\")")
    return out
