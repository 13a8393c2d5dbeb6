"""Checks of the user's PETSc options: solver types before the run, unused options after.

- `check_solver_options`: `-ksp_type`, `-pc_type` and `-pc_factor_mat_solver_type`
  (command line or the config's [petsc] table) must name a type PETSc knows, and no
  `..._type` option may be given without a value. A bad one is a one-line InputError
  before any meshing, instead of a PETSc traceback after it.
- `unused_options`: the user's options that nothing read during the run, as PETSc's
  `-options_left` reports them (`PetscOptionsLeftGet`, through ctypes), e.g. the
  misspelled `-ksp_typ cg`.
- `petsc_error_line`: the informative line of a PETSc error, for a one-line message.
"""

from __future__ import annotations

import ctypes
import re

from petsc4py import PETSc

from app.config_keys import suggestion
from app.errors import InputError
from app.petsc_lib import PETSC_INT, load_petsc
from app.user_paths import path_kind


def _type_names(cls) -> list[str]:
    return sorted({str(v) for k, v in vars(cls).items() if not k.startswith("_")
                   and isinstance(v, str)})


CHECKED_TYPES = {
    "ksp_type": lambda: _type_names(PETSc.KSP.Type),
    "pc_type": lambda: _type_names(PETSc.PC.Type),
    "pc_factor_mat_solver_type": lambda: _type_names(PETSc.Mat.SolverType),
}
"""Options whose value must be one of PETSc's registered type names."""


def given_options(config_petsc: dict[str, str]) -> dict[str, str]:
    """The options in force from the user: the config's [petsc] table, then the command
    line (which wins); names without the leading dash."""
    return {**config_petsc, **PETSc.Options().getAll()}


KSP_MONITOR = re.compile(r"(^|_)ksp_monitor(_[a-z_]+)?\Z")
"""A KSP monitor option (`-ksp_monitor`, `-mg_levels_ksp_monitor_short`, ...)."""


def _monitor_format_problem(name: str, value: str) -> str | None:
    """Why a KSP monitor's viewer format is refused: PETSc 3.18 registers its ASCII
    monitors for the default format only and calls a NULL monitor for any other:
    `-ksp_monitor ::ascii_info` (allowed in a config file's [petsc] as a viewer to the
    standard output) ended the run in a segmentation fault at the first iteration."""
    if not KSP_MONITOR.search(name) or name.endswith("_cancel"):
        return None
    parts = value.split(":")
    kind = parts[0].strip().lower()
    fmt = parts[2].strip().lower() if len(parts) > 2 else ""
    if kind in ("", "ascii", "true") and fmt not in ("", "default"):
        return (f"PETSc option -{name} {value}: a KSP monitor writes text in its default "
                f"format only (PETSc crashes on the format {fmt!r}); leave the format "
                "out: -{name} or -{name} ascii[:FILE]").replace("{name}", name)
    return None


def check_solver_options(config_petsc: dict[str, str]) -> None:
    """InputError (one line) for an unknown solver type, a `*_type` option with no value
    or a KSP monitor with a format PETSc crashes on."""
    for name, value in given_options(config_petsc).items():
        value = "" if value is None else str(value).strip()
        if name.endswith("_type") and not value:
            raise InputError(f"PETSc option -{name} needs a value")
        if problem := _monitor_format_problem(name, value):
            raise InputError(problem)
        if name in CHECKED_TYPES:
            known = CHECKED_TYPES[name]()
            if value.lower() not in known:
                raise InputError(f"PETSc option -{name} {value}: unknown type"
                                 f"{suggestion(value, known)}; known: {', '.join(known)}")


LOG_VIEW_FORMATS = ("default", "ascii_info", "ascii_info_detail", "ascii_csv", "ascii_xml",
                    "ascii_flamegraph")
"""Formats PETSc's log view writes (src/sys/logging/plog.c, PetscLogView)."""
LOG_VIEW_MODES = ("write", "append", "w", "a")
NESTED_FORMATS = ("ascii_xml", "ascii_flamegraph")
"""Formats of PETSc's nested log: from the config's [petsc] table (started after PETSc)
they ended a completed run in a segmentation fault, exit 139."""


