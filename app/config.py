"""Scene configuration: read a TOML file and check every key the solver uses.

Geometry keys ([mesh], [[body]].shape/curves/size, [points]) are checked by the mesh
builder; this module checks analysis settings, materials, supports, loads, interfaces,
load steps and the [petsc] table, and turns them into plain dataclasses.
Every problem raises InputError with a one-line message naming the key to fix.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from app.config_keys import ALLOWED_KEYS, check_keys, suggestion
from app.errors import InputError
from app.expressions import check_parameter_name, parse_expression
from app.petsc_config_guard import check_config_file_petsc
from app.references import REFERENCES, reference
from app.scene import Scene, parse_scene
from app.scene.geometry import is_number
from app.user_paths import path_kind


@dataclass
class Support:
    """Prescribed displacement components on a named curve or point group."""

    on: str
    values: dict[int, float | str]  # component (0 = x, 1 = y) -> value or expression in x, y
    history: np.ndarray  # (n_steps,) factor on the values per step


@dataclass
class Load:
    """A surface load on a named curve (per unit length, times thickness)."""

    on: str
    kind: str  # "traction" | "pressure" | "total_force"
    value: list  # traction [tx, ty] (numbers or expressions in x, y), [pressure], or [Fx, Fy]
    history: np.ndarray  # (n_steps,)


@dataclass
class Interface:
    """A contact interface between a slave and a master curve.

    mu: friction coefficient; c: tangential strength and a: normal adhesion, both as
    tractions (force per unit length of interface; pair values are c and a times the
    slave node's tributary length and the thickness).
    """

    name: str
    slave: str
    master: str
    mu: float
    c: float
    a: float
    bonded: bool
    search_distance: float
    penetration_tol: float | None = None
    interference: bool = False  # initial overlaps are an intended interference fit
    discretisation: str | None = None  # a name in app.contact.discretisation; None: default

    @property
    def frictional(self) -> bool:
        """True when tangential unknowns are needed (friction or a bonded strength)."""
        return self.mu > 0.0 or (self.bonded and self.c > 0.0)


@dataclass
class Config:
    """A checked scene description (see README, 'Config files')."""

    path: Path
    raw: dict[str, Any]
    plane: str
    thickness: float
    method: str
    sd: int
    n_steps: int
    body_names: list[str]
    E: np.ndarray
    nu: np.ndarray
    body_force: np.ndarray  # (n_bodies, 2) force per unit volume
    supports: list[Support]
    loads: list[Load]
    interfaces: list[Interface]
    petsc: dict[str, str] = field(default_factory=dict)
    mesh_size: float = 1.0
    parameters: dict[str, float] = field(default_factory=dict)
    reference: dict | None = None  # the [reference] table, checked by app.references
    scene: Scene | None = None  # geometry: [mesh], [[body]] shapes and curves, [points]
    compliance: str = "auto"  # analysis.compliance: auto | schur | solve
    warm_start: bool = True  # analysis.warm_start: Lemke starts from the last basis
    candidate_pairs: bool = True  # analysis.candidate_pairs: LCP over the pairs near contact
    lcp_solver: str = "lemke"  # analysis.lcp_solver: a name in app.lcp.solvers.LCP_SOLVERS


def _num(value: Any, where: str, *, positive: bool = False, nonneg: bool = False) -> float:
    """A finite number (`app.scene.geometry.is_number`), > 0 or >= 0 when asked."""
    if not is_number(value):
        raise InputError(f"{where} must be a finite number (got {value!r})")
    if positive and value <= 0:
        raise InputError(f"{where} must be > 0 (got {value!r})")
    if nonneg and value < 0:
        raise InputError(f"{where} must be >= 0 (got {value!r})")
    return float(value)


def _vec2(value: Any, where: str) -> np.ndarray:
    if not isinstance(value, list) or len(value) != 2:
        raise InputError(f"{where} must be a list of two numbers [x, y] (got {value!r})")
    return np.array([_num(v, where) for v in value])


def _name_key(t: dict, key: str, where: str, what: str) -> str:
    """t[key], a non-empty name string: 'missing key' when absent, else the wrong value
    (a number or an empty string was reported as a missing key before)."""
    if key not in t:
        raise InputError(f"{where}: missing key {key} ({what})")
    v = t[key]
    if not isinstance(v, str) or not v:
        raise InputError(f"{where}: {key} must be {what} (got {v!r})")
    return v


def _table(raw: dict, key: str, where: str) -> dict:
    v = raw.get(key, {})
    if not isinstance(v, dict):
        raise InputError(f"{where}{key} must be a table")
    return v


def _tables(raw: dict, key: str) -> list[dict]:
    v = raw.get(key, [])
    if not isinstance(v, list) or not all(isinstance(t, dict) for t in v):
        raise InputError(f"[[{key}]] must be an array of tables")
    return v


MAX_ENTRIES = {"body": 1000, "interface": 1000, "support": 2000, "load": 2000}
"""Most [[body]], [[interface]], [[support]] and [[load]] entries: the set-up, meshing
and each step's output grow with them (5000 bodies, supports and loads took 47 s before a
support's unknown group was reported; 1000 bodies at the bound run, README "Input checks"
gives the measured time). The shipped scenes have at most 5 bodies and 11 supports."""


def _check_counts(raw: dict) -> None:
    """InputError when an array of tables has more entries than MAX_ENTRIES allows."""
    for key, most in MAX_ENTRIES.items():
        n = len(_tables(raw, key))
        if n > most:
            raise InputError(f"[[{key}]] has {n} entries, more than {most}: split the "
                             "scene into smaller ones")


def _history(t: dict, where: str, n_steps: int) -> np.ndarray:
    """Load factor per step: `history = [...]` (one per step), `ramp = [k0, k1]`, or 1."""
    if "history" in t and "ramp" in t:
        raise InputError(f"{where}: give either history or ramp, not both")
    if "history" in t:
        h = t["history"]
        if not isinstance(h, list) or not h:
            raise InputError(f"{where}.history must be a non-empty list of numbers")
        if len(h) != n_steps:
            raise InputError(
                f"{where}.history has {len(h)} entries but analysis.steps = {n_steps}"
            )
        return np.array([_num(v, f"{where}.history") for v in h])
    if "ramp" in t:
        r = t["ramp"]
        if (
            not isinstance(r, list)
            or len(r) != 2
            or not all(isinstance(k, int) and not isinstance(k, bool) for k in r)
            or not 1 <= r[0] <= r[1] <= n_steps
        ):
            raise InputError(
                f"{where}.ramp must be [first_step, last_step] with 1 <= first <= last <= "
                f"analysis.steps = {n_steps} (got {r!r})"
            )
        k = np.arange(1, n_steps + 1)
        return np.clip((k - r[0] + 1) / (r[1] - r[0] + 1), 0.0, 1.0)
    return np.ones(n_steps)


KNOWN_TOP = set(ALLOWED_KEYS["top"])
MAX_STEPS = 100_000
"""Most load steps a config may ask for (each writes a step file)."""


def evaluate(value: float | str, x: np.ndarray, y: np.ndarray, params: dict[str, float],
             where: str) -> np.ndarray:
    """Values at points (x, y) of a number or a math expression (see app/expressions.py)."""
    if not isinstance(value, str):
        return np.full(np.shape(x), float(value))
    return parse_expression(value, where, params).evaluate(x, y)


def _scalar_or_expr(value: Any, where: str, params: dict[str, float]) -> float | str:
    """A number, or an expression string checked now (syntax, names, constant parts)."""
    if isinstance(value, str):
        parse_expression(value, where, params)
        return value
    return _num(value, where)


def _check_refine_lengths(r: dict, where: str) -> None:
    """flat (the constant-size zone) must not exceed distance (the growth zone)."""
    flat, dist = r.get("flat", 0.0), r.get("distance")
    numbers = all(isinstance(v, int | float) and not isinstance(v, bool) for v in (flat, dist))
    if numbers and flat > dist:
        raise InputError(f"{where}: flat = {flat:g} is larger than distance = {dist:g}: flat is "
                         "the zone of constant fine size around the curves/points and distance "
                         "the zone over which the size grows back; use flat <= distance")


def _check_interface_bodies(raw: dict, name: str, slave: str, master: str,
                            earlier: list[Interface]) -> None:
    """Unique interface names; slave and master curves on different bodies (for the
    curves that [[body]] tables name; a mesh file is checked after reading)."""
    if any(x.name == name for x in earlier):
        raise InputError(f"interface name '{name}' is used twice: interface names must be "
                         "unique")
    owner = {}
    for b in raw.get("body", []):
        curves = b.get("curves") if isinstance(b, dict) else None
        if isinstance(curves, dict):
            owner |= {c: b.get("name") for c in curves.values() if isinstance(c, str)}
    if slave in owner and owner.get(master) == owner[slave]:
        raise InputError(f"interface '{name}': slave '{slave}' and master '{master}' are both "
                         f"curves of body '{owner[slave]}': an interface joins two bodies")


def parse_config(raw: dict[str, Any], path: Path | str = "<config>") -> Config:
    """Check a parsed TOML dict and build a Config, table by table."""
    check_keys(raw, "top", "")
    _check_counts(raw)
    params = _parameters(raw)
    an = _analysis(raw)
    n_steps = an["steps"]
    mesh_size = _mesh_size(raw)
    names, E, nu, bf = _bodies(raw)
    supports = [_support(s, f"support #{i + 1}", n_steps, params)
                for i, s in enumerate(_tables(raw, "support"))]
    loads = [_load(ld, f"load #{i + 1}", n_steps, params)
             for i, ld in enumerate(_tables(raw, "load"))]
    interfaces: list[Interface] = []
    for i, it in enumerate(_tables(raw, "interface")):
        interfaces.append(_interface(raw, it, i, interfaces))
    return Config(
        path=Path(path), raw=raw, plane=an["plane"], thickness=an["thickness"],
        method=an["method"], sd=an["sd"], n_steps=n_steps, body_names=names, E=np.array(E),
        nu=np.array(nu), body_force=np.array(bf).reshape(-1, 2), supports=supports,
        loads=loads, interfaces=interfaces, petsc=_petsc(raw), mesh_size=mesh_size,
        parameters=params, reference=_reference_table(raw), scene=parse_scene(raw),
        compliance=an["compliance"], warm_start=an["warm_start"],
        candidate_pairs=an["candidate_pairs"], lcp_solver=an["lcp_solver"],
    )


def _parameters(raw: dict) -> dict[str, float]:
    """[parameters]: named numbers for the expressions (not x, y or a function name)."""
    params = {}
    for k, v in _table(raw, "parameters", "").items():
        check_parameter_name(k)
        params[k] = _num(v, f"parameters.{k}")
    return params


def _analysis(raw: dict) -> dict[str, Any]:
    """[analysis] with its defaults; method and sd are checked against the bulk-method
    registry by the driver, before any meshing."""
    an = _table(raw, "analysis", "")
    check_keys(an, "analysis", "analysis.")
    plane = an.get("plane", "strain")
    if plane not in ("strain", "stress"):
        raise InputError(f"analysis.plane = {plane!r}: use 'strain' or 'stress'")
    n_steps = an.get("steps", 1)
    if isinstance(n_steps, bool) or not isinstance(n_steps, int) or n_steps < 1:
        raise InputError(f"analysis.steps must be an integer >= 1 (got {n_steps!r})")
    if n_steps > MAX_STEPS:
        raise InputError(f"analysis.steps = {n_steps} is above {MAX_STEPS}: each step is "
                         "solved and written; use fewer steps")
    if an.get("compliance", "auto") not in ("auto", "schur", "solve"):
        raise InputError(f"analysis.compliance = {an['compliance']!r}: use 'auto', 'schur' "
                         "or 'solve'")
    for flag in ("warm_start", "candidate_pairs"):
        if not isinstance(an.get(flag, True), bool):
            raise InputError(f"analysis.{flag} must be true or false (got {an[flag]!r})")
    return {"plane": plane,
            "thickness": _num(an.get("thickness", 1.0), "analysis.thickness", positive=True),
            "method": an.get("method", "cs-fem"), "sd": an.get("sd", 4), "steps": n_steps,
            "compliance": an.get("compliance", "auto"),
            "warm_start": an.get("warm_start", True),
            "candidate_pairs": an.get("candidate_pairs", True),
            "lcp_solver": an.get("lcp_solver", "lemke")}


def _mesh_size(raw: dict) -> float:
    """mesh.size (1.0 with a ready mesh.file, so --mesh-size ratios stay defined); the
    [[mesh.refine]] keys and their flat <= distance."""
    mesh = raw.get("mesh")
    if not isinstance(mesh, dict):
        raise InputError("missing [mesh] table (at least mesh.size)")
    check_keys(mesh, "mesh", "mesh.")
    refine = mesh.get("refine", [])
    for i, r in enumerate(refine if isinstance(refine, list) else []):
        if isinstance(r, dict):
            check_keys(r, "mesh.refine", f"mesh.refine[{i}].")
            _check_refine_lengths(r, f"mesh.refine[{i}]")
    patches = mesh.get("patch", [])
    for i, r in enumerate(patches if isinstance(patches, list) else []):
        if isinstance(r, dict):
            check_keys(r, "mesh.patch", f"mesh.patch[{i}].")
    if "size" not in mesh and mesh.get("file") is None:
        raise InputError("missing key mesh.size (the global element size)")
    return _num(mesh.get("size", 1.0), "mesh.size", positive=True)


def _bodies(raw: dict) -> tuple[list[str], list[float], list[float], list[np.ndarray]]:
    """Names, E, nu and body forces of the [[body]] tables (shapes and unique names:
    app.scene)."""
    bodies = _tables(raw, "body")
    if not bodies:
        raise InputError("no [[body]] given: a scene needs at least one body")
    names, E, nu, bf = [], [], [], []
    for i, b in enumerate(bodies):
        nm = _name_key(b, "name", f"body #{i + 1}", "a non-empty string")
        check_keys(b, "body", f"body '{nm}'")
        for k in ("E", "nu"):
            if k not in b:
                raise InputError(f"body '{nm}': missing key {k}")
        e = _num(b["E"], f"body '{nm}': E")
        if e <= 0:
            raise InputError(f"body '{nm}': E must be > 0 (got {b['E']!r})")
        n = _num(b["nu"], f"body '{nm}': nu")
        if not -1.0 < n < 0.5:
            raise InputError(f"body '{nm}': nu must lie in (-1, 0.5) (got {b['nu']!r})")
        names.append(nm)
        E.append(e)
        nu.append(n)
        bf.append(_vec2(b.get("body_force", [0.0, 0.0]), f"body '{nm}': body_force"))
    return names, E, nu, bf


def _support(s: dict, where: str, n_steps: int, params: dict[str, float]) -> Support:
    """One [[support]]: ux and/or uy (numbers or expressions) with a history."""
    _name_key(s, "on", where, "a curve or point group name")
    check_keys(s, "support", f"{where} ({s['on']})")
    vals = {}
    for comp, key in enumerate(("ux", "uy")):
        if key in s:
            vals[comp] = _scalar_or_expr(s[key], f"{where} ({s['on']}): {key}", params)
    if not vals:
        raise InputError(f"{where} ({s['on']}): give ux and/or uy")
    return Support(s["on"], vals, _history(s, where, n_steps))


def _load(ld: dict, where: str, n_steps: int, params: dict[str, float]) -> Load:
    """One [[load]]: exactly one of traction, pressure, total_force, with a history."""
    _name_key(ld, "on", where, "a curve name")
    check_keys(ld, "load", f"{where} ({ld['on']})")
    kinds = [k for k in ("traction", "pressure", "total_force") if k in ld]
    if len(kinds) != 1:
        raise InputError(f"{where} ({ld['on']}): give exactly one of traction, pressure, "
                         "total_force")
    kind = kinds[0]
    if kind == "pressure":
        val = [_num(ld[kind], f"{where}: pressure")]
    elif kind == "traction":
        t = ld[kind]
        if not isinstance(t, list) or len(t) != 2:
            raise InputError(f"{where}: traction must be [tx, ty] (numbers or expressions)")
        val = [_scalar_or_expr(v, f"{where}: traction", params) for v in t]
    else:
        val = list(_vec2(ld[kind], f"{where}: {kind}"))
    return Load(ld["on"], kind, val, _history(ld, where, n_steps))


def _interface(raw: dict, it: dict, i: int, earlier: list[Interface]) -> Interface:
    """One [[interface]] (the discretisation name is checked by the contact registry)."""
    nm = it.get("name", f"interface{i + 1}")
    if not isinstance(nm, str) or not nm.strip():
        raise InputError(f"interface #{i + 1}: name must be a non-empty string (got {nm!r})")
    where = f"interface '{nm}'"
    check_keys(it, "interface", where)
    for k in ("slave", "master"):
        _name_key(it, k, where, "a curve name")
    if it["slave"] == it["master"]:
        raise InputError(f"{where}: slave and master are the same curve '{it['slave']}'")
    if "search_distance" not in it:
        raise InputError(f"{where}: missing key search_distance")
    mu = _num(it.get("mu", 0.0), f"{where}: mu", nonneg=True)
    c = _num(it.get("c", 0.0), f"{where}: c", nonneg=True)
    a = _num(it.get("a", 0.0), f"{where}: a", nonneg=True)
    bonded = it.get("bonded", a > 0.0 or c > 0.0)
    if not isinstance(bonded, bool):
        raise InputError(f"{where}: bonded must be true or false")
    if not bonded and (a > 0.0 or c > 0.0):
        raise InputError(f"{where}: a = {a}, c = {c} act only while a pair is bonded, and "
                         "bonded = false ignores them: remove them or set bonded = true")
    if c < mu * a * (1.0 - 1e-12):  # c = mu a is allowed (0.1 * 3 is 0.30000000000000004)
        raise InputError(f"{where}: c = {c} < mu * a = {mu * a}: need c >= mu a so the "
                         "friction bound mu p + c stays >= 0 under tension")
    sdist = _num(it["search_distance"], f"{where}: search_distance", positive=True)
    ptol = it.get("penetration_tol")
    if ptol is not None:
        ptol = _num(ptol, f"{where}: penetration_tol", nonneg=True)
    interference = it.get("interference", False)
    if not isinstance(interference, bool):
        raise InputError(f"{where}: interference must be true or false")
    _check_interface_bodies(raw, nm, it["slave"], it["master"], earlier)
    disc = it.get("discretisation")  # None: the registry default (app.contact)
    if disc is not None and (not isinstance(disc, str) or not disc):
        raise InputError(f"{where}: discretisation must be a name (got {disc!r})")
    return Interface(nm, it["slave"], it["master"], mu, c if bonded else 0.0,
                     a if bonded else 0.0, bonded, sdist, ptol, interference, disc)


VIEWER_OPTION = re.compile(r"(^|_)(view|monitor|converged_reason)(_|$)")
"""PETSc options read as a viewer (`-ksp_view`, `-ksp_monitor_short`, `-mat_view_draw`,
`-ksp_converged_reason`): their value is a viewer name, so "false" cannot turn them off."""


def _petsc(raw: dict) -> dict[str, str]:
    """[petsc] options as strings (without the dash). true is the bare flag (`-ksp_monitor`,
    `-ksp_view`: the value "true" is read as a viewer name and fails); false is "false",
    except for a viewer option (VIEWER_OPTION), which is then left out: off, PETSc's
    default (`-ksp_view false` stopped with "PETSc: Unsupported viewer false")."""
    out = {}
    for k, v in _table(raw, "petsc", "").items():
        key = str(k).lstrip("-")
        if v is False and VIEWER_OPTION.search(key.lower()):
            continue
        if isinstance(v, bool):
            v = "" if v else "false"
        out[key] = str(v)
    return out


def _reference_table(raw: dict) -> dict | None:
    """The [reference] table, its type and keys checked against the registry."""
    if "reference" not in raw:
        return None
    table = _table(raw, "reference", "")
    check_keys(table, "reference", "reference.")
    kind = table.get("type")
    if kind not in REFERENCES:
        raise InputError(f"reference.type = {kind!r}: use one of "
                         f"{', '.join(REFERENCES)}{suggestion(str(kind), REFERENCES)}")
    params = reference(kind).params(table)
    points = raw.get("points") if isinstance(raw.get("points"), dict) else {}
    if "point" in params and params["point"] not in points:  # (found after the run before)
        raise InputError(f"reference.point = {params['point']!r} is not a name in [points] "
                         f"({', '.join(points) or 'none'})")
    return dict(table)


INT64 = (-(2**63), 2**63 - 1)
"""TOML's integers are 64-bit signed: "if an integer cannot be represented losslessly, an
error must be thrown" (TOML 1.0), which tomllib does not do."""
INT64_DIGITS = 19


