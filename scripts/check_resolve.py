"""Random small contact LCPs through the re-solve on pair states (`ContactLCP._polished`).

    PYTHONPATH=. .venv/bin/python scripts/check_resolve.py                # 3000 cases
    PYTHONPATH=. .venv/bin/python scripts/check_resolve.py --out new.json
    git show 745aeb1:app/interface/coulomb.py > /tmp/old_coulomb.py
    PYTHONPATH=. .venv/bin/python scripts/check_resolve.py --coulomb /tmp/old_coulomb.py \\
        --out old.json
    PYTHONPATH=. .venv/bin/python scripts/check_resolve.py --compare old.json new.json
    PYTHONPATH=. .venv/bin/python scripts/check_resolve.py --modes 1  # a floating mode

Cases (seeded, one in three of each kind): a compliance C = A A^T + d I (2m x 2m, A
normal, d in [0, 0.5]) on m = 2..6 pairs, some with a bond (a >= 0, c = max(mu, 1) a: c >=
mu a, as app/config.py requires, else a slipping pair's bound c + mu p can be < 0), 80%
frictional (mu in [0.1, 2]); m = 2..4 frictional, no bond; m = 2..4 frictionless (C_nt = 0). Free
gaps and tangential motion normal; the start is a random LCP basis (what Lemke hands the
re-solve is near the answer; a random one is the hard case). --modes R adds R floating
modes to every case (free columns: gap += N alpha, tau += T alpha, balance e0 + N^T p + T^T
q = 0; N in [0.5, 1.5] (R = 1; of random sign for R > 1), T 0.3 x normal (0 frictionless),
e0 -[0.5, 3] x m, and a random alpha+- basis; drawn from a second generator, so the
cases' C, gaps and bases are those without modes). Per case: settled (the states
and p, q) or not, the dense solves (`ContactLCP._on_states`) it took, and how far a settled
answer is from solving the LCP, judged from C alone (`law_error`). Prints one JSON line
{"cases", "settled", "settled_by_kind", "invalid", "solves_max", "solves_total"}; --compare
prints the cases that settle in one file only, and those whose states or forces differ.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import sys
from collections.abc import Iterator
from types import ModuleType
from typing import NoReturn

import numpy as np

KINDS = ("mixed", "frictional", "frictionless")
LAW_TOL = 1e-9
"""A settled answer whose `law_error` is above this does not solve the LCP (`invalid`)."""


def cases(n: int, seed: int, modes: int = 0) -> Iterator[tuple[str, dict]]:
    """(kind, data) of n random LCPs: c (2m, 2m), mu (m,), fr, gap_free, dtau, a, coh (m,)
    and an LCP basis (3m frictional, m frictionless, + 2 modes) bool; with modes r > 0 the
    mode couplings nm, tm (m, r) and load e0 (r,) (module docstring), else nm, tm None and
    e0 (0,)."""
    rng = np.random.default_rng(seed)
    mode_rng = np.random.default_rng([seed, 1])
    for trial in range(n):
        kind = KINDS[trial % 3]
        m = int(rng.integers(2, 7)) if kind == "mixed" else int(rng.integers(2, 5))
        fr = bool(rng.random() < 0.8) if kind == "mixed" else kind == "frictional"
        g = rng.normal(size=(2 * m, 2 * m))
        c = g @ g.T + rng.uniform(0, 0.5) * np.eye(2 * m)
        if not fr:
            c[:m, m:] = 0.0
            c[m:, :m] = 0.0
        mu = np.full(m, rng.uniform(0.1, 2.0) if fr else 0.0)
        gap_free = rng.normal(size=m)
        dtau = rng.normal(size=m) if fr else np.zeros(m)
        a = np.abs(rng.normal(size=m)) * (kind == "mixed" and rng.random() < 0.3)
        basis = rng.random(3 * m if fr else m) < 0.5
        nm = tm = None
        e0 = np.zeros(0)
        if modes:
            sign = 1.0 if modes == 1 else mode_rng.choice([-1.0, 1.0], size=(m, modes))
            nm = mode_rng.uniform(0.5, 1.5, size=(m, modes)) * sign
            tm = 0.3 * mode_rng.normal(size=(m, modes)) * fr
            e0 = -mode_rng.uniform(0.5, 3.0, size=modes) * m
            basis = np.concatenate([basis, mode_rng.random(2 * modes) < 0.5])
        yield kind, dict(c=c, mu=mu, fr=fr, gap_free=gap_free, dtau=dtau, a=a,
                         coh=a * np.maximum(mu, 1.0) * (mu > 0), basis=basis, nm=nm,
                         tm=tm, e0=e0)


def law_error(d: dict, p: np.ndarray, q: np.ndarray,
              alpha: np.ndarray | None = None) -> float:
    """The largest violation of the interface law by forces p, q (m,) and mode amplitudes
    alpha (r,) (None: no modes) on case d, from C alone (not `ContactLCP._basis_errors`),
    over the case's scale (largest |C| |lam| plus the largest free motion, modes' motion,
    e0, a and 1): p + a >= 0, gap >= 0, min(p + a, gap) = 0; friction bound F = c + mu p
    >= 0 and |q| <= F; a pair that slides, |slip| above 1e-9 of the scale (slip = C_t lam
    + T alpha - dtau = tau - tau_prev), at q = -sign(slip) F; q = 0 without friction; with
    modes the balance e0 + N^T p + T^T q = 0."""
    c, m, a, mu = d["c"], p.size, d["a"], d["mu"]
    lam = np.concatenate([p, q])
    gap = d["gap_free"] + c[:m] @ lam
    slip = c[m:] @ lam - d["dtau"]
    scale = (np.abs(c).max() * np.abs(lam).max() + np.abs(d["gap_free"]).max()
             + np.abs(d["dtau"]).max() + np.abs(a).max() + 1.0)
    errs = [np.zeros(1)]
    if d.get("nm") is not None and alpha is not None:
        gap = gap + d["nm"] @ alpha
        slip = slip + d["tm"] @ alpha
        scale += (np.abs(d["nm"]).max() + np.abs(d["tm"]).max()) * np.abs(alpha).max() \
            + np.abs(d["e0"]).max()
        errs.append(np.abs(d["e0"] + d["nm"].T @ p + d["tm"].T @ q))
    errs += [-(p + a), -gap, np.abs(np.minimum(p + a, gap))]
    if d["fr"]:
        bound = d["coh"] + mu * p
        slides = np.abs(slip) > 1e-9 * scale
        errs += [-bound, np.abs(q) - bound,
                 np.where(slides, np.abs(q + np.sign(slip) * bound), 0.0)]
    else:
        errs.append(np.abs(q))
    return float(max(0.0, *(e.max() for e in errs))) / scale


def fail(msg: str) -> NoReturn:
    """Bad input: one line `error: msg` on stderr, exit 2."""
    print(f"error: {msg}", file=sys.stderr)
    sys.exit(2)


def load(path: str | None) -> ModuleType:
    """app.interface.coulomb, or another version of it from a file."""
    if path is None:
        from app.interface import coulomb
        return coulomb
    spec = importlib.util.spec_from_file_location("app.interface.coulomb_checked", path)
    if not os.path.isfile(path) or spec is None or spec.loader is None:
        fail(f"--coulomb {path}: not a Python file (give a copy of app/interface/coulomb.py)")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def run(mod: ModuleType, n: int, seed: int, modes: int = 0) -> list[dict]:
    """One record per case: kind, settled, solves, and the states and p, q when settled."""
    solves = [0]
    on_states = mod.ContactLCP._on_states

    def counted(self, *args, **kw):
        solves[0] += 1
        return on_states(self, *args, **kw)

    mod.ContactLCP._on_states = counted
    out = []
    for kind, d in cases(n, seed, modes):
        m = d["mu"].size
        lcp = mod.ContactLCP(d["c"], d["mu"], np.full(m, d["fr"]), d["nm"], d["tm"],
                             cache=False)
        solves[0] = 0
        got = lcp._polished(d["basis"], (d["gap_free"], d["dtau"]), d["a"], d["coh"],
                            d["mu"], d["e0"])
        rec = {"kind": kind, "settled": got is not None, "solves": solves[0]}
        if got is not None:
            rec.update(p=got[0].tolist(), q=got[1].tolist(),
                       states=[np.asarray(s, int).tolist() for s in got[3:]],
                       law_error=law_error(d, got[0], got[1], got[2]))
        out.append(rec)
    mod.ContactLCP._on_states = on_states
    return out


def summary(recs: list[dict]) -> dict:
    """The counts of one run."""
    return {"cases": len(recs), "settled": sum(r["settled"] for r in recs),
            "settled_by_kind": {k: [sum(r["settled"] for r in recs if r["kind"] == k),
                                    sum(r["kind"] == k for r in recs)] for k in KINDS},
            "invalid": int(sum(r.get("law_error", 0.0) > LAW_TOL for r in recs)),
            "solves_max": max((r["solves"] for r in recs), default=0),
            "solves_total": sum(r["solves"] for r in recs)}


def compare(a: list[dict], b: list[dict]) -> dict:
    """Cases settled in a only, in b only, and settled in both with other states or p, q."""
    pairs = list(enumerate(zip(a, b, strict=True)))
    only_a = [i for i, (x, y) in pairs if x["settled"] and not y["settled"]]
    only_b = [i for i, (x, y) in pairs if y["settled"] and not x["settled"]]
    differ = [i for i, (x, y) in pairs if x["settled"] and y["settled"]
              and any(x[k] != y[k] for k in ("states", "p", "q"))]
    return {"settled_first_only": only_a, "settled_second_only": only_b,
            "differ": differ, "first": summary(a), "second": summary(b)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=3000)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--modes", type=int, default=0,
                    help="floating modes added to every case (free columns; default 0)")
    ap.add_argument("--coulomb", help="another version of app/interface/coulomb.py")
    ap.add_argument("--out", help="write every case's record (JSON) here")
    ap.add_argument("--compare", nargs=2, metavar=("FIRST", "SECOND"),
                    help="compare two --out files instead of running")
    args = ap.parse_args()
    if args.compare:
        recs = []
        for f in args.compare:
            try:
                with open(f) as fh:
                    recs.append(json.load(fh))
            except (OSError, ValueError) as exc:
                fail(f"--compare {f}: not a JSON file of --out ({exc})")
        if len(recs[0]) != len(recs[1]):
            fail(f"--compare: {len(recs[0])} cases against {len(recs[1])}: run both with the "
                 "same --cases and --seed")
        print(json.dumps(compare(*recs)))
        return
    if args.cases < 1:
        fail(f"--cases {args.cases}: give at least 1")
    if args.modes < 0:
        fail(f"--modes {args.modes}: give 0 or more")
    recs = run(load(args.coulomb), args.cases, args.seed, args.modes)
    if args.out:
        with open(args.out, "w") as fh:
            json.dump(recs, fh)
    print(json.dumps(summary(recs)))


if __name__ == "__main__":
    main()
