"""CalculiX mortar contact on a 2D scene: the `ContactDeck` of `calculix_deck.py` extruded
to one layer of C3D8 (CalculiX's mortar refuses 2D elements, see
../shared/design/CALCULIX-NOTES.md).

Node i of the mesh is CalculiX node i + 1 at z = 0 and i + 1 + n at z = 1 (thickness 1:
forces per unit thickness); element e is C3D8 e + 1 (the quad at z = 0, then at z = 1).
Plane strain: u_z = 0 at every node except those of the contact faces (CalculiX's mortar
refuses constraints on slave nodes); face k of a quad (corner k -> k + 1) is face S{k + 3}
of its C3D8. Frictionless, `*CONTACT PAIR, TYPE=MORTAR` (dual multipliers), with the
deck's penalty K as the linear regularisation or hard contact (K <= 0). Pure text
functions; the contact pressure is read from the `.frd` (CPRESS at the slave nodes).
"""

from __future__ import annotations

import numpy as np
from calculix_deck import ContactDeck, _fixed_lines, _lines, _step_lines, _surface_lines


def face_nodes(quads: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Sorted node indices of the (element, local face) rows `faces` (k, 2) of quads."""
    q = quads[faces[:, 0]]
    k = np.arange(len(faces))
    return np.unique(np.concatenate([q[k, faces[:, 1]], q[k, (faces[:, 1] + 1) % 4]]))


def write_deck_c3d8(deck: ContactDeck) -> str:
    """The `.inp` text of the scene as one layer of C3D8 with mortar contact.

    Raises ValueError for friction (the notes: NaN with Coulomb friction; a step's own mu
    too) or more than one step (CalculiX's mortar was reliable in one step only).
    """
    if deck.mu > 0 or len(deck.steps) != 1 or deck.steps[0].mu is not None:
        raise ValueError("CalculiX mortar on C3D8: frictionless and one step only")
    n = deck.points.shape[0]
    out = ["*HEADING", "csfem-contact scene exported by scripts/calculix_c3d8.py",
           "*NODE, NSET=NALL"]
    for z in (0, 1):
        out += [f"{i + 1 + z * n}, {x:.13g}, {y:.13g}, {z}"
                for i, (x, y) in enumerate(deck.points)]
    for b in range(len(deck.E)):
        out.append(f"*ELEMENT, TYPE=C3D8, ELSET=BODY{b}")
        for e in np.flatnonzero(deck.body == b):
            q = deck.quads[e] + 1
            out.append(f"{e + 1}, " + ", ".join(str(int(v)) for v in (*q, *(q + n))))
    contact = np.union1d(face_nodes(deck.quads, deck.slave_faces),
                         face_nodes(deck.quads, deck.master_faces))
    held = np.setdiff1d(np.arange(n), contact)
    for name, nodes in {**deck.node_sets, "zfix": held}.items():
        nodes = np.unique(nodes)
        out.append(f"*NSET, NSET={name.upper()}")
        out += _lines(np.concatenate([nodes + 1, nodes + 1 + n]))
    out += _surface_lines(deck, 3)
    for b, (E, nu) in enumerate(zip(deck.E, deck.nu, strict=True)):
        out += [f"*MATERIAL, NAME=MAT{b}", "*ELASTIC", f"{E:.10g}, {nu:.10g}",
                f"*SOLID SECTION, ELSET=BODY{b}, MATERIAL=MAT{b}"]
    out.append("*SURFACE INTERACTION, NAME=SI")
    if deck.penalty > 0:
        out += ["*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR", f"{deck.penalty:.10g}"]
    out += ["*CONTACT PAIR, INTERACTION=SI, TYPE=MORTAR", "SLAVE, MASTER",
            "*BOUNDARY", "ZFIX, 3, 3, 0.", *_fixed_lines(deck)]
    out += _step_lines(deck.steps[0], deck)
    return "\n".join(out) + "\n"
