"""Where a `mortar-smooth` contact reaches an end or a corner of its smoothed master.

At a master curve's end (or a corner sharper than MAX_KINK_DEG) the quadratic B-spline of
`mortar-smooth` (app/contact/mortar_smooth.py) gives the master nodes other shares of a
uniform traction than the element does (13/24 and 23/24 of a segment for 1/2 and 1 at an
end), so the non-matching patch test fails there, and the error spreads over a few
master elements. Measured on configs/two_blocks.toml with the fine lower block as slave
(`--set 'body.lower.shape.divisions=[NX,8]' --set 'body.upper.shape.divisions=[8,4]'`,
master elements 10x / 50x the slave's): max |p - 10| / 10 = 17% / 55% (mortar: 1.3e-12 /
2.6e-11), 60 of 81 / 312 of 401 pairs off by more than 0.1%, and no warning: the
stripe check (app/contact/resolution.py) leaves the pairs at a zone's edges out, and
the error inside is smooth. A step's check: a closed pair whose closest master segment
touches such an end or corner node.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from app.contact.mortar_smooth import master_neighbours
from app.contact.pairs import ContactPairs, _curve_edges
from app.contact.resolution import CLOSED_REL
from app.mesh.model import Mesh, orient_boundary_edges

SMOOTHED = "quadratic B-spline"
"""`master_interpolation` of an interface whose master mortar-smooth smoothed."""


def unsmoothed_nodes(mesh: Mesh, master: str, label: str) -> tuple[np.ndarray, np.ndarray]:
    """The master curve's nodes where the B-spline falls back to the linear half segment:
    (ends, corners), node ids (k,) each."""
    pts = np.asarray(mesh.points, dtype=float)
    m_edges = orient_boundary_edges(mesh, _curve_edges(mesh, master, "master", label),
                                    f"interface '{label}': master curve '{master}'")
    prev, nxt = master_neighbours(pts, m_edges)
    cut = np.unique(np.concatenate([m_edges[prev < 0, 0], m_edges[nxt < 0, 1]]))
    count = np.bincount(m_edges.ravel(), minlength=pts.shape[0])
    return cut[count[cut] == 1], cut[count[cut] > 1]


def smooth_end_checks(mesh: Mesh, pairs: ContactPairs, normal_force: np.ndarray,
                      interfaces: Sequence, described: dict, force_scale: float
                      ) -> list[dict]:
    """Per smoothed interface (described[name]["master_interpolation"] == SMOOTHED) whose
    closed pairs (normal_force (m,) above CLOSED_REL x force_scale) face a master segment
    at an end or corner of the master curve: {interface, master, where ("an end" or "a
    corner"), at (x, y) of the first such slave node, pairs (their count)}."""
    out = []
    if not force_scale > 0:
        return out
    for i, itf in enumerate(interfaces):
        if described.get(itf.name, {}).get("master_interpolation") != SMOOTHED:
            continue
        sel = (pairs.interface == i) & (normal_force > CLOSED_REL * force_scale)
        if not sel.any():
            continue
        ends, corners = unsmoothed_nodes(mesh, itf.master, itf.name)
        seg = pairs.master[sel]
        at_end = np.isin(seg, ends).any(axis=1)
        at_corner = np.isin(seg, corners).any(axis=1) & ~at_end
        hit = at_end | at_corner
        if not hit.any():
            continue
        first = int(np.flatnonzero(hit)[0])
        out.append({"interface": itf.name, "master": itf.master,
                    "where": "an end" if at_end.any() else "a corner",
                    "at": tuple(float(v) for v in pairs.position[sel][first]),
                    "pairs": int(hit.sum())})
    return out


def smooth_end_warning(check: dict, step: int) -> str:
    """The one-line warning for a `smooth_end_checks` entry at 1-based `step`."""
    x, y = check["at"]
    return (f"interface '{check['interface']}', step {step}: the contact reaches "
            f"{check['where']} of its smoothed master '{check['master']}' ({check['pairs']} "
            f"closed pair(s), the first at x={x:.4g}, y={y:.4g}), where mortar-smooth does "
            "not pass the patch test: p there and over the next few master elements can be "
            "off by 10-55% (README \"Smoothed master\"). Use discretisation = \"mortar\" on "
            "it, make the coarser side the slave, or refine the master")