def check_log_view_spec(config_petsc: dict[str, str]) -> None:
    """InputError (one line) unless -log_view is `[ascii][:file][:format][:mode]` with
    a format and mode PETSc's log view takes: PETSc reads the value only at PetscFinalize,
    and `-log_view 1` (or draw, binary:f, stdout, `:f:bogus`, `:f::bogus`) ended a
    completed run, exit 0, in a 12-line PETSc error and no log (scripts/fuzz_inputs.py);
    an XML or flame-graph log from the config, in a segmentation fault."""
    value = given_options(config_petsc).get("log_view")
    if value is None or not str(value).strip():
        return
    vtype, _, rest = str(value).partition(":")
    _, _, rest = rest.partition(":")
    fmt, _, mode = rest.partition(":")
    problem = None
    if vtype.strip().lower() not in ("", "ascii"):
        problem = f"the viewer type is {vtype!r}; the log is ASCII text: use ascii or nothing"
    elif fmt.strip() and fmt.strip().lower() not in LOG_VIEW_FORMATS:
        problem = f"unknown format {fmt!r}; use one of {', '.join(LOG_VIEW_FORMATS)}"
    elif mode.strip() and mode.strip().lower() not in LOG_VIEW_MODES:
        problem = f"unknown file mode {mode!r}; use write or append"
    elif fmt.strip().lower() in NESTED_FORMATS and not PETSc.Options().hasName("log_view"):
        problem = (f"the {fmt} log needs PETSc's nested log, which starts with PETSc only: "
                   "give this -log_view on the command line, not in [petsc]")
    if problem:
        PETSc.Options().delValue("log_view")  # else PetscFinalize fails on it at exit
        raise InputError(f"-log_view {value}: {problem} ([ascii][:file][:format][:mode], "
                         "e.g. -log_view :log.txt:ascii_info_detail)")


def check_log_view_file(config_petsc: dict[str, str]) -> None:
    """InputError (one line) when -log_view names a file that cannot be written: PETSc
    opens it only at PetscFinalize, and a completed run then ended with a 30-line PETSc
    error ("Cannot open PetscViewer file") and no log, exit 0. Collective: rank 0 judges
    the file and every rank takes its verdict (a name under OUT, `:OUT/../log.txt`, could
    be looked up by a rank that came later, once rank 0 had made OUT: that rank went on
    into the run alone and the job hung)."""
    check_log_view_spec(config_petsc)
    value = given_options(config_petsc).get("log_view")
    parts = str(value or "").split(":")
    name = parts[1].strip() if len(parts) > 1 else ""
    if not name:
        return
    from app.parallel import rank0_call

    problem = rank0_call(_log_view_file_problem, str(value), name)
    if problem is not None:
        PETSc.Options().delValue("log_view")  # else PetscFinalize fails on it at exit
        raise InputError(problem)


def _log_view_file_problem(value: str, name: str) -> str | None:
    """Why the -log_view file `name` cannot be written (the error's line), or None."""
    import os
    from pathlib import Path

    folder = Path(name).parent
    try:
        bad = path_kind(folder, "-log_view") != "dir" or path_kind(name, "-log_view") == "dir" \
            or not os.access(folder, os.W_OK | os.X_OK)
    except InputError as exc:  # a name the system cannot look up (too long)
        return str(exc)
    if bad:
        return (f"-log_view {value}: cannot write the file {name} (its folder does not "
                "exist or is not writable, or it is a folder)")
    return None


READ_AT_FINALIZE = frozenset({"options_left"})
"""Options PETSc reads only at PetscFinalize, after the summary is written: never unused
(before, `-options_left` listed itself in `petsc_options_unused`)."""


def unused_options(user_names: set[str]) -> list[str]:
    """Names (with the dash) of the user's options that nothing used during the run."""
    lib = load_petsc()
    if lib is None:
        return []
    n = PETSC_INT()
    names = ctypes.POINTER(ctypes.c_char_p)()
    values = ctypes.POINTER(ctypes.c_char_p)()
    if lib.PetscOptionsLeftGet(None, ctypes.byref(n), ctypes.byref(names), ctypes.byref(values)):
        return []
    try:
        left = [names[i].decode() for i in range(n.value)]
    finally:
        lib.PetscOptionsLeftRestore(None, ctypes.byref(n), ctypes.byref(names),
                                    ctypes.byref(values))
    return sorted(f"-{x}" for x in left if x in user_names and x not in READ_AT_FINALIZE)


def petsc_error_line(exc: Exception) -> str:
    """The most informative line of a petsc4py error (its last non-empty line)."""
    lines = [ln.strip().removeprefix("[0]").strip() for ln in str(exc).splitlines()]
    lines = [ln for ln in lines if ln and not ln.startswith("error code")]
    return lines[-1] if lines else str(exc).strip().splitlines()[0]
