"""Fine slave on a coarse master: smoothness of p and false debonding across size ratios.

The striping of a fine slave on a coarse master (README "Smoothed master") measured for
every discretisation over a range of master / slave element-size ratios, and the
multiplier spaces that were tried against it (README "Multiplier spaces on a coarse
master"). One JSON line per run:

- `indent`: configs/indent.toml (arc elements 0.018 as slave, or the block as slave) with
  the block's element size S: largest deviation of p from a local quadratic fit over the
  closed pairs (/ max p), the same two pairs in from each end ("inner"), max p, the
  contact force P, the number of closed pairs, and the largest difference from the
  answer with the block meshed at 0.02 (mortar, the block as slave), interpolated at the
  pairs, where that answer is above half its max p (/ its max p).
- `bond`: configs/multibody.toml with block1's element size S on the foundation (0.2),
  the bonded `bond` interface: bonded pairs left at the last step, and the fraction
  debonded (a smooth answer debonds none; README "A bond between a fine slave and a
  coarse master debonds falsely").
- `spaces`: the frictionless indent LCP (mu = 0, mortar rows, K and G built in-process
  through app/) with other multiplier spaces, p read at the arc's slave nodes:
  `dual` (one multiplier per slave node: `mortar`), `smooth-quadratic` (`mortar-smooth`'s
  rows), `smooth-cubic` (the same with a cubic B-spline master), `coarse-hat` and `coarse-bspline`
  (multipliers at the master nodes, lambda = D P Lambda with P the master's hat or
  quadratic B-spline functions at each slave node's closest master point; the LCP is
  P^T D C D P, complementarity per master node), and `lps-G` (one multiplier per slave
  node with the local projection stabilisation C + G c S: S penalises the part of the
  traction off the coarse-hat space, c the mean diagonal of C).

    .venv/bin/python scripts/bench_indent_ratio.py [--only indent bond spaces]
        [--block-sizes 0.144 0.12 ... 0.02] [--block1-sizes 0.1 ... 0.025]
        [--discretisations node-to-segment mortar mortar-smooth mortar-coarse-slave]
        [--gammas 1 10]
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterator

import numpy as np
import scipy.sparse as sp
from app_runner import ROOT, run_app

sys.path.insert(0, str(ROOT))
from app.contact.resolution import interior_deviation  # noqa: E402
from app.contact.smoothness import local_fit_deviation  # noqa: E402

ARC = 0.018
"""Element size of the arc under the contact in indent.toml (refine size 0.02, measured
median tributary length 0.018): the size ratio of a block of size S is S / ARC."""
REFERENCE_SIZE = 0.02
"""Block element size of the fine reference of the `indent` rows (1.1x the arc)."""
REFERENCE_CORE = 0.5
"""The `indent` rows compare with the reference where it is at least this x its max."""
FOUNDATION = 0.2
"""Element size of multibody's foundation (the bond's master as shipped)."""


def smoothness(x: np.ndarray, p: np.ndarray) -> dict:
    """Largest |p - local quadratic fit| / max p over the closed pairs (p > 0) and two pairs
    in from each end; max p; number of closed pairs (x, p: (m,) in any order)."""
    on = p > 0
    x, p = x[on], p[on]
    return {"n_closed": int(on.sum()),
            "max_fit_deviation": float(local_fit_deviation(x, p).max(initial=0.0)),
            "inner_fit_deviation": interior_deviation(np.column_stack([x, 0 * x]), p),
            "max_p": float(p.max(initial=0.0))}


def fine_reference() -> tuple[np.ndarray, np.ndarray]:
    """(x, p) (k,) of every pair of indent.toml with the block meshed at REFERENCE_SIZE
    (about the arc's size; mortar, open pairs included): the smooth answer the other rows
    are compared with. The block is the slave: its nodes are evenly spaced through the
    contact edges, where the arc's are graded (0.046 apart at x = 0.17 ... 0.216), so
    linear interpolation between them reads the concave profile low by up to 6% of max p
    there."""
    s = run_app("configs/indent.toml", ["--set", f"body.block.size={REFERENCE_SIZE}",
                                        "--set", 'interface.indent.discretisation="mortar"',
                                        "--set", 'interface.indent.slave="block_top"',
                                        "--set", 'interface.indent.master="cyl_arc"'],
                pairs=("x", "p"))
    c = s["last_step_pairs"]
    return c["x"], c["p"]


def reference_deviation(x: np.ndarray, p: np.ndarray, ref: tuple[np.ndarray, np.ndarray]
                        ) -> float:
    """Largest |p - p_ref(x)| / max p_ref over the pairs where p_ref(x) is at least
    REFERENCE_CORE x max p_ref, p_ref the fine reference (x_ref, p_ref) interpolated
    linearly: the bulk of the contact, leaving out its edges, where a coarse mesh places
    the last closed node within an element of the fine one's and the difference is the
    edge's position, not the tractions."""
    pr = np.interp(x, ref[0], ref[1], left=0.0, right=0.0)
    core = pr >= REFERENCE_CORE * ref[1].max()
    return float(np.abs(p[core] - pr[core]).max(initial=0.0) / ref[1].max())


def _set_args(body: str, size: float, interface: str, disc: str,
              sides: tuple[str, str]) -> list[str]:
    """`--set` options: the body's element size, the interface's discretisation and its
    (slave, master) curves."""
    return ["--set", f"body.{body}.size={size}",
            "--set", f'interface.{interface}.discretisation="{disc}"',
            "--set", f'interface.{interface}.slave="{sides[0]}"',
            "--set", f'interface.{interface}.master="{sides[1]}"']


def _indent_rows(a: argparse.Namespace) -> Iterator[dict]:
    """indent.toml per discretisation, side and block size."""
    ref = fine_reference()
    for disc in a.discretisations:
        for block_slave in (False, True):
            sides = ("block_top", "cyl_arc") if block_slave else ("cyl_arc", "block_top")
            for size in a.block_sizes:
                s = run_app("configs/indent.toml", _set_args("block", size, "indent", disc, sides),
                            pairs=("x", "p"))
                row = {"case": "indent", "discretisation": disc, "slave": sides[0],
                       "block_size": size, "ratio": round(size / ARC, 2),
                       "error": s.get("error")}
                if "last_step_pairs" in s:
                    c = s["last_step_pairs"]
                    row |= smoothness(c["x"], c["p"])
                    row["ref_deviation"] = reference_deviation(c["x"], c["p"], ref)
                    row["P"] = s["steps"][-1]["interfaces"]["indent"]["normal_force"]
                yield row


def _bond_rows(a: argparse.Namespace) -> Iterator[dict]:
    """multibody.toml's bonded `bond` per discretisation, side and block1 size."""
    for disc in a.discretisations:
        for swapped in (False, True):
            sides = ("foundation_top", "block1_bottom") if swapped else \
                ("block1_bottom", "foundation_top")
            for size in a.block1_sizes:
                s = run_app("configs/multibody.toml",
                            _set_args("block1", size, "bond", disc, sides),
                            pairs=("state", "debonded_step"))
                row = {"case": "bond", "discretisation": disc, "slave": sides[0],
                       "block1_size": size, "ratio": round(FOUNDATION / size, 2),
                       "error": s.get("error")}
                if "last_step_pairs" in s:
                    c = s["last_step_pairs"]
                    steps = c["debonded_step"][c["debonded_step"] > 0]
                    row |= {"pairs": int(c["state"].size),
                            "bonded": int((c["state"] == 0).sum()),
                            "debonded_fraction": float(steps.size / c["state"].size),
                            "first_debond_step": int(steps.min()) if steps.size else None}
                yield row


def coarse_basis(cols: np.ndarray, weights: np.ndarray, n_nodes: int
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Coarse multiplier functions at the slave nodes: P (m, k) with P[j, J] the value of
    master node J's function at slave node j, from cols (m, w) master node ids (-1: none)
    and weights (m, w) (rows summing to 1); returns P over the k master nodes that some
    slave node sees, and those node ids (k,)."""
    m = cols.shape[0]
    ok = cols >= 0
    p = sp.csr_matrix((weights[ok], (np.nonzero(ok)[0], cols[ok])), shape=(m, n_nodes))
    used = np.flatnonzero(np.asarray(abs(p).sum(axis=0)).ravel() > 0)
    return p.tocsc()[:, used].toarray(), used


def coarse_lcp(c_mat: np.ndarray, b: np.ndarray, d: np.ndarray,
               basis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The LCP of coarse multipliers Lambda (tractions at the master nodes) with the pair
    forces lambda = D P Lambda: (P^T D C D P, P^T D b). c_mat (m, m) compliance of the
    slave rows (length / force), b (m,) their free gaps (length), d (m,) D_j (length),
    basis P (m, k)."""
    dp = d[:, None] * basis
    return dp.T @ c_mat @ dp, dp.T @ b


def lps_matrix(d: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Local projection stabilisation (m, m) of pair forces lambda (m,): with tractions
    t = lambda / D and Pi the D-weighted least-squares projection onto span(basis),
    lambda^T S lambda = mean(D) sum_j D_j ((I - Pi) t)_j^2 (dimensionless; zero on coarse
    traction fields, positive semidefinite)."""
    w = np.diag(d)
    pi = basis @ np.linalg.pinv(basis.T @ w @ basis) @ basis.T @ w
    r = (np.eye(d.size) - pi) / d[None, :]
    return d.mean() * r.T @ w @ r


def quadratic_bspline_weights(eta: np.ndarray, has_prev: np.ndarray,
                              has_next: np.ndarray) -> np.ndarray:
    """Weights (4, p, g) on (prev, a, b, next) of the uniform quadratic B-spline at
    parameters eta (p, g) of segments [a, b] (has_prev, has_next (p,) bool), knots at the
    segments' midpoints; a missing neighbour is the reflection 2 x_a - x_b (2 x_b - x_a),
    folded into a and b (`mortar-smooth`'s first master, kept for `coarse-bspline`)."""
    left = eta < 0.5
    u = np.where(left, eta + 0.5, eta - 0.5)
    b0, b1, b2 = 0.5 * (1 - u) ** 2, 0.5 * (1 + 2 * u - 2 * u * u), 0.5 * u * u
    hp, hn = has_prev[:, None], has_next[:, None]
    zero = np.zeros_like(eta)
    w_a = np.where(left, b1 + np.where(hp, 0, 2 * b0), b0 - np.where(hn, 0, b2))
    w_b = np.where(left, b2 - np.where(hp, 0, b0), b1 + np.where(hn, 0, 2 * b2))
    return np.stack([np.where(left & hp, b0, zero), w_a, w_b, np.where(~left & hn, b2, zero)])


def cubic_weights(eta: np.ndarray, has_prev: np.ndarray, has_next: np.ndarray) -> np.ndarray:
    """Weights (4, p, g) on (prev, a, b, next) of the uniform cubic B-spline at parameters
    eta (p, g) of segments [a, b] (has_prev, has_next (p,) bool): C2, not interpolating
    the nodes, reproduces linear fields; a missing neighbour is the reflection 2 x_a - x_b
    (2 x_b - x_a), folded into a and b as in `quadratic_bspline_weights`."""
    t = eta
    b0, b3 = (1 - t) ** 3 / 6, t ** 3 / 6
    b1 = (3 * t ** 3 - 6 * t ** 2 + 4) / 6
    b2 = (-3 * t ** 3 + 3 * t ** 2 + 3 * t + 1) / 6
    hp, hn = has_prev[:, None], has_next[:, None]
    w_a = b1 + np.where(hp, 0, 2 * b0) - np.where(hn, 0, b3)
    w_b = b2 - np.where(hp, 0, b0) + np.where(hn, 0, 2 * b3)
    return np.stack([np.where(hp, b0, 0.0), w_a, w_b, np.where(hn, b3, 0.0)])


def cubic_master(pts: np.ndarray, m_edges: np.ndarray, facing: np.ndarray,
                 slave_length: np.ndarray):
    """`mortar-smooth`'s master basis with the cubic B-spline instead of the quadratic one
    (same switch: the master / slave size ratio above COARSE_RATIO)."""
    from app.contact.mortar import linear_master
    from app.contact.mortar_smooth import COARSE_RATIO, master_neighbours, master_slave_ratio

    if master_slave_ratio(pts, m_edges, facing, slave_length) <= COARSE_RATIO:
        return linear_master(pts, m_edges, facing, slave_length)
    prev, nxt = master_neighbours(pts, m_edges)
    nodes = np.column_stack([prev, m_edges[:, 0], m_edges[:, 1], nxt])

    def basis(f: np.ndarray, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return nodes[f], cubic_weights(eta, prev[f] >= 0, nxt[f] >= 0)

    basis.label = "cubic B-spline"
    return basis


def _indent_scene(size: float) -> dict:
    """The frictionless indent.toml scene with the block at `size`, in-process: mesh,
    config, the factorization of K on the free DOFs and the free displacement u0."""
    import scipy.sparse.linalg as spla

    from app.assembly.loads import constrained_dofs, load_cases
    from app.assembly.stiffness import assemble_stiffness
    from app.config import load_config
    from app.driver.context import RunOptions
    from app.driver.model import build_scene_mesh, make_discretisation

    cfg = load_config(ROOT / "configs/indent.toml",
                      [f"body.block.size={size}", "interface.indent.mu=0.0"])
    opts = RunOptions()
    mesh = build_scene_mesh(cfg, opts)
    ia, ja, va = assemble_stiffness(mesh, make_discretisation(cfg, opts)).getValuesCSR()
    k = sp.csr_matrix((va, ja, ia), shape=(2 * mesh.n_nodes,) * 2)
    fixed = constrained_dofs(mesh, cfg)
    free = np.setdiff1d(np.arange(k.shape[0]), fixed)
    ud = sum(c.prescribed * c.history[-1] for c in load_cases(mesh, cfg))
    lu = spla.splu(k[free][:, free].tocsc())
    u0 = ud.copy()
    u0[free] = lu.solve(-(k[free][:, fixed] @ ud[fixed]))
    return {"mesh": mesh, "cfg": cfg, "lu": lu, "free": free, "u0": u0}


def _indent_lcp(scene: dict, master_basis=None) -> dict:
    """Mortar rows of the scene (master_basis as app.contact.mortar.mortar_constraints):
    the pairs, the compliance C (m, m) of the normal rows and their free gaps b (m,)."""
    from app.contact.mortar import mortar_constraints

    mesh, free = scene["mesh"], scene["free"]
    rows = mortar_constraints(mesh, scene["cfg"].interfaces[0], 0, master_basis=master_basis)
    gn = rows.matrix(mesh.n_nodes)[: rows.n_pairs].tocsc()
    c_mat = gn[:, free] @ scene["lu"].solve(gn[:, free].T.toarray())
    return scene | {"pairs": rows.pairs, "C": np.asarray(c_mat),
                    "b": rows.pairs.g0 + gn @ scene["u0"]}


def _master_bases(scene: dict) -> dict[str, np.ndarray]:
    """Coarse-hat and coarse-bspline P (m, k) at the slave nodes' closest master points."""
    from app.contact.mortar import _interface_edges
    from app.contact.mortar_smooth import master_neighbours

    mesh, pr = scene["mesh"], scene["pairs"]
    pts = np.asarray(mesh.points, float)
    _, m_edges, _ = _interface_edges(mesh, scene["cfg"].interfaces[0], pts)
    seg = {(int(a), int(b)): i for i, (a, b) in enumerate(m_edges)}
    f = np.array([seg[(int(a), int(b))] for a, b in pr.master])
    prev, nxt = master_neighbours(pts, m_edges)
    spline = quadratic_bspline_weights(pr.xi[:, None], prev[f] >= 0, nxt[f] >= 0)[:, :, 0].T
    quad = np.column_stack([prev[f], m_edges[f, 0], m_edges[f, 1], nxt[f]])
    hat = np.column_stack([1 - pr.xi, pr.xi])
    n = mesh.n_nodes
    return {"coarse-hat": coarse_basis(pr.master, hat, n)[0],
            "coarse-bspline": coarse_basis(quad, spline, n)[0]}


def _solve(c_mat: np.ndarray, b: np.ndarray) -> np.ndarray:
    from app.lcp.lemke import lemke

    res = lemke(c_mat, b)
    if res.status != "solved":
        raise RuntimeError(f"lemke: {res.status}")
    return res.z


def _spaces_rows(a: argparse.Namespace) -> Iterator[dict]:
    """The frictionless indent LCP with each multiplier space and smoothed master, per
    block size."""
    from app.contact.mortar_smooth import smooth_master

    for size in a.block_sizes:
        scene = _indent_scene(size)
        lcp = _indent_lcp(scene)
        pr, c_mat, b = lcp["pairs"], lcp["C"], lcp["b"]
        d, x = pr.length, pr.position[:, 0]
        out = {"dual": (x, d, _solve(c_mat, b) / d)}  # name: (x, D, p), each (m,)
        for name, factory in (("smooth-quadratic", smooth_master),
                              ("smooth-cubic", cubic_master)):
            o = _indent_lcp(scene, factory)
            od = o["pairs"].length
            out[name] = (o["pairs"].position[:, 0], od, _solve(o["C"], o["b"]) / od)
        bases = _master_bases(lcp)
        for name, basis in bases.items():
            out[name] = (x, d, basis @ _solve(*coarse_lcp(c_mat, b, d, basis)))
        stab = lps_matrix(d, bases["coarse-hat"]) * np.diag(c_mat).mean()
        for g in a.gammas:
            out[f"lps-{g:g}"] = (x, d, _solve(c_mat + g * stab, b) / d)
        for name, (xs, ds, p) in out.items():
            yield {"case": "spaces", "space": name, "block_size": size,
                   "ratio": round(size / ARC, 2), "P": float(p @ ds)} | smoothness(xs, p)


CASES = {"indent": _indent_rows, "bond": _bond_rows, "spaces": _spaces_rows}


def _arguments(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="+", choices=list(CASES), default=list(CASES))
    ap.add_argument("--block-sizes", type=float, nargs="+",
                    default=[0.144, 0.12, 0.1, 0.09, 0.08, 0.07, 0.06, 0.05, 0.04, 0.035,
                             0.03, 0.025, 0.02])
    ap.add_argument("--block1-sizes", type=float, nargs="+",
                    default=[0.1, 0.05, 0.04, 0.0333, 0.025])
    ap.add_argument("--discretisations", nargs="+",
                    default=["node-to-segment", "mortar", "mortar-smooth",
                             "mortar-coarse-slave"])
    ap.add_argument("--gammas", type=float, nargs="+", default=[1.0, 10.0],
                    help="LPS weights of the `spaces` rows (x mean diagonal of C)")
    return ap.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    a = _arguments(argv)
    for case in a.only:
        for row in CASES[case](a):
            print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
