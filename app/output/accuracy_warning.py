"""A warning when round-off limits a step's contact answer (summary `steps[k].lcp_accuracy`).

`lcp_accuracy` is eps x LAPACK's 1-norm condition estimate of the system that fixes the
contact forces on the step's final pair states (`app.interface.coulomb.ContactLCP.
_accuracy`): how far round-off in the compliance C and in the solve may move p, q and the
mode amplitudes, relative to the largest. It grows with the stiffness contrast between
bodies in contact (cond ~ 34 x the contrast on two_blocks.toml: a stiff body's share of C is
round-off beside the soft one's), which neither `kkt` nor `kkt_pairs` sees: they read the
solved system's residual, not the round-off of C itself (README "Hard cases").
"""

from __future__ import annotations

from dataclasses import dataclass

ACCURACY_WARN = 1e-4
"""Largest `lcp_accuracy` that passes without a warning. The figure is an upper estimate:
on the sweep of README "Hard cases" the forces were 5 to 70 times closer to the stiffer
runs' than it says; 1e-4 is 100 x the KKT figures' own floors (`KKT_WARN`, `PAIR_WARN`,
1e-6) and above every shipped scene's largest (README "Hard cases")."""

FROM_CONTRAST = 1e4
"""A stiffness contrast across an interface from which the warning names it as the cause
(cond ~ 34 x the contrast: eps x 34e4 = 8e-11, far below ACCURACY_WARN)."""


@dataclass
class Contrast:
    """An interface's bodies: the stiffer (its name and Young's modulus) and the softer."""

    interface: str
    stiff: str
    stiff_e: float
    soft: str
    soft_e: float

    @property
    def ratio(self) -> float:
        return self.stiff_e / self.soft_e if self.soft_e > 0 else float("inf")


def accuracy_warning(accuracy: float, step: int, contrasts: list[Contrast]) -> str | None:
    """The warning text for a step's `lcp_accuracy` (step 1-based), or None when it is at
    most ACCURACY_WARN; contrasts: one per interface, the largest ratio named as the cause
    when it is at least FROM_CONTRAST."""
    if accuracy <= ACCURACY_WARN:  # (NaN warns too)
        return None
    head = (f"step {step}: round-off limits the contact answer: its forces may be off by "
            f"up to {accuracy:.2g} of the largest (`lcp_accuracy`, eps x the condition "
            f"estimate of the pair states' system; at most {ACCURACY_WARN:g} expected), "
            "though the law checks pass; ")
    if accuracy >= 1.0:  # singular: not a bound on an error, the forces are not unique
        head = (f"step {step}: the pair states' system does not fix the contact forces "
                "(singular to round-off, `lcp_accuracy` 1: its null space is neither a "
                "floating mode's amplitude nor a split between alike pairs): a family of "
                "forces solves the step and the written ones are one of them, though the "
                "law checks pass; ")
    worst = max(contrasts, key=lambda c: c.ratio, default=None)
    if worst is None or not worst.ratio >= FROM_CONTRAST:
        return head + ("the cause is not a stiffness contrast between bodies in contact: "
                       "check for nearly coincident contact pairs or for floating bodies "
                       "held by few pairs")
    return head + (f"the cause is the stiffness contrast {worst.ratio:.3g} between bodies "
                   f"'{worst.stiff}' (E = {worst.stiff_e:g}) and '{worst.soft}' (E = "
                   f"{worst.soft_e:g}) at interface '{worst.interface}': the stiff body's "
                   "compliance is round-off beside the soft one's. Lower its E: at a "
                   "contrast of 1e5 it is already rigid to about 3e-4 (README \"Hard "
                   "cases\"), and each decade of contrast less gains one of round-off accuracy")


def interface_contrasts(mesh, cfg) -> list[Contrast]:
    """One `Contrast` per interface of cfg (a Config), its bodies those of the first node
    of its slave and master curves in mesh (a Mesh)."""
    node_body = mesh.node_body()
    young = dict(zip(cfg.body_names, map(float, cfg.E), strict=True))
    out = []
    for itf in cfg.interfaces:
        names = [mesh.body_names[int(node_body[mesh.curves[curve][0, 0]])]
                 for curve in (itf.slave, itf.master)]
        stiff, soft = sorted(names, key=lambda b: -young[b])
        out.append(Contrast(itf.name, stiff, young[stiff], soft, young[soft]))
    return out
