"""The keys each config table accepts, in one place (extend by adding a line).

`check_keys` rejects any other key with a one-line InputError that suggests the closest
allowed key (difflib, case-insensitive), so that a misspelling such as `sdd = 16` or
`young = 5` is never ignored. Tables whose keys are user names ([parameters], [points],
[petsc], [body.curves]) and the per-type [body.shape] keys (app/mesh/build.py) are not
listed here.
"""

from __future__ import annotations

import difflib

from app.errors import InputError

ALLOWED_KEYS: dict[str, tuple[str, ...]] = {
    "top": (
        "title",
        "parameters",
        "analysis",
        "mesh",
        "body",
        "support",
        "load",
        "interface",
        "points",
        "reference",
        "petsc",
    ),
    "analysis": (
        "plane",
        "thickness",
        "method",
        "sd",
        "steps",
        "compliance",
        "warm_start",
        "candidate_pairs",
        "lcp_solver",
    ),
    "mesh": (
        "size",
        "file",
        "refine",
        "algorithm",
        "patch",
    ),
    "mesh.patch": (
        "box",
        "size",
    ),
    "mesh.refine": (
        "curves",
        "points",
        "size",
        "distance",
        "flat",
    ),
    "body": (
        "name",
        "E",
        "nu",
        "body_force",
        "size",
        "shape",
        "curves",
    ),
    "support": (
        "on",
        "ux",
        "uy",
        "history",
        "ramp",
    ),
    "load": (
        "on",
        "traction",
        "pressure",
        "total_force",
        "history",
        "ramp",
    ),
    "interface": (
        "name",
        "slave",
        "master",
        "mu",
        "c",
        "a",
        "bonded",
        "search_distance",
        "penetration_tol",
        "interference",
        "discretisation",
    ),
    "reference": (
        "type",
        "radius",
        "center_x",
        "center_y",
        "P",
        "L",
        "D",
        "point",
    ),
}


def suggestion(key: str, allowed: tuple[str, ...] | list[str]) -> str:
    """' (did you mean X?)' for the closest allowed key, or ''."""
    lower = {a.lower(): a for a in allowed}
    close = difflib.get_close_matches(str(key).lower(), list(lower), n=1, cutoff=0.5)
    return f" (did you mean {lower[close[0]]}?)" if close else ""


def check_keys(table: dict, kind: str, where: str) -> None:
    """Raise InputError on the first key of `table` not allowed in a table of `kind`.

    kind: a key of ALLOWED_KEYS. where: how the message names the table: a dotted prefix
    such as "analysis." (message "unknown key analysis.sdd (did you mean analysis.sd?)")
    or a label such as "body 'block'" (message "body 'block': unknown key 'young'").
    """
    allowed = ALLOWED_KEYS[kind]
    for key in table:
        if key not in allowed:
            hint = suggestion(key, allowed)
            if where.endswith(".") or not where:
                hint = hint.replace("mean ", f"mean {where}")
                head = f"unknown key {where}{key}"
            else:
                head = f"{where}: unknown key '{key}'"
            raise InputError(f"{head}{hint}; allowed keys: {', '.join(allowed)}")
