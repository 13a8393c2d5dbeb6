"""CalculiX 2.20 exchange for the contact scenes: write a CPE4 deck from this project's
mesh, read the `.dat` tables back, and recover slave-side contact tractions from the
displacement field.

Pure numpy and text functions (no ccx, no files): `scripts/calculix_cattaneo.py` runs them.
Conventions of the deck (see ../shared/design/CALCULIX-NOTES.md): 2D elements in z = 0,
counter-clockwise, `*SOLID SECTION` with the thickness, surfaces built from element
faces (face k of a CPE4 is its edge from corner k to corner k + 1, label S{k+1}),
face-to-face penalty contact with a linear pressure-overclosure law and Coulomb friction
with a stick slope. Node i of the mesh is CalculiX node i + 1, element e is element e + 1.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from app.contact.mortar import nodal_normals
from app.contact.pairs import tributary_length
from app.discretisation.elements import elasticity_matrix
from app.discretisation.fem_q4 import cell_gradients
from app.mesh.model import orient_boundary_edges

MIN_MU = 1e-6
"""The friction coefficient written for a step asked to be frictionless (ccx needs mu > 0)."""


@dataclass
class Step:
    """One CalculiX step: prescribed displacements {node set: {component (1 = x, 2 = y):
    value}} reached at its end (ramped from the previous step's values), the increment
    count, and the friction coefficient in force during it (None: the interaction's)."""

    boundary: dict[str, dict[int, float]]
    increments: int = 1
    mu: float | None = None


@dataclass
class ContactDeck:
    """A two-body contact scene for CalculiX.

    points (n, 2), quads (ne, 4) counter-clockwise, body (ne,) body index per element;
    node_sets: name -> node indices; slave_faces, master_faces: (k, 2) arrays of
    (element, local face 0..3); E, nu per body; penalty K (stress / length); mu and the
    stick slope `stick` (stress / length); fixed: node set -> components held at zero
    throughout; steps in order.
    """

    points: np.ndarray
    quads: np.ndarray
    body: np.ndarray
    node_sets: dict[str, np.ndarray]
    slave_faces: np.ndarray
    master_faces: np.ndarray
    E: list[float]
    nu: list[float]
    thickness: float
    penalty: float
    mu: float
    stick: float
    fixed: dict[str, tuple[int, ...]]
    steps: list[Step]
    print_sets: list[str] = field(default_factory=list)  # node sets whose U and RF are printed
    nlgeom: bool = False  # geometrically nonlinear steps (*STEP, NLGEOM)
    pair_type: str = "SURFACE TO SURFACE"  # or "NODE TO SURFACE" (*CONTACT PAIR, TYPE=)
    behavior_extra: tuple[float, ...] = ()  # *SURFACE BEHAVIOR values after K (sigma_inf, c0)


def edge_faces(quads: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """(k, 2) (element, local face) of boundary edges (k, 2) oriented with their element on
    the left (A -> B = corner f -> corner f + 1 of a counter-clockwise quad).

    Raises ValueError if an edge is not such an element edge.
    """
    n = int(max(quads.max(), edges.max())) + 1
    keys = (quads * n + np.roll(quads, -1, axis=1)).ravel()
    order = np.argsort(keys)
    want = edges[:, 0] * n + edges[:, 1]
    pos = np.minimum(np.searchsorted(keys[order], want), keys.size - 1)
    hit = keys[order][pos] == want
    if not hit.all():
        a, b = edges[np.argmin(hit)]
        raise ValueError(f"edge {a}-{b} is not an element edge with its element on the left")
    flat = order[pos]
    return np.stack([flat // 4, flat % 4], axis=1)


def interface_curves(mesh, slave: str, master: str
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(slave edges, master edges, slave faces, master faces) of a mesh's two contact
    curves (names in mesh.curves): edges (k, 2) oriented with their body on the left
    (`orient_boundary_edges`), faces (k, 2) their (element, local face) (`edge_faces`)."""
    s = orient_boundary_edges(mesh, mesh.curves[slave], "slave")
    m = orient_boundary_edges(mesh, mesh.curves[master], "master")
    return s, m, edge_faces(mesh.quads, s), edge_faces(mesh.quads, m)


def _lines(ids: np.ndarray, per_line: int = 8) -> list[str]:
    ids = np.asarray(ids, dtype=np.int64)
    return [", ".join(str(int(i)) for i in ids[k:k + per_line])
            for k in range(0, ids.size, per_line)]


def _surface_lines(deck: ContactDeck, face_offset: int) -> list[str]:
    """The SLAVE and MASTER `*SURFACE` cards; local face f is label S{f + face_offset}
    (1 for CPE4, 3 for the C3D8 of `calculix_c3d8.py`)."""
    out = []
    for name, faces in (("SLAVE", deck.slave_faces), ("MASTER", deck.master_faces)):
        out.append(f"*SURFACE, NAME={name}, TYPE=ELEMENT")
        out += [f"{int(e) + 1}, S{int(f) + face_offset}" for e, f in faces]
    return out


def _fixed_lines(deck: ContactDeck) -> list[str]:
    """The `*BOUNDARY` data lines of the components held at zero throughout."""
    return [f"{name.upper()}, {c}, {c}, 0." for name, comps in deck.fixed.items()
            for c in comps]


def _step_lines(step: Step, deck: ContactDeck) -> list[str]:
    inc = 1.0 / step.increments
    # automatic incrementation capped at 1 / increments (ccx cuts back where contact
    # states cycle; DIRECT stops there)
    out = [f"*STEP, {'NLGEOM, ' if deck.nlgeom else ''}INC=1000", "*STATIC",
           f"{inc:.10g}, 1., {inc * 1e-4:.10g}, {inc:.10g}"]
    if step.mu is not None:
        mu = max(step.mu, MIN_MU)  # CalculiX refuses mu = 0
        out += ["*CHANGE FRICTION, INTERACTION=SI", "*FRICTION", f"{mu:.10g}, {deck.stick:.10g}"]
    out.append("*BOUNDARY")
    for name, comps in step.boundary.items():
        out += [f"{name.upper()}, {c}, {c}, {v:.10g}" for c, v in comps.items()]
    out += ["*NODE PRINT, NSET=NALL", "U"]
    for name in deck.print_sets:
        out += [f"*NODE PRINT, NSET={name.upper()}, TOTALS=YES", "RF"]
    out += ["*CONTACT FILE", "CSTR, CDIS", "*END STEP"]
    return out


def write_deck(deck: ContactDeck) -> str:
    """The `.inp` text of the scene (CPE4, z = 0; body 0 is the slave body's, any other
    bodies follow)."""
    pts, quads = deck.points, deck.quads
    out = ["*HEADING", "csfem-contact scene exported by scripts/calculix_deck.py",
           "*NODE, NSET=NALL"]
    out += [f"{i + 1}, {x:.13g}, {y:.13g}, 0" for i, (x, y) in enumerate(pts)]
    for b in range(len(deck.E)):
        sel = np.flatnonzero(deck.body == b)
        out.append(f"*ELEMENT, TYPE=CPE4, ELSET=BODY{b}")
        out += [f"{e + 1}, " + ", ".join(str(int(v) + 1) for v in quads[e]) for e in sel]
    for name, nodes in deck.node_sets.items():
        out.append(f"*NSET, NSET={name.upper()}")
        out += _lines(np.unique(nodes) + 1)
    out += _surface_lines(deck, 1)
    for b, (E, nu) in enumerate(zip(deck.E, deck.nu, strict=True)):
        out += [f"*MATERIAL, NAME=MAT{b}", "*ELASTIC", f"{E:.10g}, {nu:.10g}",
                f"*SOLID SECTION, ELSET=BODY{b}, MATERIAL=MAT{b}", f"{deck.thickness:.10g}"]
    out += ["*SURFACE INTERACTION, NAME=SI", "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR",
            ", ".join(f"{v:.10g}" for v in (deck.penalty, *deck.behavior_extra))]
    if deck.mu > 0:
        out += ["*FRICTION", f"{deck.mu:.10g}, {deck.stick:.10g}"]
    out += [f"*CONTACT PAIR, INTERACTION=SI, TYPE={deck.pair_type}", "SLAVE, MASTER"]
    out += ["*BOUNDARY", *_fixed_lines(deck)]
    for step in deck.steps:
        out += _step_lines(step, deck)
    return "\n".join(out) + "\n"


_HEADER = re.compile(r"^\s*(?P<title>[a-z].*?) for (?:set (?P<set>\S+)|all contact elements)"
                     r" and time\s+(?P<time>\S+)\s*$")


def parse_dat(text: str) -> list[dict]:
    """The tables of a CalculiX `.dat` file, in order: dicts with `title` (e.g.
    "displacements (vx,vy,vz)"), `set` (upper case, None for contact tables), `time`
    (float, total time) and `rows` (k, c) float array (first column the node or element
    number); `total` (c-1,) for a TOTALS=YES table (its "total force" line)."""
    tables: list[dict] = []
    cur: dict | None = None
    for line in text.splitlines():
        m = _HEADER.match(line)
        if m:
            cur = {"title": m["title"].strip(), "set": m["set"], "time": float(m["time"]),
                   "rows": []}
            tables.append(cur)
            continue
        if cur is None or not line.strip():
            continue
        parts = line.split()
        try:
            vals = [float(v) for v in parts]
        except ValueError:
            if parts[0] == "total" or line.strip().startswith("total"):
                cur["total"] = np.array([float(v) for v in parts if _is_float(v)])
            else:
                cur = None
            continue
        cur["rows"].append(vals)
    for t in tables:
        width = max((len(r) for r in t["rows"]), default=0)
        t["rows"] = np.array([r + [np.nan] * (width - len(r)) for r in t["rows"]])
    return tables


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def nodal_table(tables: list[dict], title: str, nset: str, n_nodes: int,
                time: float | None = None) -> tuple[float, np.ndarray]:
    """(time, (n_nodes, 3) array, NaN where not printed) of the last table whose title
    starts with `title` for node set `nset` (at `time` if given)."""
    hits = [t for t in tables if t["title"].startswith(title) and t["set"] == nset.upper()
            and (time is None or abs(t["time"] - time) < 1e-9)]
    if not hits:
        raise KeyError(f"no '{title}' table for set {nset}" +
                       ("" if time is None else f" at time {time}"))
    t = hits[-1]
    out = np.full((n_nodes, 3), np.nan)
    rows = t["rows"]
    out[rows[:, 0].astype(np.int64) - 1] = rows[:, 1:4]
    return t["time"], out


def total_force(tables: list[dict], nset: str | None = None,
                time: float | None = None) -> np.ndarray | None:
    """The (fx, fy, fz) row of the last "total force" table (of node set `nset`, at `time`
    when given); None when there is none."""
    hits = [t for t in tables if t["title"].startswith("total force")
            and (nset is None or t["set"] == nset.upper())
            and (time is None or abs(t["time"] - time) < 1e-9)]
    return hits[-1]["rows"][0] if hits else None


def median_edge(points: np.ndarray, edges: np.ndarray, x_max: float) -> float:
    """Median length of the edges (k, 2) whose midpoint has |x| < x_max (the contact
    element size h_c of a penalty)."""
    mid = 0.5 * (points[edges[:, 0]] + points[edges[:, 1]])
    ln = np.linalg.norm(points[edges[:, 1]] - points[edges[:, 0]], axis=1)
    return float(np.median(ln[np.abs(mid[:, 0]) < x_max]))


def times(tables: list[dict], title: str, nset: str) -> list[float]:
    """The output times of the tables `title` for `nset`, in order."""
    return [t["time"] for t in tables if t["title"].startswith(title)
            and t["set"] == nset.upper()]


def parse_frd_contact(text: str, n_nodes: int) -> list[tuple[float, np.ndarray]]:
    """(time, (n_nodes, 6) array of COPEN, CSLIP1, CSLIP2, CPRESS, CSHEAR1, CSHEAR2; zero
    where not written) of every CONTACT block of a `.frd` file (nodal values at the 2D
    nodes; fixed columns: ' -1', node I10, values E12.5)."""
    out: list[tuple[float, np.ndarray]] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("  100CL") and i + 1 < len(lines) and "CONTACT" in lines[i + 1]:
            t = float(line[12:25])
            arr = np.zeros((n_nodes, 6))
            i += 2
            while i < len(lines) and not lines[i].startswith(" -3"):
                row = lines[i]
                if row.startswith(" -1"):
                    node = int(row[3:13])
                    arr[node - 1] = [float(row[13 + 12 * k:25 + 12 * k]) for k in range(6)]
                i += 1
            out.append((t, arr))
        i += 1
    return out


def internal_forces(points: np.ndarray, quads: np.ndarray, u: np.ndarray, E: float, nu: float,
                    thickness: float, plane: str = "strain", nonlinear: bool = False
                    ) -> np.ndarray:
    """(n, 2) nodal internal forces of bilinear quads with 2x2 Gauss points (CalculiX's
    CPE4, the same as this project's FEM-Q4) of one material; u (n, 2).

    Linear: K u. nonlinear: the total-Lagrangian forces of CalculiX's NLGEOM with a linear
    elastic material (St. Venant-Kirchhoff: S = D E with the Green-Lagrange strain E, first
    Piola-Kirchhoff stress F S), integrated over the undeformed elements.
    """
    xe = points[quads]
    bx, by, w = cell_gradients(xe)  # (ne, 4 gauss, 4 nodes), (ne, 4)
    ue = u[quads]  # (ne, 4, 2)
    ux_x, ux_y = (np.einsum("egn,en->eg", b, ue[..., 0]) for b in (bx, by))
    uy_x, uy_y = (np.einsum("egn,en->eg", b, ue[..., 1]) for b in (bx, by))
    exx, eyy, gxy = ux_x, uy_y, ux_y + uy_x
    if nonlinear:
        exx = exx + 0.5 * (ux_x**2 + uy_x**2)
        eyy = eyy + 0.5 * (ux_y**2 + uy_y**2)
        gxy = gxy + ux_x * ux_y + uy_x * uy_y
    d = elasticity_matrix(E, nu, plane)
    sxx = d[0, 0] * exx + d[0, 1] * eyy
    syy = d[1, 0] * exx + d[1, 1] * eyy
    sxy = d[2, 2] * gxy
    if nonlinear:  # P = F S, F = I + grad u
        pxx, pxy = (1 + ux_x) * sxx + ux_y * sxy, (1 + ux_x) * sxy + ux_y * syy
        pyx, pyy = uy_x * sxx + (1 + uy_y) * sxy, uy_x * sxy + (1 + uy_y) * syy
    else:
        pxx, pxy, pyx, pyy = sxx, sxy, sxy, syy
    ww = w * thickness
    fx = np.einsum("egn,eg->en", bx, ww * pxx) + np.einsum("egn,eg->en", by, ww * pxy)
    fy = np.einsum("egn,eg->en", bx, ww * pyx) + np.einsum("egn,eg->en", by, ww * pyy)
    f = np.zeros((points.shape[0], 2))
    np.add.at(f[:, 0], quads, fx)
    np.add.at(f[:, 1], quads, fy)
    return f


def chain_nodes(edges: np.ndarray) -> np.ndarray:
    """Node order along an open chain of edges (k, 2) oriented head to tail."""
    nxt = dict(zip(edges[:, 0].tolist(), edges[:, 1].tolist(), strict=True))
    start = set(nxt) - set(edges[:, 1].tolist())
    if len(start) != 1:
        raise ValueError("the edges do not form one open chain")
    node = start.pop()
    order = [node]
    while node in nxt:
        node = nxt[node]
        order.append(node)
    return np.array(order)


def surface_tractions(points: np.ndarray, edges: np.ndarray, force: np.ndarray,
                      u: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Nodal tractions of a slave curve from nodal forces on its body.

    edges (k, 2): the curve's edges oriented with the body on the left (the outward
    normal of an edge A -> B is (dy, -dx) / length); force (n, 2): forces on the body
    (the recovered contact force at the curve's nodes). Per curve node, in chain order:
    x, y, `length` (tributary length, half of each adjacent edge), `fx`, `fy`, and the
    force per tributary length projected on the curve's averaged nodal normal (outward)
    and tangent (the normal turned clockwise, +x where the normal is -y): `pn` (> 0 when
    pressing) and `qt`, in the undeformed geometry and, if u (n, 2) is given, `pn_def`,
    `qt_def` in the deformed one.
    """
    nodes = chain_nodes(edges)
    out = {"node": nodes, "x": points[nodes, 0], "y": points[nodes, 1]}
    on, length = tributary_length(points, edges)
    trib = length[np.searchsorted(on, nodes)]
    out["length"] = trib
    f = force[nodes]
    out["fx"], out["fy"] = f[:, 0] / trib, f[:, 1] / trib
    for key, xy in (("", points), ("_def", None if u is None else points + u)):
        if xy is None:
            continue
        nn = nodal_normals(xy, edges, xy.shape[0])[0][nodes]
        tt = np.stack([-nn[:, 1], nn[:, 0]], axis=1)
        out["pn" + key] = -np.einsum("ij,ij->i", f, nn) / trib
        out["qt" + key] = np.einsum("ij,ij->i", f, tt) / trib
    return out


def recovered_tractions(tables: list[dict], deck: ContactDeck, slave: np.ndarray,
                        plane: str = "strain", time: float | None = None
                        ) -> dict[str, np.ndarray]:
    """Slave tractions recovered from a CalculiX run's displacements (the NALL table at
    `time`, default the last; NaN read as 0): the internal forces of the slave body (the
    body of the elements of deck.slave_faces; NLGEOM forces when deck.nlgeom) through
    `surface_tractions` on the slave edges (k, 2), in chain order without the nodes of
    any of deck.node_sets (the supported ones), plus `force` (m, 2) the nodal forces there.

    Raises ValueError when the slave faces belong to more than one body.
    """
    n = deck.points.shape[0]
    bodies = np.unique(deck.body[deck.slave_faces[:, 0]])
    if bodies.size != 1:
        raise ValueError(f"the slave faces lie on {bodies.size} bodies, not one")
    b = int(bodies[0])
    _, u = nodal_table(tables, "displacements", "NALL", n, time)
    u2 = np.nan_to_num(u[:, :2])
    f = internal_forces(deck.points, deck.quads[deck.body == b], u2, deck.E[b], deck.nu[b],
                        deck.thickness, plane, nonlinear=deck.nlgeom)
    tr = surface_tractions(deck.points, slave, f, u2)
    tr["force"] = f[tr["node"]]
    free = ~np.isin(tr["node"], np.concatenate(list(deck.node_sets.values())))
    return {k: v[free] for k, v in tr.items()}
