"""What a config file's `[petsc]` table may do: tune the solvers, nothing else.

A config file is shared between people, so its `[petsc]` table is checked as the
command line is not (`check_config_file_petsc`, called on the table as read from the
file, before any `--set`). It is an allow-list:
- an option's name must be a solver option, `ksp_*`, `pc_*` or `mat_*` (also behind the
  prefixes of inner solvers: `sub_`, `mg_levels_`, `mg_levels_N_`, `mg_coarse_`,
  `redundant_`, `fieldsplit_NAME_`, `esteig_`, `inner_`, `upper_`, `telescope_`,
  `redistribute_`), one of this program's `contact_*` options, `log_view` (with its
  flags `log_view_memory`, `log_view_gpu_time`) or `options_left`. Anything else
  (`options_file`, `history`, `start_in_debugger`, `dll_append`, `draw_save`,
  `draw_type`, `malloc_*`, ...) is refused, whatever its value: before, `draw_type =
  "image"` with `draw_save = "FILE"` and `ksp_plot_eigenvalues = true` wrote 26 images
  FILE_0.ppm ... and a folder FILE, anywhere;
- within those, no name about drawing, plotting, files or Python (`ksp_plot_eigenvalues`,
  `*_draw*`, `*_binary*`, `*_python_type`, ...), and no Python type (`pc_type = "python"`
  with `pc_python_type = "os.abort"` imported and called that function before);
- a viewer (`*_view*`, `*_monitor*`, `*_converged_reason`) writes to the standard output
  only: its type is `ascii` or empty (`true`, `""`, `ascii`, `::FORMAT`); no other value
  names a file (`TYPE:FILE...`; `ksp_view = "ascii:/home/me/.bashrc"` truncated that file
  before) or a viewer type that writes a file or connects somewhere (`binary`, `socket`);
- `ksp_max_it` is at most MAX_ITERATIONS (a solve that never converges runs that long);
- MUMPS's output units ICNTL(1)-ICNTL(3) are 6 (the standard output) or <= 0 (none):
  another unit, `mat_mumps_icntl_2 = 58`, wrote the file `fort.58` into the working
  directory.

The user's own command line (`-ksp_view ascii:log.txt`, or `--set petsc.KEY=VALUE`) is
not restricted. Each refusal is one InputError naming the key and what to do instead.
"""

from __future__ import annotations

import re
from pathlib import Path

from app.errors import InputError

FILE_VIEWER_TYPES = frozenset({"binary", "hdf5", "vtk", "vtu", "matlab", "socket", "saws",
                               "glvis", "adios", "adios2", "exodusii", "cgns", "mathematica",
                               "draw", "vu", "string", "python"})
"""PETSc viewer types that write a file (a default name when none is given), connect to a
socket or open a window (refused as the value of any option)."""

STDOUT_VIEWER_TYPES = frozenset({"", "ascii", "true"})
"""The viewer types a config file's viewer option may have: text on the standard output."""

_INNER_PREFIX = (r"(?:sub_|redundant_|mg_coarse_|mg_levels_(?:\d+_)?|fieldsplit_[a-z0-9]+_|esteig_"
                 r"|inner_|upper_|telescope_|redistribute_)*")
ALLOWED_NAME = re.compile(rf"{_INNER_PREFIX}(?:ksp|pc|mat)_[a-z0-9_]+\Z")
"""Solver options (KSP, PC, Mat), also of inner solvers behind their prefixes: GAMG's
Chebyshev smoother's eigenvalue estimate (`mg_levels_esteig_ksp_type`), a Schur
fieldsplit's `fieldsplit_1_inner_`/`_upper_`, PCTELESCOPE and PCREDISTRIBUTE (before,
these were refused as not solver options)."""
ALLOWED_OTHER = frozenset({"log_view", "log_view_memory", "log_view_gpu_time", "options_left",
                           "contact_compliance",
                           "contact_candidate_pairs", "contact_lcp_cache"})
"""Other options a config file may set (this program's own `contact_*` options, read in
app/assembly and app/condensation)."""
REFUSED_WORDS = ("draw", "plot", "python", "binary", "dump", "save", "file", "socket",
                 "viewer", "debug", "hdf5", "vtk", "matlab", "saws", "glvis", "adios",
                 "exodus", "cgns", "mathematica", "lg_")
