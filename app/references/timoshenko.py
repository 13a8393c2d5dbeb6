"""Timoshenko & Goodier's cantilever: tip deflection and strain energy."""

from __future__ import annotations

from app.closed_form import timoshenko_cantilever
from app.errors import InputError
from app.references.base import Reference, RunFigures


def _errors(params: dict, run: RunFigures) -> dict:
    point = run.point_values.get(params["point"])
    if point is None:
        raise InputError(f"[reference] type 'timoshenko': point group '{params['point']}' "
                         f"is not in [points] ({sorted(run.point_values)})")
    # P is per unit thickness, like a [[load]]'s traction or total_force (which the run
    # multiplies by the thickness); the closed form takes the total (before, thickness 2
    # halved the exact tip deflection and energy: 98% and 295% errors on a right answer)
    # the closed form's uy where the point is (the tip (L, 0) in cantilever.toml; before,
    # a point elsewhere was compared with the tip's deflection, without a word)
    L, D = params["L"], params["D"]
    xp, yp = float(point.get("x", L)), float(point.get("y", 0.0))
    if not (-1e-9 * L <= xp <= L * (1 + 1e-9) and abs(yp) <= 0.5 * D * (1 + 1e-9)):
        raise InputError(f"[reference] type 'timoshenko': point '{params['point']}' at "
                         f"({xp:g}, {yp:g}) is not on the beam 0 <= x <= L = {L:g}, "
                         f"|y| <= D/2 = {0.5 * D:g} (clamped at x = 0, centreline y = 0)")
    exact = timoshenko_cantilever(xp, yp, P=params["P"] * run.thickness, L=L, D=D, E=run.E,
                                  nu=run.nu, plane=run.plane, thickness=run.thickness)
    tip, u_ex = point["uy"], float(exact["uy"])
    e_ex = exact["strain_energy"]
    return {"tip_deflection": tip, "tip_deflection_exact": u_ex,
            "tip_deflection_rel_error": abs(tip - u_ex) / abs(u_ex),
            "strain_energy_exact": e_ex,
            "strain_energy_rel_error": abs(run.strain_energy - e_ex) / abs(e_ex)}


REFERENCE = Reference(
    name="timoshenko",
    keys={"P": None, "L": None, "D": None, "point": "tip"},
    positive=("L", "D"), nonzero=("P",),
    errors=_errors,
    columns=((("tip_deflection_rel_error",), "tip_deflection"),
             (("strain_energy_rel_error",), "strain_energy")),
)
