"""The rigid motion of floating bodies, from the displacement field.

`steps[k].rigid_modes` are the LCP's amplitudes of the floating modes on top of a solution
with one DOF per mode pinned, so they depend on which DOFs were pinned and are not the
body's motion (multibody: the cylinder's "translation y" amplitude is +0.059 while it moves
down by 0.053). `rigid_motion` is the least-squares rigid fit of the body's nodal
displacements instead. Plain numpy (every rank has u whole).
"""

from __future__ import annotations

import numpy as np


def rigid_motion(points: np.ndarray, node_body: np.ndarray, body_names: list[str],
                 bodies: list[str], u: np.ndarray) -> dict[str, dict]:
    """Per body in `bodies`: the rigid motion closest to its nodal displacements.

    points (n, 2), node_body (n,) body index per node, u (2n,) displacements. With xc the
    node positions about the body's node centroid c, the fit minimises
    sum |u_i - (t + theta e_z x xc_i)|^2: t = mean u_i, theta = sum(xc_i x u_i) /
    sum |xc_i|^2 (radians, counter-clockwise positive). Returns {name: {"translation":
    [tx, ty], "rotation": theta, "centroid": [cx, cy]}}.
    """
    uu = u.reshape(-1, 2)
    out = {}
    for name in bodies:
        nodes = np.flatnonzero(node_body == body_names.index(name))
        c = points[nodes].mean(axis=0)
        xc = points[nodes] - c
        ub = uu[nodes]
        t = ub.mean(axis=0)
        r2 = float((xc ** 2).sum())
        theta = float((xc[:, 0] * ub[:, 1] - xc[:, 1] * ub[:, 0]).sum()) / r2 if r2 else 0.0
        out[name] = {"translation": [float(t[0]), float(t[1])], "rotation": theta,
                     "centroid": [float(c[0]), float(c[1])]}
    return out
