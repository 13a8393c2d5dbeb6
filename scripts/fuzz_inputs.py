"""Fuzz the input handling of `python -m app`: random bad configs and command lines.

Each case takes a shipped config (configs/*.toml, configs/hard/*.toml by default), applies
one mutation (a `--set KEY=VALUE`, a mutated TOML file, a broken file, or a bad command
line option), runs `python -m app ...` in a subprocess with a timeout and classifies it:

- OK: exit 0, OUT/summary.json `completed` with finite numbers only;
- CLEAN_ERROR: exit 2 with one `error: ...` line last on stderr (other lines `warning: `),
  and OUT/summary.json `failed` with an `error` when the run could write one (README "Exit
  status"); or argparse's usage lines ending in `python -m app run: error: ...`;
- BUG: anything else: a traceback, another exit status, a timeout, a multi-line error, no
  `failed` summary, `running` left behind, a non-finite number in a `completed` summary,
  or a value that is invalid on its face (NaN, a negative E, nu >= 0.5, a wrong type, a
  missing required key, a curve that does not exist) accepted with exit 0;
- SLOW: a timeout on a model the app's own size estimate puts above 1e5 elements (a big
  valid model the size check accepted, e.g. a radius scaled by 1000), reported apart.

Prints one JSON line per case and a final summary line ({"summary": ...}); the exit status
is 1 when a BUG was found. Every case is cheap: the configs run at 4x their mesh.size.

    .venv/bin/python scripts/fuzz_inputs.py --seed 1 --cases 300
    .venv/bin/python scripts/fuzz_inputs.py --ranks 2 --cases 40 --configs 'configs/p*.toml'
"""

from __future__ import annotations

import argparse
import copy
import glob
import json
import math
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from app.contact.discretisation import DISCRETISATIONS  # noqa: E402
from app.discretisation.methods import BULK_METHODS  # noqa: E402
from app.errors import MAX_MESSAGE  # noqa: E402
from app.lcp.solvers import LCP_SOLVERS  # noqa: E402
from app.scene.mesh_algorithms import MESH_ALGORITHMS  # noqa: E402

DEFAULT_CONFIGS = ("configs/*.toml", "configs/hard/*.toml")

# ------------------------------------------------------------------ what a value may be

POSITIVE = {"E", "thickness", "size", "search_distance", "radius", "width", "height"}
NONNEG = {"mu", "c", "a", "penetration_tol", "flat"}
BOOLS = {"structured", "bonded", "warm_start", "candidate_pairs", "interference"}
ENUMS = {"plane": {"strain", "stress"}, "method": set(BULK_METHODS),
         "compliance": {"auto", "schur", "solve"}, "lcp_solver": set(LCP_SOLVERS),
         "algorithm": set(MESH_ALGORITHMS), "discretisation": set(DISCRETISATIONS),
         "side": {"lower", "upper", "left", "right"}}
VECTOR2 = {"origin", "center", "body_force", "total_force", "traction"}
REFS = {"on", "slave", "master"}
FREE = {"title", "name"}
REQUIRED = {"E", "nu", "shape", "type", "on", "slave", "master", "search_distance",
            "origin", "width", "height", "radius"}

BAD_SCALARS: list[tuple[str, Any]] = [  # (TOML text for --set, the value in a file)
    ('"abc"', "abc"), ("[1.0, 2.0]", [1.0, 2.0]), ("[]", []), ("{x = 1}", {"x": 1}),
    ("true", True), ("false", False), ("nan", math.nan), ("inf", math.inf),
    ("-inf", -math.inf), ("-0.0", -0.0), ("0", 0), ("0.0", 0.0), ("-1", -1), ("-1e-300", -1e-300),
    ("1e308", 1e308), ("-1e308", -1e308), ("5e-324", 5e-324), ("1e-12", 1e-12), ("1e12", 1e12),
    ("123456789012345678901234567890", 123456789012345678901234567890),
    ("9223372036854775807", 9223372036854775807), ("0.5", 0.5), ("0.49999999", 0.49999999),
    ("1", 1), ("2", 2), ("3", 3), ("-0.5", -0.5), ("1.5", 1.5),
    ('"' + "x" * 5000 + '"', "x" * 5000),
    ('"\u00fc\u65e5\u672c \u2207"', "\u00fc\u65e5\u672c \u2207"),
    ('"a\\u0000b"', "a\u0000b"), ('"../../x"', "../../x"), ('""', ""), ('"x\\ny"', "x\ny"),
]
HUGE_COUNTS = [10**6, 10**9, 2**63 - 1, 10**30]


def must_fail(key: str, old: Any, new: Any) -> bool | None:
    """True when `new` in place of `old` under `key` is invalid on its face (a run that
    accepts it answers silently wrong); None when it may be valid."""
    if key in ("title",) or isinstance(new, float) and not math.isfinite(new):
        return key != "title"
    num = isinstance(old, int | float) and not isinstance(old, bool)
    if num:
        if not (isinstance(new, int | float) and not isinstance(new, bool)):
            return True
        if key in POSITIVE:
            return not new > 0
        if key in NONNEG:
            return not new >= 0
        if key == "nu":
            return not -1 < new < 0.5
        if key == "steps":
            return not (isinstance(new, int) and 1 <= new <= 100_000)
        if key == "sd":
            return not (isinstance(new, int) and new in (1, 2, 3, 4, 8, 16))
        return None
    if isinstance(old, bool):
        return not isinstance(new, bool)
    if isinstance(old, str):
        if not isinstance(new, str):
            return key not in ("ux", "uy")  # an expression key also takes a number
        if key in ENUMS:
            return new not in ENUMS[key]
        if key in REFS:
            return True  # the pool holds no existing curve name
        if key in ("name",):
            return True if not new else None
        return None
    if isinstance(old, list):
        if not isinstance(new, list):
            return True
        if key in VECTOR2:
            return len(new) != 2 or None
        if key in ("curves", "points") and not new:
            return None
        if key in ("history",):
            return None
        return True if not new else (None if key in ("curves", "points") else True)
    if isinstance(old, dict):
        return not isinstance(new, dict)
    return None


