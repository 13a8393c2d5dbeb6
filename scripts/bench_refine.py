"""Benchmark: a fine Hertz level built by uniform splitting (gmsh meshes level 0 only)
against the same level meshed directly by gmsh. One JSON line per run: DOFs, mesh seconds,
total seconds, the mesh share of the total and the errors against Hertz.

    .venv/bin/python scripts/bench_refine.py --mesh-size 0.0245 --splits 4 [--no-gmsh]

Split run: `run --mesh-size H*2^N --refine N`; gmsh run: `run --mesh-size H` (both have
the same element size everywhere, the contact refinement scaled alike).

Options the script does not know go to the app (e.g. `-ksp_type cg`); a run that fails
prints its row with `error` (the app's `error:` line) and the script exits 1.
"""

from __future__ import annotations

import argparse
import json

from app_runner import ROOT, run_app


def row(kind: str, args: list[str], s: dict) -> dict:
    if "error" in s:
        return {"kind": kind, "args": args, **s}
    t = s["timings"]
    hz = s["reference"]["hertz"]
    return {
        "kind": kind, "args": " ".join(args), "method": s["label"], "n_dofs": s["n_dofs"],
        "n_elements": s["n_elements"], "n_pairs": s["n_pairs"],
        "t_mesh_s": round(t["mesh"], 3), "t_total_s": round(t["total"], 3),
        "mesh_share": round(t["mesh"] / t["total"], 4),
        "timings_s": {k: round(v, 3) for k, v in t.items()},
        **{k: round(hz[k], 6) for k in ("p_max_rel_error", "half_width_rel_error",
                                        "pressure_l2_rel_error",
                                        "pressure_l2_interp_rel_error")},
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default=str(ROOT / "configs" / "hertz.toml"))
    ap.add_argument("--mesh-size", type=float, default=0.0245,
                    help="element size of the fine level (hertz.toml: 0.0245 = 1.12M DOFs)")
    ap.add_argument("--splits", type=int, default=4)
    ap.add_argument("--no-gmsh", action="store_true", help="skip the direct gmsh run")
    ap.add_argument("--ranks", type=int, default=1)
    args, extra = ap.parse_known_args()
    h0 = args.mesh_size * 2**args.splits
    split = ["--mesh-size", f"{h0:.6g}", "--refine", str(args.splits), *extra]
    rows = [row("split", split, run_app(args.config, split, args.ranks))]
    print(json.dumps(rows[-1]), flush=True)
    if not args.no_gmsh:
        direct = ["--mesh-size", f"{args.mesh_size:.6g}", *extra]
        rows.append(row("gmsh", direct, run_app(args.config, direct, args.ranks)))
        print(json.dumps(rows[-1]), flush=True)
    raise SystemExit(1 if any("error" in r for r in rows) else 0)


if __name__ == "__main__":
    main()
