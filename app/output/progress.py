"""One progress line per load step and one closing line per run (stderr, rank 0)."""

from __future__ import annotations

import math


def _g(v: float) -> str:
    return f"{v:.4g}"


def step_line(step_info: dict, n_steps: int, prefix: str = "") -> str:
    """'step k/N: energy E; stick 3 slip+ 1 open 5; interface I F=(Fx, Fy) max p P; ...'"""
    parts = [f"{prefix}step {step_info['step']}/{n_steps}",
             f"energy {_g(step_info.get('strain_energy', math.nan))}"]
    states = step_info.get("states")
    if states:
        parts.append(" ".join(f"{k} {v}" for k, v in states.items() if v))
    for name, itf in (step_info.get("interfaces") or {}).items():
        f = itf.get("force")
        force = f"F=({_g(f[0])}, {_g(f[1])})" if f else \
            f"N={_g(itf.get('normal_force', 0.0))}"
        parts.append(f"{name} {force} max p {_g(itf.get('max_pressure', 0.0))}")
    bal = step_info.get("balance")
    if bal:
        parts.append(f"balance {bal['max_relative_residual']:.1e}")
    return "; ".join(parts)


def reference_errors(summary: dict) -> list[str]:
    """'name rel.err' for every *_rel_error of the reference, nested one level."""
    ref = summary.get("reference") or {}
    out = []
    for key, v in ref.items():
        if isinstance(v, dict):
            out += [f"{key}.{k[:-10]} {x:.3e}" for k, x in v.items()
                    if k.endswith("_rel_error") and isinstance(x, float)]
        elif key.endswith("_rel_error") and isinstance(v, float):
            out.append(f"{key[:-10]} {v:.3e}")
    return out


def final_line(summary: dict, out) -> str:
    """The run's closing line: status, steps done, energy, errors against the reference."""
    steps = summary.get("steps", [])
    n = summary.get("n_steps", len(steps))
    parts = [f"{summary.get('label') or 'run'}: {summary.get('status')}",
             f"{len(steps)}/{n} steps"]
    if "n_dofs" in summary:
        parts.append(f"{summary['n_dofs']} DOFs")
    if "strain_energy" in summary:
        parts.append(f"strain energy {summary['strain_energy']:.10g}")
    errs = reference_errors(summary)
    if errs:
        parts.append("rel. errors: " + ", ".join(errs))
    total = (summary.get("timings") or {}).get("total")
    if total is not None:
        parts.append(f"total {total:.2f} s")
    return ", ".join(parts) + f" -> {out}"