def _domain_key(path: tuple, key: str) -> str:
    """The key whose value domain applies: a [parameters] name is a free number (a
    parameter called nu is not a Poisson ratio)."""
    return "parameter" if path[0] == "parameters" else key


# ------------------------------------------------------------------ the cases


@dataclass
class Case:
    """One fuzz case: a command line with placeholders {CONFIG} {OUT} {CASE}, and what
    the config file is (a copy of `config`, mutated `toml` text, raw bytes, a folder)."""

    id: int
    family: str
    desc: str
    config: str  # shipped config it starts from (relative to ROOT)
    argv: list[str]
    toml: str | None = None  # mutated config text written to {CASE}/config.toml
    raw_bytes: bytes | None = None  # written as is instead (broken encodings)
    config_kind: str = "copy"  # copy | text | bytes | dir | missing
    msh: str | None = None  # a mutated gmsh mesh written to {CASE}/mesh.msh
    must_fail: bool | None = None
    expect_summary: bool = True  # exit 2 must leave OUT/summary.json `failed`
    extra: dict = field(default_factory=dict)


def leaves(raw: Any, path: tuple = ()) -> list[tuple[tuple, Any, Any, Any]]:
    """(set path, container, key, value) of every leaf: arrays of tables by entry name
    (or index when unnamed or the name is not unique)."""
    out = []
    if isinstance(raw, dict):
        for k, v in raw.items():
            if k == "petsc":
                continue
            if isinstance(v, dict):
                out += leaves(v, path + (k,))
                out.append((path + (k,), raw, k, v))
            elif isinstance(v, list) and v and all(isinstance(t, dict) for t in v):
                names = [t.get("name") for t in v]
                for i, t in enumerate(v):
                    nm = t.get("name")
                    part = nm if isinstance(nm, str) and names.count(nm) == 1 \
                        and "." not in nm and not nm.isdigit() else str(i)
                    out += leaves(t, path + (k, part))
            else:
                out.append((path + (k,), raw, k, v))
    return out


def cheap_args(raw: dict) -> list[str]:
    """--mesh-size 4x the config's (none for a mesh.file) so that every case is fast."""
    mesh = raw.get("mesh", {})
    if "size" in mesh and not mesh.get("file"):
        return ["--mesh-size", repr(4.0 * float(mesh["size"]))]
    return []


def without_mesh_size(argv: list[str]) -> list[str]:
    """argv without its `--mesh-size H` pair."""
    if "--mesh-size" not in argv:
        return list(argv)
    i = argv.index("--mesh-size")
    return argv[:i] + argv[i + 2:]


