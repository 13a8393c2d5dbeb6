"""Bodies held only by contact: their rigid (and, with CS-FEM-1SD, hourglass) modes.

The supports leave some modes of a body free; a body in contact keeps them as LCP
unknowns (amplitudes alpha) and pins one DOF per mode so that K is regular. A body with a
free mode and no contact is an error that names it. Plain numpy on the mesh (rank 0).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sps
from scipy.sparse.csgraph import connected_components

from app.assembly.sequential_factor import SequentialCholesky
from app.config import Config
from app.discretisation.bulk import zero_energy_modes
from app.errors import SolveError
from app.mesh.model import Mesh

if TYPE_CHECKING:
    import scipy.sparse as sp

    from app.interface.contact import ContactSetup


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


@dataclass
class FloatingModes:
    """Rigid-body modes of bodies held only by contact.

    r: (2n, n_modes) displacement fields of the modes; pins: DOFs fixed to make the
    factorization regular (their reactions vanish at equilibrium); names: per mode text;
    bodies: per mode its body's name; rigid: (3, n_modes) coefficients of (tx, ty, rotation
    about the body centroid) per mode (NaN for hourglass modes); centroids (n_modes, 2).
    """

    r: np.ndarray
    pins: np.ndarray
    names: list[str]
    bodies: list[str] = field(default_factory=list)
    rigid: np.ndarray | None = None
    centroids: np.ndarray | None = None


HOURGLASS_HINT = ("CS-FEM-1SD leaves zero-energy (hourglass) modes that only the contact "
                  "holds, and those may have no equilibrium, or one only with hourglass "
                  "amplitudes far beyond small displacements (and the search's bound): use "
                  "--sd 2 or more (hourglass-free smoothing), --method fem-q4, or a finer mesh")
"""What a failed contact step adds when zero-energy (hourglass) modes are held by contact.
Both happen: multibody.toml --sd 1 --mesh-size 1.6 has no equilibrium (an LP on the modes'
forces in their cones), 1.0's step 1 has one with a mode amplitude of 6.3e3 in a scene 6
wide (Lemke on the unscaled LCP; its scaled unknowns to 3.7e5 x max |q|, README "Floating
bodies"), where --method fem-q4 completes."""


def held_text(floating: FloatingModes) -> str:
    """The modes held only by contact for an error line: rigid modes by name ('b1:
    translation x'); a body's zero-energy (hourglass) modes counted ('block1: 12
    zero-energy modes'), as 21 of them listed one by one made the line unreadable."""
    zero = np.zeros(len(floating.names), dtype=bool) if floating.rigid is None else \
        np.isnan(floating.rigid).any(axis=0)
    bodies = floating.bodies or floating.names
    count = Counter(b for b, z in zip(bodies, zero, strict=True) if z)
    out = []
    for name, body, z in zip(floating.names, bodies, zero, strict=True):
        if not z:
            out.append(name)
        elif body in count:
            k = count.pop(body)
            out.append(f"{body}: {k} zero-energy mode{'s' if k > 1 else ''}")
    return ", ".join(out)


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
    cols, pins, names, bodies, rigid, centres = [], [], [], [], [], []
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
        coef = modes
        if hourglass:  # rigid and hourglass modes together, from the body stiffness
            rb = zero_energy_modes(mesh, disc, b, fixed, factorize=SequentialCholesky,
                                   max_modes=FLOATING_MODES_MAX)
            _check_mode_count(mesh.body_names[b], rb.shape[1], disc.label)
            labels = [f"zero-energy mode {i + 1}" for i in range(rb.shape[1])]
            coef = np.full((3, rb.shape[1]), np.nan)
            if rb.shape[1] == 0:
                continue
        dofs = np.stack([2 * nodes, 2 * nodes + 1], axis=1).ravel()
        # the pins of the bodies before count as fixed (their contact rows' DOFs are no
        # longer free)
        pins.append(_pins(rb, dofs, contact, np.concatenate([fixed, *pins])))
        full = np.zeros((2 * mesh.n_nodes, rb.shape[1]))
        full[dofs] = rb
        cols.append(full)
        names += [f"{mesh.body_names[b]}: {t}" for t in labels]
        bodies += [mesh.body_names[b]] * rb.shape[1]
        rigid.append(coef)
        centres += [centroid] * rb.shape[1]
    if not cols:
        return None
    return FloatingModes(np.hstack(cols), np.concatenate(pins).astype(np.int64), names,
                         bodies, np.hstack(rigid), np.array(centres))


FLOATING_MODES_MAX = 32
"""Zero-energy modes (rigid and hourglass) a body held only by contact may have. More is a
mesh that CS-FEM-1SD leaves without stiffness, a strip one element thick (n x 1 elements:
n + 4 modes), and the LCP then fails or runs for ever: multibody.toml's block1 as a strip
of [10,1] (14 modes) completes; [20,1], [30,1], [50,1], [150,1] stop with Lemke
'inaccurate' (step 1), [300,1] at step 2 after 6910 pivots, [600,1] ran past 900 s."""


def _check_mode_count(name: str, count: int, label: str) -> None:
    """One line naming the body when it has more than FLOATING_MODES_MAX modes (count: the
    modes found, all of them or, when the eigen-solve stopped early, more than the most)."""
    if count > FLOATING_MODES_MAX:
        raise SolveError(
            f"body '{name}' has more than {FLOATING_MODES_MAX} zero-energy modes (at least "
            f"{count}) under {label}, held only by contact: its mesh has hourglass modes "
            "of nearly every element (one element thick?); use --sd 2 or more "
            "(hourglass-free smoothing), --method fem-q4 or a mesh at least two elements "
            "thick")


PIN_RANK_REL = 1e-6
"""Off-contact DOFs pin a body's modes when the last pivot of their QR factorization is
above this x the first (else every DOF of the body is a candidate)."""


PIN_ROUND_OFF = 1e-12
"""Entries of a contact row below this x its largest are round-off (a weight of ~1e-17 on
a node the projection does not reach), not a DOF that gives the pair a compliance."""


def _pins(rb: np.ndarray, dofs: np.ndarray, contact: ContactSetup | None,
          fixed: np.ndarray | None = None) -> np.ndarray:
    """DOFs (r,) of a body (its DOFs `dofs`, its modes rb (len(dofs), r)) that pin the
    modes: chosen by QR with column pivoting (well spread), among the DOFs that no contact
    row touches when they pin every mode; else among the DOFs whose contact rows all keep
    a DOF off the body and off the supports and earlier pins `fixed` (a pin there leaves
    every pair a compliance) and that leave the contact rows as independent as they were
    (not `_rank_keepers`); else among the latter alone; else among all. A pin on a pair's
    node gave that pair a zero compliance, whose motion came from the modes alone: the
    stiff tie of `_fixed_pairs` (1e-12 of the largest compliance) on it then acted as a
    penalty: q of an interface 1e11 times stiffer than another was 18% off
    (configs/hard/tangential_contrast.toml; 0.19% at 1e9, 40% at 1e12); with the core one
    element thick (--mesh-size 0.5, every DOF of the core a contact DOF), p 3% and q 10%
    off at 1e11. Pins on the slave nodes of a bond whose master is coarser left its rows
    dependent (C singular, the null-space tie of `app.lcp.coulomb_matrix` on them, 1e12 in
    the modes' block): Lemke failed (configs/multibody.toml --sd 1 --mesh-size 0.8)."""
    r = rb.shape[1]
    if contact is not None and r:
        g = contact.g.tocsr()
        for allowed in _pin_candidates(g, dofs, fixed):
            if allowed.sum() >= r:
                piv, d = pivot_rows(rb[allowed])
                if d[r - 1] > PIN_RANK_REL * d[0]:
                    return dofs[allowed][piv]
    return dofs[pivot_rows(rb)[0]]


PIVOT_TIE = 1e-6
"""Rows whose remaining norm is within this fraction of the largest tie in `pivot_rows`."""


def pivot_rows(a: np.ndarray, stop: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Rows (r,) of a (k, r) chosen as QR with column pivoting of a.T chooses them, and
    their remaining norms (r,), with ties (within PIVOT_TIE) going to the lowest row: a
    mirror-symmetric mesh has rows of equal norm, which LAPACK's pivoting separated by
    round-off, so the pins (and the amplitudes `rigid_modes`) differed between 1 and 2
    ranks (hard/floating_gravity.toml --sd 1: DOFs 727, 728 against 710, 781). The one
    pivot rule of this module (`_pins` and `_rank_keepers`). Ends early once the largest
    remaining norm is at most `stop` (a rank test): the entries left are then 0 in d."""
    res = np.array(a, dtype=float)
    r = a.shape[1]
    piv, d = np.zeros(r, dtype=np.int64), np.zeros(r)
    for j in range(min(r, a.shape[0])):  # each step O(k r): vectorised over the rows
        norms = np.linalg.norm(res, axis=1)
        i = int(np.argmax(norms >= (1.0 - PIVOT_TIE) * norms.max()))
        if norms[i] <= stop or norms[i] == 0.0:
            break
        piv[j], d[j] = i, norms[i]
        q = res[i] / norms[i]
        res -= np.outer(res @ q, q)
    return piv, d


def _pin_candidates(g: sp.csr_matrix, dofs: np.ndarray, fixed: np.ndarray | None):
    """The candidate masks of `_pins` in turn ((len(dofs),) bool each), each computed
    only when the one before cannot pin the modes (the rank test is dense)."""
    yield ~np.isin(dofs, g.indices)
    safe = _pin_safe(g, dofs, fixed)
    free = ~_rank_keepers(g, dofs, fixed, safe)
    yield safe & free
    yield free


def _pin_safe(g: sp.csr_matrix, dofs: np.ndarray, fixed: np.ndarray | None) -> np.ndarray:
    """(len(dofs),) bool: the body's DOFs that no contact row (of g, (2m, 2n)) confined to
    the body's DOFs and the supports `fixed` touches: every row with an entry on such a
    DOF also has one (above PIN_ROUND_OFF of its largest) on a free DOF elsewhere, which
    keeps it a compliance whatever DOFs of the body are pinned."""
    elsewhere = np.ones(g.shape[1], dtype=bool)
    elsewhere[dofs] = False
    if fixed is not None:
        elsewhere[fixed] = False
    rows = np.repeat(np.arange(g.shape[0]), np.diff(g.indptr))
    size = np.abs(g.data)
    top = np.zeros(g.shape[0])
    np.maximum.at(top, rows, size)
    live = size > PIN_ROUND_OFF * top[rows]  # (a projection's round-off weights are not)
    keeps = np.bincount(rows[live], weights=elsewhere[g.indices[live]],
                        minlength=g.shape[0]) > 0
    return ~np.isin(dofs, g.indices[live & ~keeps[rows]])


RANK_REL = 1e-10
"""Singular values below this x the largest are round-off in `_rank_keepers` (the rows of
G scaled to a largest entry of 1)."""


def _live_rows(g: sp.csr_matrix) -> sp.csr_matrix:
    """g (2m, 2n) with each row scaled to a largest |entry| of 1 and its round-off entries
    (at most PIN_ROUND_OFF of the row's largest) dropped."""
    top = np.asarray(abs(g).max(axis=1).todense()).ravel()
    out = sps.diags(1.0 / np.maximum(top, 1e-300)) @ g
    out.data[np.abs(out.data) <= PIN_ROUND_OFF] = 0.0
    out.eliminate_zeros()
    return out.tocsr()


def _rank_keepers(g: sp.csr_matrix, dofs: np.ndarray, fixed: np.ndarray | None,
                  safe: np.ndarray) -> np.ndarray:
    """(len(dofs),) bool: DOFs of a body to leave unpinned so that the contact rows of g
    (2m, 2n) keep their rank on the free DOFs, as C = G K^-1 G^T keeps its rank. With E
    the rows of g on the free DOFs off the body (off `fixed`) and Y a basis of E's left
    null space, the DOFs whose columns of Y^T G_body span its range, taken first among the
    DOFs that are not `safe` (never pins): no combination of rows that moved a free DOF
    stops moving one when the other DOFs are pinned. The rows are those linked to the body
    through shared free DOFs (the others cannot cancel with them); dense on those rows.
    Pins on the slave nodes of a bond to a coarser master left its rows dependent."""
    live = _live_rows(g)
    on_body = np.zeros(g.shape[1], dtype=bool)
    on_body[dofs] = True
    off = ~on_body
    if fixed is not None:
        off[fixed] = False
    ge = live[:, np.flatnonzero(off)].tocsr()
    link = (abs(ge) @ abs(ge).T).tocsr()
    _, label = connected_components(link, directed=False)
    touch = np.diff(live[:, dofs].tocsr().indptr) > 0
    rows = np.flatnonzero(np.isin(label, label[touch]))
    keep = np.zeros(dofs.size, dtype=bool)
    if not touch.any():
        return keep
    e = ge[rows]
    e = e[:, np.flatnonzero(np.diff(e.tocsc().indptr) > 0)].toarray()
    b = live[rows][:, dofs].toarray()  # (rows, len(dofs))
    if e.shape[1]:
        u, sv, _ = np.linalg.svd(e, full_matrices=True)
        rank = int(np.sum(sv > RANK_REL * sv.max()))
        b = u[:, rank:].T @ b  # the row combinations that move no free DOF off the body
    top = float(np.abs(b).max(initial=0.0))
    for part in (~safe, safe):  # the unsafe DOFs first: they are no pins anyway
        idx = np.flatnonzero(part)
        if idx.size == 0 or not top > 0:
            continue
        rest = b[:, idx]
        kept = np.flatnonzero(keep)
        if kept.size:  # less what the columns kept so far span
            qk, rk = np.linalg.qr(b[:, kept])
            qk = qk[:, np.abs(np.diag(rk)) > RANK_REL * top]
            rest = rest - qk @ (qk.T @ rest)
        piv, d = pivot_rows(rest.T, stop=RANK_REL * top)  # ties to the lowest DOF
        keep[idx[piv[d > RANK_REL * top]]] = True
    return keep


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
        # a body linked to no other is left to floating_modes' own message (its modes)
        if len(members) > 1 and not supported.intersection(members):
            names = ", ".join(f"'{mesh.body_names[b]}'" for b in members)
            raise SolveError(f"bodies {names} are free to move together: no support holds "
                             "any of them; add a [[support]]")


def split_modes(n_modes: np.ndarray, t_modes: np.ndarray,
                rel: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal bases (r, r1), (r, r0) of the floating-mode amplitudes that move some
    pair ([N; T] v != 0) and of those that move none (see `undetermined_modes`)."""
    a = np.vstack([n_modes, t_modes])
    r = a.shape[1]
    if a.shape[0] == 0:
        return np.zeros((r, 0)), np.eye(r)
    _, sv, vt = np.linalg.svd(a, full_matrices=a.shape[0] < a.shape[1])  # vt: (r, r)
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
    _, sv, vt = np.linalg.svd(a, full_matrices=a.shape[0] < a.shape[1])  # vt: (r, r)
    sv = np.concatenate([sv, np.zeros(vt.shape[0] - sv.size)])
    null = vt[sv <= rel * max(sv.max(initial=0.0), 1e-300)]
    return [names[int(np.argmax(np.abs(v)))] for v in null]