UNPRINTABLE = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e"
                         "\u2066-\u2069]")
"""Control characters (C0 but tab and newline, DEL, C1) and bidirectional formatting
characters, refused in every key and string of a config: names reach the terminal in
progress, warning and error lines."""
MULTILINE_KEYS = re.compile(r"(^|\.)(title|ux|uy)$|\.traction(\.\d+)?$")
"""Values that may hold a newline: the title and expressions (never printed raw)."""


def _value_problem(key: str, node: Any) -> str | None:
    """Why a config value (or key) is refused, or None."""
    if isinstance(node, int) and not isinstance(node, bool) and not (
            INT64[0] <= node <= INT64[1]):
        return (f"{key} is an integer of {node.bit_length()} bits, beyond TOML's 64-bit "
                "signed integers (-2^63 .. 2^63 - 1): write a float, e.g. 1e30, if you mean "
                "one")
    if isinstance(node, str):
        bad = UNPRINTABLE.search(node) or (not MULTILINE_KEYS.search(key)
                                           and re.search("\n", node))
        if bad:
            return (f"{key} contains the control character U+{ord(bad.group()):04X}: names "
                    "and values are printed on the terminal (escape sequences, line breaks "
                    "and text direction marks are refused)")
    return None


def check_values(raw: Any, where: str) -> None:
    """InputError naming the key of the first integer outside 64 bits, or of the first
    key or string with a control character (a tab anywhere, a newline only in `title`
    and expressions), iteratively.

    Before, `E = 0x` followed by 5000 `f` (an integer of 6000 digits) ended in an
    `OverflowError: int too large to convert to float` traceback, exit 1, and an interface
    named "if\u001b[2J" cleared the terminal from its progress line."""
    stack: list[tuple[str, Any]] = [("", raw)]
    while stack:
        key, node = stack.pop()
        if isinstance(node, dict):
            for k, v in node.items():
                name = f"{key}.{k}" if key else str(k)
                if why := _value_problem(f"the key {name!r}", str(k)):
                    raise InputError(f"{where}{why}")
                stack.append((name, v))
        elif isinstance(node, list):
            stack += [(f"{key}.{i}", v) for i, v in enumerate(node)]
        elif why := _value_problem(key, node):
            raise InputError(f"{where}{why}")