def toml_value(v: Any) -> str:
    """v as a TOML inline value."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {toml_value(x)}"
                               for k, x in v.items()) + "}"
    raise TypeError(type(v))


def dump_toml(raw: dict) -> str:
    """A config dict as TOML: one `key = inline value` line per top-level key."""
    return "".join(f"{json.dumps(str(k))} = {toml_value(v)}\n" for k, v in raw.items())


def absolute_mesh_file(raw: dict, config: Path) -> None:
    """mesh.file relative to the shipped config made absolute (the copy lives elsewhere)."""
    mesh = raw.get("mesh")
    if isinstance(mesh, dict) and isinstance(mesh.get("file"), str):
        mesh["file"] = str((config.parent / mesh["file"]).resolve())


# --- structural edits of a config (the `structure` family): each edits the parsed file
# raw in place and returns (must_fail, description or None for the edit's name)


def _dup_body(rng: random.Random, raw: dict) -> tuple[bool | None, str | None]:
    raw["body"].append(copy.deepcopy(rng.choice(raw["body"])))
    return True, None


def _dup_interface(rng: random.Random, raw: dict) -> tuple[bool | None, str | None]:
    if not raw.get("interface"):
        return _dup_support(rng, raw)[0], None  # no interface to repeat: a support
    raw["interface"].append(copy.deepcopy(rng.choice(raw["interface"])))
    return True, None


def _unknown_key(rng: random.Random, raw: dict) -> tuple[bool | None, str | None]:
    tables = [raw] + [t for _, _, _, v in leaves(raw) if isinstance(v, dict)
                      for t in [v]] + [t for k in ("body", "support", "load", "interface")
                                       for t in raw.get(k, [])]
    t = rng.choice(tables)
    fail = True
    if t is raw.get("parameters") or t is raw.get("points") or \
            any(t is b.get("curves") for b in raw["body"]):
        fail = None  # user names: any key is allowed there
    name = rng.choice(["younng", "sizee", "Nu", "\u00fcber", "x" * 300, "steps "])
    t[name] = 1.0
    return fail, f"unknown key {name[:20]!r}"


def _dangling(rng: random.Random, raw: dict) -> tuple[bool | None, str | None]:
    refs = [(t, k) for s in ("support", "load", "interface") for t in raw.get(s, [])
            for k in ("on", "slave", "master") if k in t]
    refs += [(r, "curves") for r in raw.get("mesh", {}).get("refine", []) if r.get("curves")]
    t, k = rng.choice(refs)
    bad = rng.choice(["nowhere", "", "\u00fcnknown", "x" * 2000, "block top"])
    t[k] = [bad] if k == "curves" else bad
    return True, f"dangling {k} -> {bad[:20]!r}"


def _empty_array(rng: random.Random, raw: dict) -> tuple[bool | None, str | None]:
    k = rng.choice(["body", "support", "load", "interface"])
    raw[k] = []
    return (True if k == "body" else None), f"{k} = []"


def _table_scalar(rng: random.Random, raw: dict) -> tuple[bool | None, str | None]:
    k = rng.choice([k for k in raw if k != "title"])
    raw[k] = rng.choice([1.0, "text", [1, 2], True])
    return True, f"{k} = scalar"


def _swap_ref(rng: random.Random, raw: dict) -> tuple[bool | None, str | None]:
    curves = sorted({c for b in raw["body"] for c in b.get("curves", {}).values()})
    refs = [t for s in ("support", "load") for t in raw.get(s, [])]
    if not (curves and refs):
        return None, None
    t = rng.choice(refs)
    t["on"] = rng.choice(curves)
    return None, f"on -> {t['on']}"


def _dup_support(rng: random.Random, raw: dict) -> tuple[bool | None, str | None]:
    if raw.get("support"):
        raw["support"].append(copy.deepcopy(rng.choice(raw["support"])))
    return None, None


STRUCTURE_EDITS: dict[str, Callable[[random.Random, dict], tuple[bool | None, str | None]]] = {
    "dup_body": _dup_body, "dup_interface": _dup_interface, "unknown_key": _unknown_key,
    "dangling": _dangling, "empty_array": _empty_array, "table_scalar": _table_scalar,
    "swap_ref": _swap_ref, "dup_support": _dup_support,
}
"""The `structure` family's edits by name (the order is the random choice's)."""


# --- command-line edits (the `cli_run` family): each edits case.argv (and the case's
# expectations) for option opt and returns whether argparse must refuse it (usage error)


def _cli_mesh_size(rng: random.Random, case: Case, opt: str) -> bool:
    v = rng.choice(["0", "-1", "nan", "inf", "1e-9", "abc", "", "-0", "1e-300"])
    case.argv = without_mesh_size(case.argv) + [opt, v]
    return v in ("abc", "")


def _cli_sd(rng: random.Random, case: Case, opt: str) -> bool:
    v = rng.choice(["0", "5", "-1", "100", "abc", "1.5", "99999999999999999999"])
    case.argv += [opt, v]
    return v in ("abc", "1.5")


def _cli_method(rng: random.Random, case: Case, opt: str) -> bool:
    case.argv += [opt, rng.choice(["fem", "", "CS-FEM", "q4"])]
    return True


def _cli_refine(rng: random.Random, case: Case, opt: str) -> bool:
    v = rng.choice(["-1", "9", "100", "1.5", "abc", "99999999999999999999"])
    case.argv += [opt, v]
    return v in ("1.5", "abc")


def _cli_path(rng: random.Random, case: Case, opt: str) -> bool:
    v = rng.choice(["", " ", "/proc/fuzz_out", "/dev/null", "{CASE}/afile",
                    "{CASE}/afile/sub", "{CASE}/" + "n" * 300])
    if opt == "--out":
        case.argv[case.argv.index("--out") + 1] = v
    else:
        case.argv += [opt, v]
    case.expect_summary = opt == "--mesh-cache"
    case.extra["afile"] = True
    return False


def _cli_petsc(rng: random.Random, case: Case, opt: str) -> bool:
    v = rng.choice([["-ksp_type", "bogus"], ["-pc_type", "bogus"],
                    ["-pc_factor_mat_solver_type", "bogus"], ["-ksp_type"],
                    ["-ksp_rtol", "-1"], ["-ksp_rtol", "nan"],
                    ["-ksp_max_it", "-5"], ["-mat_mumps_icntl_14", "abc"],
                    ["-log_view", ":/proc/nope/log.txt"],
                    ["-options_file", "/nonexistent/opts"],
                    ["-ksp_type", "cg", "-pc_type", "none"],
                    ["-pc_type", "gamg"], ["-mat_mumps_icntl_24", "x"]])
    case.argv += v
    case.desc = " ".join(v)
    case.must_fail = None
    return False


def _cli_flag(rng: random.Random, case: Case, opt: str) -> bool:
    case.must_fail = None
    case.argv += [opt]
    return False


CLI_EDITS: dict[str, Callable[[random.Random, Case, str], bool]] = {
    "--mesh-size": _cli_mesh_size, "--sd": _cli_sd, "--method": _cli_method,
    "--refine": _cli_refine, "--out": _cli_path, "--mesh-cache": _cli_path,
    "petsc": _cli_petsc,
}
"""The `cli_run` family's edits by option (any other option: `_cli_flag`, a bare flag)."""