"""Parts of a solver option's name that draw, plot, write files or load Python code
(`ksp_plot_eigenvalues` opened a drawing that `draw_save` wrote to any path)."""
VIEWER_NAME = re.compile(r"(^|_)(view|monitor|converged_reason)(_|$)")
"""Options read as a viewer (`-ksp_view`, `-ksp_monitor_short`, `-ksp_converged_reason`)."""
MAX_ITERATIONS = 100_000
"""Largest `*ksp_max_it` in a config file (ten times PETSc's default 10,000): before,
`ksp_type = "richardson"`, `ksp_richardson_scale = 1e-9`, `ksp_max_it = 2000000000` and
tolerances of 1e-300 kept patch.toml's first solve busy for as long as it was let run."""
MUMPS_UNIT = re.compile(r"(?:.*_)?mat_mumps_icntl_([123])\Z")
"""MUMPS's ICNTL(1)-ICNTL(3): Fortran output units (a unit N other than 6 is fort.N)."""


def _viewer_refusal(name: str, text: str) -> str | None:
    """Why a viewer value, or a value that looks like one, is refused (None: allowed)."""
    parts = text.split(":")
    kind = parts[0].strip().lower()
    if len(parts) > 1 and parts[1].strip():
        return f"the viewer writes the file '{parts[1].strip()}'"
    if kind in FILE_VIEWER_TYPES:
        return f"a '{kind}' viewer writes a file, connects to a socket or opens a window"
    if VIEWER_NAME.search(name) and kind not in STDOUT_VIEWER_TYPES:
        return (f"a viewer in a config file writes text to the standard output only "
                f"(true, ascii or ::FORMAT), not a '{kind}' viewer")
    return None


def _at_most(text: str, limit: int) -> bool:
    """Whether `text` is a number <= limit (PETSc reads 1e5 as an integer too)."""
    try:
        return float(text) <= limit
    except ValueError:
        return False


def refusal(key: str, value: str) -> str | None:
    """Why a config file may not set `-key value` (None: it may)."""
    name = key.strip().lstrip("-").lower()
    text = str(value).strip()
    if name not in ALLOWED_OTHER and not ALLOWED_NAME.match(name):
        return ("a config file may set only solver options (ksp_*, pc_*, mat_*, also "
                "behind sub_, mg_levels_, ...), contact_*, log_view and options_left")
    if any(word in name for word in REFUSED_WORDS):
        return "it draws, plots, names a file or loads Python code"
    if "python" in [t.strip() for t in text.lower().split(",")]:  # also pc_composite_pcs
        return "a Python type imports and calls Python code named in the config"
    if name.endswith("ksp_max_it") and not _at_most(text, MAX_ITERATIONS):
        return (f"more than {MAX_ITERATIONS} iterations per solve (a solve that never "
                "converges would run that long)")
    unit = MUMPS_UNIT.match(name)
    if unit and text not in ("6", "0") and not re.fullmatch(r"-\d+", text):
        return (f"ICNTL({unit.group(1)}) is a Fortran output unit: {text} writes the "
                f"file fort.{text} into the working directory; use 6 (the standard "
                "output) or 0 (none)")
    return _viewer_refusal(name, text)


def check_config_file_petsc(table: object, path: Path | str) -> None:
    """InputError (one line) for the first option of a config file's [petsc] table that
    is not on the allow-list or would write a file or load code (see the module
    docstring); `table` is the table as read from the file (not a table: the config
    checks report it later)."""
    if not isinstance(table, dict):
        return
    for key, value in table.items():
        text = "" if isinstance(value, bool) else str(value)  # a flag: only the name counts
        why = refusal(str(key), text)
        if why:
            shown = str(value).lower() if isinstance(value, bool) else repr(text)
            raise InputError(
                f"config file '{path}': petsc.{key} = {shown} is not allowed in a "
                f"config file ({why}); give it on the command line (-{str(key).lstrip('-')} "
                f"...) if you mean it")