def _is_index(part: str) -> bool:
    """A 0-based index in a --set key: ASCII digits, at most 19 (`int()` of 5000 digits,
    or of `²`, raised a ValueError traceback)."""
    return part.isascii() and part.isdigit() and len(part) <= INT64_DIGITS


def _override_value(text: str) -> Any:
    """A TOML value (number, bool, string, array, inline table); bare words are strings."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
    except ValueError:  # int(): more than 4300 digits
        raise InputError(f"--set value {text[:40]!r}...: an integer of more than "
                         f"{INT64_DIGITS} digits: TOML integers are 64-bit") from None
    except RecursionError:
        raise InputError(f"--set value {text[:40]!r}...: arrays or tables nested too "
                         "deeply") from None


def apply_overrides(raw: dict[str, Any], overrides: list[str]) -> dict[str, Any]:
    """Set config values from `KEY=VALUE` strings (the `--set` option), in place.

    KEY is a dotted path into the TOML tables; inside an array of tables ([[body]],
    [[interface]], [[support]], [[mesh.refine]], ...) the next part is the entry's `name` or
    its 0-based index (the index one past the end appends an entry). Examples:
    `interface.contact.mu=5`, `body.block.nu=0.499`, `analysis.steps=100`,
    `mesh.refine.0.size=0.002`, `support.1.on=corner` with `support.1.ux=0` (a new
    support), or the whole entry as an inline table, `support.1={on="corner", ux=0.0}`.
    VALUE is a TOML value.
    """
    for item in overrides:
        key, sep, text = item.partition("=")
        parts = [k for k in key.strip().split(".") if k]
        if not sep or not parts:
            raise InputError(f"--set {item!r}: use KEY=VALUE, e.g. interface.contact.mu=0.5")
        node: Any = raw
        for i, part in enumerate(parts[:-1]):
            here = ".".join(parts[: i + 1])
            if isinstance(node, dict):
                if part not in node:  # a new table, or a new array of tables ("x.0.key")
                    node[part] = [] if _is_index(parts[i + 1]) else {}
                node = node[part]
            elif isinstance(node, list):
                names = [t.get("name") for t in node if isinstance(t, dict)]
                if part in names:
                    node = node[names.index(part)]
                elif _is_index(part) and int(part) < len(node):
                    node = node[int(part)]
                elif _is_index(part) and int(part) == len(node):  # append a new entry
                    node.append({})
                    node = node[-1]
                else:
                    where = here.rsplit(".", 1)[0]
                    raise InputError(f"--set {item!r}: no entry '{part}' in {where} (names: "
                                     f"{names}, or an index 0..{len(node)})")
            if not isinstance(node, dict | list):
                raise InputError(f"--set {item!r}: {here} is a value, not a table")
        if isinstance(node, list):
            _set_entry(node, parts, _override_value(text.strip()), item)
            continue
        node[parts[-1]] = _override_value(text.strip())
    return raw


def _set_entry(entries: list, parts: list[str], value: Any, item: str) -> None:
    """`--set load.1={on="top", total_force=[0.0, -1.0]}`: a whole entry of an array of
    tables, picked as apply_overrides picks one (by name or index; one past the end
    appends). Before, an error saying to name an entry, which the key did."""
    where, last = ".".join(parts[:-1]), parts[-1]
    if not isinstance(value, dict):
        raise InputError(f"--set {item!r}: name an entry of {where} (its name or 0-based "
                         f"index) before the key, or give a whole entry as an inline table, "
                         f"e.g. {where}.{len(entries)}={{...}}")
    names = [t.get("name") for t in entries if isinstance(t, dict)]
    if last in names:
        entries[names.index(last)] = value
    elif _is_index(last) and int(last) < len(entries):
        entries[int(last)] = value
    elif _is_index(last) and int(last) == len(entries):
        entries.append(value)
    else:
        raise InputError(f"--set {item!r}: no entry '{last}' in {where} (names: {names}, or "
                         f"an index 0..{len(entries)})")


MAX_CONFIG_BYTES = 4 << 20
"""Largest config file read: the shipped ones have at most a few kB, a 10,000-corner
polygon about 400 kB. Before, a config's size had no bound: a 4.4 MB file listing 200,000
`[[mesh.refine]]` points ran 25 s and 488 MB, and parsing and meshing grow with the file."""


def _config_text(data: bytes, p: Path) -> str:
    """The file's text: UTF-8, a leading UTF-8 byte order mark dropped (Windows editors
    write one; before, it read as `not valid TOML: Invalid statement (at line 1, column
    1)`); a UTF-16 or UTF-32 one is named (UnicodeDecodeError otherwise; UTF-32 LE's mark
    starts with UTF-16 LE's, so it is tested first)."""
    for name, marks in (("UTF-32", (b"\xff\xfe\x00\x00", b"\x00\x00\xfe\xff")),
                        ("UTF-16", (b"\xff\xfe", b"\xfe\xff"))):
        if data.startswith(marks):
            raise InputError(f"config file '{p}' is {name} text (it starts with a {name} "
                             "byte order mark): save it as UTF-8")
    return data.decode("utf-8-sig")


def _read_config_text(p: Path) -> str:
    """The config file's text, checked (a regular file, at most MAX_CONFIG_BYTES, UTF-8);
    InputError (one line) if not."""
    kind = path_kind(p, "config file")
    if kind is None:
        raise InputError(f"config file '{p}' does not exist")
    if kind != "file":
        raise InputError(f"config file '{p}' is not a regular file")
    try:
        with p.open("rb") as fh:
            data = fh.read(MAX_CONFIG_BYTES + 1)
        if len(data) > MAX_CONFIG_BYTES:
            raise InputError(f"config file '{p}' is larger than {MAX_CONFIG_BYTES >> 20} MB: "
                             "a scene needs far less (a mesh goes in mesh.file)")
        return _config_text(data, p)
    except UnicodeDecodeError as exc:
        raise InputError(f"config file '{p}' is not UTF-8 text (byte {exc.start}): save it "
                         "as UTF-8") from None
    except OSError as exc:
        raise InputError(f"config file '{p}' cannot be read: {exc.strerror}") from None


def shared_config_text(p: Path) -> str:
    """_read_config_text on rank 0, its text (or InputError) every rank's once PETSc has
    started (app.parallel.rank0_call); read here otherwise (a script, a test). Before,
    every rank read the file itself: with ranks whose file systems differ (nodes without a
    shared one, ranks started in other folders: a relative path), the rank that did not
    find it refused alone while rank 0 ran, and the job ended 35 s later with
    OUT/summary.json still `running` (tests/test_input_checks_ranks.py). Every rank parses the
    same text, so `--set` and the checks see the same scene."""
    import sys

    if "petsc4py.PETSc" not in sys.modules:  # (importing it would start PETSc)
        return _read_config_text(p)
    from app.parallel import rank0_call

    return rank0_call(_read_config_text, p)


def load_config(path: str | Path, overrides: list[str] | None = None) -> Config:
    """Read and check a TOML scene file; `overrides` are `--set KEY=VALUE` strings. The
    file is read on rank 0 (shared_config_text)."""
    p = Path(path)
    text = shared_config_text(p)
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"config file '{p}' is not valid TOML: {exc}") from None
    except ValueError:  # int(): more than 4300 digits (sys.get_int_max_str_digits)
        raise InputError(f"config file '{p}' has an integer of more than "
                         f"{INT64_DIGITS} digits: TOML integers are 64-bit") from None
    except RecursionError:  # tomllib recurses per nested array or inline table
        raise InputError(f"config file '{p}' nests arrays or tables too deeply") from None
    check_values(raw, f"config file '{p}': ")
    check_config_file_petsc(raw.get("petsc"), p)  # the file's own table, before --set
    if overrides:
        apply_overrides(raw, overrides)
        check_values(raw, "--set: ")
    return parse_config(raw, p)