class Generator:
    """Random cases from a list of shipped configs (deterministic for a seed)."""

    def __init__(self, seed: int, configs: list[str], families: list[str] | None = None):
        self.rng = random.Random(seed)
        self.configs = configs
        self.raw = {c: tomllib.loads((ROOT / c).read_text()) for c in configs}
        self.families = [
            (self.set_value, 30), (self.file_value, 12), (self.list_element, 6),
            (self.drop_key, 10), (self.structure, 12), (self.broken_file, 8),
            (self.cli_run, 12), (self.set_syntax, 4), (self.study, 6),
            (self.add_entry, 6), (self.petsc_table, 4), (self.msh_file, 5),
            (self.scaled_value, 10),
        ]
        if families:
            unknown = set(families) - {f.__name__ for f, _ in self.families}
            if unknown:
                raise ValueError(f"--families: unknown families {sorted(unknown)}; the "
                                 f"families: {', '.join(f.__name__ for f, _ in self.families)}")
            self.families = [(f, w) for f, w in self.families if f.__name__ in families]

    def cases(self, n: int) -> list[Case]:
        funcs = [f for f, w in self.families for _ in range(w)]
        out = []
        for i in range(n):
            cfg = self.rng.choice(self.configs)
            case = self.rng.choice(funcs)(cfg)
            case.id = i
            out.append(case)
        return out

    def base(self, cfg: str, family: str, desc: str, extra: list[str] | None = None,
             **kw: Any) -> Case:
        argv = ["run", "{CONFIG}", "--out", "{OUT}", "--quiet", *cheap_args(self.raw[cfg]),
                *(extra or [])]
        return Case(0, family, desc, cfg, argv, **kw)

    def pick_leaf(self, cfg: str, scalar_only: bool = False) -> tuple:
        lv = [x for x in leaves(self.raw[cfg])
              if not scalar_only or not isinstance(x[3], dict | list)]
        return self.rng.choice(lv)

    def text_of(self, cfg: str, raw: dict) -> str:
        absolute_mesh_file(raw, ROOT / cfg)
        return dump_toml(raw)

    # --- families

    def set_value(self, cfg: str) -> Case:
        path, _, key, old = self.pick_leaf(cfg)
        text, new = self.rng.choice(BAD_SCALARS)
        sets = ["--set", f"{'.'.join(path)}={text}"]
        case = self.base(cfg, "set_value", f"--set {'.'.join(path)}={text[:40]}", sets,
                         must_fail=must_fail(_domain_key(path, key), old, new))
        if path == ("mesh", "size"):  # mesh.size itself: no --mesh-size
            case.argv = without_mesh_size(case.argv)
        return case

    def file_value(self, cfg: str) -> Case:
        raw = copy.deepcopy(self.raw[cfg])
        path, cont, key, old = self.rng.choice(leaves(raw))
        text, new = self.rng.choice(BAD_SCALARS + [("huge", h) for h in HUGE_COUNTS])
        if key in ("steps", "divisions", "sd") and self.rng.random() < 0.5:
            new = self.rng.choice(HUGE_COUNTS)
            new = [new, new] if key == "divisions" else new
        cont[key] = new
        return self.base(cfg, "file_value", f"file {'.'.join(path)} = {repr(new)[:40]}",
                         toml=self.text_of(cfg, raw), config_kind="text",
                         must_fail=must_fail(_domain_key(path, key), old, new))

    def scaled_value(self, cfg: str) -> Case:
        """A number (or every number of a list) scaled by a factor: mostly values the
        checks accept, which then have to run or fail cleanly (no NaN, no traceback)."""
        raw = copy.deepcopy(self.raw[cfg])
        nums = [x for x in leaves(raw) if x[0][0] != "petsc" and (
            isinstance(x[3], float) or isinstance(x[3], list) and x[3]
            and all(isinstance(v, float) for v in x[3]))]
        path, cont, key, old = self.rng.choice(nums)
        f = self.rng.choice([1e-12, 1e-6, 1e-3, 0.1, 0.5, 2.0, 10.0, 1e3, 1e6, 1e12, -1.0,
                             0.0])
        new = [v * f for v in old] if isinstance(old, list) else old * f
        cont[key] = new
        fail = must_fail(_domain_key(path, key), old, new) if not isinstance(old, list) \
            else None
        return self.base(cfg, "scaled_value", f"file {'.'.join(path)} x {f:g}",
                         toml=self.text_of(cfg, raw), config_kind="text", must_fail=fail)

    def list_element(self, cfg: str) -> Case:
        raw = copy.deepcopy(self.raw[cfg])
        lists = [x for x in leaves(raw) if isinstance(x[3], list) and x[3]
                 and not isinstance(x[3][0], dict)]
        if not lists:
            return self.file_value(cfg)
        path, cont, key, old = self.rng.choice(lists)
        i = self.rng.randrange(len(old))
        _, new = self.rng.choice(BAD_SCALARS)
        elem = old[i]
        cont[key] = old[:i] + [new] + old[i + 1:]
        fail = None
        if isinstance(elem, int | float) and not isinstance(elem, bool):
            if not (isinstance(new, int | float) and not isinstance(new, bool)) \
                    or isinstance(new, float) and not math.isfinite(new):
                fail = key not in ("traction",) or not isinstance(new, str) or None
            elif key in ("divisions",):
                fail = not (isinstance(new, int) and new >= 1) or None
            elif key in ("ramp",):
                fail = not isinstance(new, int) or None
        elif isinstance(elem, list) and not isinstance(new, list):
            fail = True
        elif isinstance(elem, str) and key == "curves":
            fail = True if not isinstance(new, str) or new != elem else None
        return self.base(cfg, "list_element", f"file {'.'.join(path)}[{i}] = {repr(new)[:40]}",
                         toml=self.text_of(cfg, raw), config_kind="text", must_fail=fail)

    def drop_key(self, cfg: str) -> Case:
        raw = copy.deepcopy(self.raw[cfg])
        choices = [x for x in leaves(raw)] + [((k,), raw, k, v) for k, v in raw.items()]
        path, cont, key, _ = self.rng.choice(choices)
        del cont[key]
        file_mesh = isinstance(raw.get("mesh"), dict) and "file" in raw["mesh"]
        fail = key in REQUIRED and not (file_mesh and key in ("shape", "type", "origin"))
        if path in (("mesh",), ("body",), ("mesh", "size")) and not file_mesh:
            fail = True
        return self.base(cfg, "drop_key", f"drop {'.'.join(path)}",
                         toml=self.text_of(cfg, raw), config_kind="text",
                         must_fail=fail or None)

    def structure(self, cfg: str) -> Case:
        """A structural edit of the file (`STRUCTURE_EDITS`, one picked at random)."""
        raw = copy.deepcopy(self.raw[cfg])
        kind = self.rng.choice(list(STRUCTURE_EDITS))
        fail, desc = STRUCTURE_EDITS[kind](self.rng, raw)
        return self.base(cfg, "structure", desc or kind, toml=self.text_of(cfg, raw),
                         config_kind="text", must_fail=fail)

    def broken_file(self, cfg: str) -> Case:
        text = (ROOT / cfg).read_text()
        raw = copy.deepcopy(self.raw[cfg])
        kind = self.rng.choice(["truncate", "garbage", "empty", "blank", "binary", "latin1",
                                "bom", "dir", "missing", "nested", "dup_table", "missing_msh",
                                "msh_dir", "msh_empty", "msh_text"])
        case = self.base(cfg, "broken_file", kind, config_kind="text", must_fail=True)
        if kind == "truncate":
            cut = self.rng.randrange(1, max(2, len(text)))
            case.toml = text[:cut]
            case.must_fail = None  # a cut at a line end may still be a valid config
        elif kind == "garbage":
            lines = text.splitlines()
            i = self.rng.randrange(len(lines) + 1)
            lines.insert(i, self.rng.choice(["= = =", "[[", "x = [1, 2", "a = 'b",
                                             "[analysis", "\u00ff\u00fe = 1", "key"]))
            case.toml = "\n".join(lines)
        elif kind == "empty":
            case.toml = ""
        elif kind == "blank":
            case.toml = "\n   \n# only a comment\n"
        elif kind in ("binary", "latin1"):
            case.config_kind = "bytes"
            case.raw_bytes = (os.urandom(0) + bytes(range(256)) if kind == "binary" else
                              text.encode() + "\n# caf\u00e9\n".encode("latin-1"))
        elif kind == "bom":
            case.toml = "\ufeff" + text
            case.must_fail = None
        elif kind == "dir":
            case.config_kind = "dir"
        elif kind == "missing":
            case.config_kind = "missing"
        elif kind == "nested":
            case.toml = text + "\nzz = " + "[" * 5000 + "]" * 5000 + "\n"
        elif kind == "dup_table":
            case.toml = text + "\n[analysis]\nsteps = 1\n"
        else:
            mesh = raw.setdefault("mesh", {})
            for k in ("size", "refine", "patch", "algorithm"):
                mesh.pop(k, None)
            mesh["file"] = {"missing_msh": "{CASE}/nothere.msh", "msh_dir": "{CASE}",
                            "msh_empty": "{CASE}/empty.msh",
                            "msh_text": "{CASE}/config.toml"}[kind]
            case.toml = dump_toml(raw)
            case.argv = without_mesh_size(case.argv)
        return case

    def cli_run(self, cfg: str) -> Case:
        """A bad command-line option or PETSc option (`CLI_EDITS`, one picked at random)."""
        opt = self.rng.choice(["--mesh-size", "--sd", "--method", "--refine", "--out",
                               "--mesh-cache", "petsc", "petsc", "--energy-bracket"])
        case = self.base(cfg, "cli_run", opt, must_fail=True)
        usage = CLI_EDITS.get(opt, _cli_flag)(self.rng, case, opt)
        if usage:  # argparse's error: OUT/summary.json says failed too
            case.extra["usage"] = True
        if opt == "--out":
            case.desc = f"{opt} {case.argv[case.argv.index('--out') + 1]!r}"
        elif opt != "petsc":
            case.desc = f"{opt} {case.argv[-1]!r}"
        return case

    def add_entry(self, cfg: str) -> Case:
        """A new [[...]] entry (or [points] name) through --set, partly filled in."""
        raw = self.raw[cfg]
        curves = sorted({c for b in raw["body"] for c in b.get("curves", {}).values()}) \
            or ["nowhere"]
        n = {k: len(raw.get(k, [])) for k in ("body", "support", "load", "interface")}
        c1, c2 = self.rng.choice(curves), self.rng.choice(curves)
        b, su, lo, it = n["body"], n["support"], n["load"], n["interface"]
        options = [  # (the --set strings, must they fail?)
            ([f"body.{b}.name=extra", f"body.{b}.E=1.0"], True),
            ([f"body.{b}.name=extra", f"body.{b}.E=1.0", f"body.{b}.nu=0.3",
              f"body.{b}.shape={{type = \"disk\", center = [0.0, 0.0], radius = 0.3}}"], None),
            ([f"support.{su}.on={c1}"], True),
            ([f"support.{su}.on={c1}", f"support.{su}.ux=nan"], True),
            ([f"load.{lo}.on={c1}", f"load.{lo}.pressure=1e300"], None),
            ([f"load.{lo}.on={c1}", f"load.{lo}.traction=[\"x/0\", 0.0]"], True),
            ([f"interface.{it}.slave={c1}", f"interface.{it}.master={c2}",
              f"interface.{it}.search_distance=0.1"], True if c1 == c2 else None),
            (["points.extra=[1e300, 0.0]"], True), (["points.extra=[0.0]"], True),
            ([f"points.{c1}=[0.0, 0.0]"], True if c1 != "nowhere" else None),
            (["mesh.patch.0.box=[0.0, 0.0, 0.0, 0.0]", "mesh.patch.0.size=0.1"], True),
            # (structured bodies ignore patches, README: refused or without effect)
            (["mesh.patch.0.box=[-1e6, -1e6, 1e6, 1e6]", "mesh.patch.0.size=1e-9"], None),
            (["mesh.refine.9.size=0.1"], True),
            (["mesh.refine.0.curves=[]", "mesh.refine.0.points=[]"], True),
            (["reference.type=hertz"], None),
            (["reference.type=timoshenko", "reference.P=nan"], True),
        ]
        sets, fail = self.rng.choice(options)
        argv = [a for s_ in sets for a in ("--set", s_)]
        return self.base(cfg, "add_entry", " ".join(sets)[:70], argv, must_fail=fail)

    def petsc_table(self, cfg: str) -> Case:
        """A [petsc] value of the config (through --set and in the file)."""
        key = self.rng.choice(["ksp_type", "pc_type", "ksp_rtol", "mat_mumps_icntl_14",
                               "ksp_max_it", "options_left", "no_such_option", "log_view",
                               "pc_factor_mat_solver_type", "ksp_view"])
        text, value = self.rng.choice(BAD_SCALARS)
        if self.rng.random() < 0.5:
            return self.base(cfg, "petsc_table", f"--set petsc.{key}={text[:30]}",
                             ["--set", f"petsc.{key}={text}"])
        raw = copy.deepcopy(self.raw[cfg])
        raw.setdefault("petsc", {})[key] = value
        return self.base(cfg, "petsc_table", f"file petsc.{key} = {repr(value)[:30]}",
                         toml=self.text_of(cfg, raw), config_kind="text")

    def msh_file(self, cfg: str) -> Case:
        """meshes/punch.toml on a mutated copy of meshes/punch.msh (whatever `cfg`)."""
        cfg = "meshes/punch.toml"
        lines = (ROOT / "meshes/punch.msh").read_text().splitlines()
        kind = self.rng.choice(["truncate", "drop_line", "dup_line", "number", "number",
                                "rename", "version", "shuffle_block"])
        i = self.rng.randrange(len(lines))
        if kind == "truncate":
            lines = lines[:i]
        elif kind == "drop_line":
            del lines[i]
        elif kind == "dup_line":
            lines.insert(i, lines[i])
        elif kind == "number":
            toks = lines[i].split(" ")
            j = self.rng.randrange(len(toks))
            toks[j] = self.rng.choice(["nan", "inf", "-1", "0", "1e308", "99999999",
                                       "-99999999", "0.5", "x", ""])
            lines[i] = " ".join(toks)
        elif kind == "rename":
            k = next(n for n, ln in enumerate(lines) if ln == "$PhysicalNames")
            j = k + 2 + self.rng.randrange(int(lines[k + 1]))
            lines[j] = lines[j].rsplit(" ", 1)[0] + ' "' + self.rng.choice(
                ["block", "punch_top", "", "x" * 300, "bl\u00f6ck"]) + '"'
        elif kind == "version":
            lines[1] = self.rng.choice(["2.2 0 8", "4.1 1 8", "3.0 0 8", "9 0 8", "4.1 0 4"])
        else:
            j = self.rng.randrange(max(1, len(lines) - 20))
            lines[j:j + 20] = lines[j:j + 20][::-1]
        raw = copy.deepcopy(self.raw.get(cfg) or tomllib.loads((ROOT / cfg).read_text()))
        raw["mesh"]["file"] = "{CASE}/mesh.msh"
        return Case(0, "msh_file", f"punch.msh {kind} at line {i}", cfg,
                    ["run", "{CONFIG}", "--out", "{OUT}", "--quiet"], toml=dump_toml(raw),
                    config_kind="text", msh="\n".join(lines) + "\n", must_fail=None)

    def set_syntax(self, cfg: str) -> Case:
        body = self.raw[cfg]["body"][0].get("name", "0")
        v = self.rng.choice(["noequals", "=5", ".=1", "a..b=1", "body.99.E=1",
                             f"body.{body}.E.x=1", "analysis=5", "body=5", "mesh=[]",
                             "support=1", "analysis.steps=", f"body.{body}=1",
                             "interface.nope.mu=1", "body.-1.E=1", "x" * 3000 + "=1",
                             "analysis.steps=[[[[[[[[[[1]]]]]]]]]]",
                             "analysis.steps=" + "[" * 3000])
        return self.base(cfg, "set_syntax", f"--set {v[:40]}", ["--set", v], must_fail=True)

    def study(self, cfg: str) -> Case:
        raw = self.raw[cfg]
        sweep = self.rng.random() < 0.5
        base = ["study", "{CONFIG}", "--out", "{OUT}", "--quiet", *cheap_args(raw)]
        if sweep:
            mu = [f"interface.{t.get('name', i)}.mu" for i, t in
                  enumerate(raw.get("interface", []))] or ["body.0.E"]
            v = self.rng.choice([["--sweep", "noequals"], ["--sweep", f"{mu[0]}="],
                                 ["--sweep", f"{mu[0]}=a,b"], ["--sweep", "nope.key=1,2"],
                                 ["--sweep", "analysis.steps=0,1"], ["--sweep", f"{mu[0]}=,,"],
                                 ["--sweep", f"{mu[0]}=nan,1"],
                                 ["--sweep", f"{mu[0]}=0.1", "--at-step", "99"],
                                 ["--sweep", f"{mu[0]}=0.1", "--at-step", "-99"],
                                 ["--sweep", f"{mu[0]}=0.1", "--refine", "-1"],
                                 ["--sweep", f"{mu[0]}=0.1", "--levels", "2"]])
        else:
            v = self.rng.choice([["--levels", "0"], ["--levels", "-1"], ["--levels", "1000"],
                                 ["--methods", ""], ["--methods", "5"], ["--methods", "q4,,"],
                                 ["--methods", "abc"], ["--first-level", "-1"],
                                 ["--first-level", "50"], ["--reference-levels", "-1"],
                                 ["--reference-levels", "9"],
                                 ["--reference-method", "BOGUS", "--levels", "1"],
                                 ["--levels", "1", "--methods", "4", "--refine", "2"]])
        case = Case(0, "study", " ".join(v)[:60], cfg, base + v, config_kind="copy")
        # a sweep goes on after a run that fails: it fails only when every run does
        some_valid = v[1].endswith(("=nan,1", "=0,1")) or v[-2:] == ["--at-step", "-99"]
        case.must_fail = None if some_valid else True
        return case


