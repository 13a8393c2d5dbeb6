"""A warning when a step's answer breaks the interface law (summary `steps[k].kkt`).

The KKT figures are recomputed from the written displacement field; on every scene of
configs/ and configs/hard/ they stay below 1e-7. A larger one means the contact forces
and the displacements do not answer the LCP, e.g. an LCP answer accepted by a faulty
check (a warm-started step of a floating body penetrated by 5e-4 of max |u|, its kkt gap
5.4e-3, and the run completed without a word).
"""

from __future__ import annotations

KKT_WARN = 1e-6
"""Largest KKT figure that passes without a warning."""


def kkt_warning(kkt: dict[str, float], step: int) -> str | None:
    """The warning text for a step's `kkt` figures (step 1-based), or None when every
    figure is at most KKT_WARN."""
    bad = {k: v for k, v in kkt.items() if not v <= KKT_WARN}  # (NaN warns too)
    if not bad:
        return None
    worst = ", ".join(f"{k} {v:.3g}" for k, v in bad.items())
    return (f"step {step}: the contact answer breaks the interface law ({worst}, relative; "
            f"at most {KKT_WARN:g} expected): the forces and displacements written do not "
            "solve the contact problem; try --set analysis.warm_start=false and report it")