def regression_cases() -> list[Case]:
    """One case of each BUG class this fuzzer found and that was fixed (all were BUG
    before the fix; see README "Input checks", the fuzzer)."""
    run = ["run", "{CONFIG}", "--out", "{OUT}", "--quiet"]
    long_name = "n" * 300
    cases = [
        Case(0, "regression", "a 5000-character value quoted back (error line length)",
             "configs/patch.toml", run + ["--set", 'interface.interface.search_distance="'
                                          + "x" * 5000 + '"'], must_fail=True),
        Case(0, "regression", "--out with a 300-character name (OSError traceback)",
             "configs/patch.toml", ["run", "{CONFIG}", "--out", "{CASE}/" + long_name,
                                    "--quiet"], expect_summary=False),
        Case(0, "regression", "config path with a 300-character name (OSError traceback)",
             "configs/patch.toml", ["run", "{CASE}/" + long_name + ".toml", "--out", "{OUT}",
                                    "--quiet"], must_fail=True),
        Case(0, "regression", "-options_file that does not exist (PETSc start traceback)",
             "configs/patch.toml", run + ["-options_file", "/nonexistent/opts"]),
        Case(0, "regression", "-history in a folder that does not exist (segfault)",
             "configs/patch.toml", run + ["-history", "/proc/x/y"]),
        Case(0, "regression", "no load at all (kkt.complementarity NaN)",
             "configs/two_blocks.toml", run + ["--mesh-size", "1.0", "--set", "load=[]"]),
        Case(0, "regression", "reference.point a list (TypeError traceback after the run)",
             "configs/cantilever.toml", run + ["--mesh-size", "0.5", "--set",
                                               "reference.point=[1.0, 2.0]"], must_fail=True),
        Case(0, "regression", "-log_view 1 from [petsc] (PETSc error at exit 0)",
             "configs/patch.toml", run + ["--set", 'petsc.log_view="1"']),
        Case(0, "regression", "-log_view ::ascii_xml from [petsc] (segfault)",
             "configs/patch.toml", run + ["--set", 'petsc.log_view="::ascii_xml"']),
        Case(0, "regression", "reference.center_x=1e308 (-inf contact edges at exit 0)",
             "configs/hertz.toml", run + ["--mesh-size", "2.0", "--set",
                                          "reference.center_x=1e308"]),
    ]
    for i, c in enumerate(cases):
        c.id = 10_000 + i
    return cases


# ------------------------------------------------------------------ running one case


def materialise(case: Case, case_dir: Path) -> list[str]:
    """Write the case's config into case_dir; the argv with placeholders filled in."""
    cfile = case_dir / "config.toml"
    if case.config_kind == "copy":
        raw = tomllib.loads((ROOT / case.config).read_text())
        absolute_mesh_file(raw, ROOT / case.config)
        cfile.write_text(dump_toml(raw))
    elif case.config_kind == "text":
        cfile.write_text((case.toml or "").replace("{CASE}", str(case_dir)))
    elif case.config_kind == "bytes":
        cfile.write_bytes(case.raw_bytes or b"")
    elif case.config_kind == "dir":
        cfile.mkdir()
    (case_dir / "empty.msh").write_text("")
    if case.msh is not None:
        (case_dir / "mesh.msh").write_text(case.msh)
    (case_dir / "afile").write_text("not a folder\n")
    sub = {"{CONFIG}": str(cfile), "{OUT}": str(case_dir / "out"), "{CASE}": str(case_dir)}
    argv = []
    for a in case.argv:
        for k, v in sub.items():
            a = a.replace(k, v)
        argv.append(a)
    return argv


def finite_numbers(obj: Any, path: str = "") -> str | None:
    """The path of the first non-finite number in a JSON document, or None. NaN under
    `.reference` is allowed: the documented 'no closed form' of a contact that carries no
    force (tests/test_reference_unloaded.py)."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return None if math.isnan(obj) and path.startswith(".reference.") else path or "."
    if isinstance(obj, dict):
        for k, v in obj.items():
            if k == "provenance":
                continue
            bad = finite_numbers(v, f"{path}.{k}")
            if bad:
                return bad
    if isinstance(obj, list):
        for i, v in enumerate(obj):
            bad = finite_numbers(v, f"{path}[{i}]")
            if bad:
                return bad
    return None


def read_summary(out: Path) -> tuple[dict | None, str | None]:
    f = out / "summary.json"
    if not f.is_file():
        return None, None
    try:
        return json.loads(f.read_text()), None
    except ValueError as exc:
        return None, f"summary.json is not JSON: {exc}"


USAGE_LINE = re.compile(r"^python -m app( \w+)?: error: ")
BATCH_LINE = re.compile(r"^\[ *[0-9.]+ s\] .*: failed: ")
"""A study's or sweep's line for a run that failed (it goes on with the next run)."""


MPI_BOX = re.compile(r"^-{20,}\n(?:.*\n)*?-{20,}\n?", re.M)
"""Open MPI's boxed note on a rank's non-zero exit ("Primary job terminated normally, but 1
process returned a non-zero exit code ..."): mpiexec's, printed for every exit 2."""


def classify(case: Case, rc: int | None, stderr: str, out: Path) -> tuple[str, str]:
    """('OK' | 'CLEAN_ERROR' | 'BUG', reason)."""
    stderr = MPI_BOX.sub("", stderr)
    if rc is None:
        return "BUG", "timeout"
    if "Traceback (most recent call last)" in stderr:
        return "BUG", "traceback: " + stderr.strip().splitlines()[-1][:200]
    for s in sorted(out.rglob("summary.json")) if out.is_dir() else []:
        try:
            st = json.loads(s.read_text()).get("status")
        except ValueError:
            return "BUG", f"{s.relative_to(out)} is not JSON"
        if st == "running":
            return "BUG", f"{s.relative_to(out)} left at status running"
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    if rc == 0:
        if case.must_fail:
            return "BUG", "accepted an invalid value (exit 0)"
        summary, bad = read_summary(out)
        if summary is None:
            return "BUG", bad or "exit 0 without summary.json"
        if summary.get("status") != "completed":
            return "BUG", f"exit 0 with status {summary.get('status')!r}"
        if case.argv[0] != "run":  # a study's own summary.json: no figures
            return "OK", ""
        where = finite_numbers(summary)
        if where:
            return "BUG", f"exit 0 with a non-finite number at {where}"
        return "OK", ""
    if rc != 2:
        return "BUG", f"exit status {rc}: " + (lines[-1][:200] if lines else "")
    if lines and USAGE_LINE.match(lines[-1]):
        bad = failed_summary_problem(case, out)
        if bad:
            return "BUG", bad
        return ("CLEAN_ERROR", "usage") if case.extra.get("usage") or not case.expect_summary \
            else ("CLEAN_ERROR", "usage (unexpected)")
    errors = [ln for ln in lines if ln.startswith("error: ")]
    others = [ln for ln in lines if not ln.startswith(("error: ", "warning: "))
              and not (case.argv[0] == "study" and BATCH_LINE.match(ln))]
    if len(errors) != 1 or lines[-1] != errors[0] or others:
        return "BUG", f"not one error line: {len(errors)} error lines, {len(others)} others: " \
            + " | ".join(lines)[:300]
    if len(errors[0]) > len("error: ") + MAX_MESSAGE:  # app/errors.py cuts longer ones
        return "BUG", f"error line of {len(errors[0])} characters"
    bad = failed_summary_problem(case, out)
    if bad:
        return "BUG", bad
    return "CLEAN_ERROR", errors[0][7:120]


def failed_summary_problem(case: Case, out: Path) -> str | None:
    """After exit 2: why OUT/summary.json does not say `failed` with an `error` (a run's
    or a study's; also after argparse's usage error), or None."""
    if not (case.expect_summary and case.argv[0] in ("run", "study") and out.is_dir()
            and not case.config_kind == "missing"):
        return None
    summary, bad = read_summary(out)
    if summary is None:
        return bad or "exit 2 without OUT/summary.json"
    if summary.get("status") != "failed" or not summary.get("error"):
        return f"exit 2 with status {summary.get('status')!r}"
    return None


BIG_MODEL = 1e5
"""Elements (the app's own estimate before meshing) above which a timeout is a big valid
model the size check accepted (verdict SLOW), not a hang."""


def estimated_elements(argv: list[str]) -> float:
    """The app's size estimate (elements) of a `run`/`study` command line; 0 if none."""
    try:
        from app.config import load_config
        from app.mesh.estimate import estimate

        sets = [argv[i + 1] for i, a in enumerate(argv) if a == "--set"]
        cfg = load_config(argv[1], sets)
        scale = 1.0
        if "--mesh-size" in argv:
            scale = float(argv[argv.index("--mesh-size") + 1]) / cfg.mesh_size
        est = estimate(cfg.scene, scale)
        return est.elements if est else 0.0
    except Exception:  # the config does not load: no estimate
        return 0.0


def run_case(case: Case, work: Path, timeout: float, ranks: int, keep: bool) -> dict:
    case_dir = work / f"case_{case.id:04d}"
    case_dir.mkdir(parents=True)
    argv = materialise(case, case_dir)
    cmd = [sys.executable, "-m", "app", *argv]
    if ranks > 1:
        cmd = [shutil.which("mpiexec") or "mpiexec", "-n", str(ranks), *cmd]
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
               OMPI_MCA_rmaps_base_oversubscribe="1")
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, cwd=case_dir, env=env, capture_output=True, text=True,
                           timeout=timeout, errors="replace", start_new_session=True)
        rc, stderr = p.returncode, p.stderr
    except subprocess.TimeoutExpired as exc:
        rc, stderr = None, (exc.stderr or b"").decode(errors="replace") \
            if isinstance(exc.stderr, bytes) else (exc.stderr or "")
    seconds = time.perf_counter() - t0
    verdict, reason = classify(case, rc, stderr, case_dir / "out")
    if reason == "timeout" and estimated_elements(argv) > BIG_MODEL:
        verdict, reason = "SLOW", f"timeout on a model of {estimated_elements(argv):.3g} " \
            "estimated elements (accepted by the size check)"
    result = {"id": case.id, "verdict": verdict, "reason": reason, "family": case.family,
              "desc": case.desc, "config": case.config, "exit": rc,
              "seconds": round(seconds, 2), "argv": argv}
    if verdict == "BUG":
        result["stderr_tail"] = stderr.strip().splitlines()[-3:]
        if case.toml is not None:
            result["toml_file"] = str(case_dir / "config.toml")
    if not keep and verdict != "BUG":
        shutil.rmtree(case_dir, ignore_errors=True)
    return result


def bug_class(r: dict) -> str:
    """A short key that groups BUG results of one cause."""
    reason = re.sub(r"\d+(\.\d+)?(e[-+]?\d+)?", "N", r["reason"])[:80]
    return f"{r['family']}: {reason}"


def select_configs(patterns: list[str]) -> list[str]:
    files = sorted({str(Path(f).resolve().relative_to(ROOT)) for pat in patterns
                    for f in glob.glob(str(ROOT / pat))})
    if not files:
        raise ValueError(f"--configs: no config matches {patterns}")
    return files


def generate_cases(seed: int, n: int, configs: list[str] | None = None,
                   families: list[str] | None = None) -> list[Case]:
    """The first n cases of the generator for `seed` (for tests and the command line)."""
    return Generator(seed, configs or select_configs(list(DEFAULT_CONFIGS)),
                     families).cases(n)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cases", type=int, default=200)
    ap.add_argument("--timeout", type=float, default=90.0, help="seconds per case")
    ap.add_argument("--configs", action="append", default=None, metavar="GLOB",
                    help="config files (relative to the repository; repeatable); default "
                    "configs/*.toml and configs/hard/*.toml")
    ap.add_argument("--ranks", type=int, choices=(1, 2), default=1)
    ap.add_argument("--jobs", type=int, default=2, help="cases run at once")
    ap.add_argument("--families", default=None,
                    help="comma list of mutation families (default: all), e.g. msh_file,cli_run")
    ap.add_argument("--keep", action="store_true", help="keep the folders of every case")
    ap.add_argument("--regressions", action="store_true",
                    help="also run one case of every BUG class found and fixed so far")
    ap.add_argument("--work", default=None, help="folder for the cases (default: a temp dir)")
    args = ap.parse_args(argv)
    try:  # an unknown family or no matching config: `error:`, exit 2 (before: exit 1)
        cases = generate_cases(args.seed, args.cases,
                               select_configs(args.configs or list(DEFAULT_CONFIGS)),
                               args.families.split(",") if args.families else None)
    except ValueError as exc:
        ap.error(str(exc))
    if args.regressions:
        cases += regression_cases()
    work = Path(args.work or tempfile.mkdtemp(prefix="fuzz_inputs_"))
    work.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    counts = {"OK": 0, "CLEAN_ERROR": 0, "SLOW": 0, "BUG": 0}
    classes: dict[str, int] = {}
    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        for r in pool.map(lambda c: run_case(c, work, args.timeout, args.ranks, args.keep),
                          cases):
            counts[r["verdict"]] += 1
            if r["verdict"] == "BUG":
                classes[bug_class(r)] = classes.get(bug_class(r), 0) + 1
            print(json.dumps(r, ensure_ascii=False), flush=True)
    families = sorted({c.family for c in cases})
    print(json.dumps({"summary": {"cases": len(cases), **counts, "bug_classes": classes,
                                  "families": families, "seed": args.seed,
                                  "ranks": args.ranks, "seconds": round(
                                      time.perf_counter() - t0, 1), "work": str(work)}}))
    return 1 if counts["BUG"] else 0


if __name__ == "__main__":
    sys.exit(main())
