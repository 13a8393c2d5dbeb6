"""What a config file's `[petsc]` table may not do: write files or load code.

A config file is shared between people, so its `[petsc]` table is checked as the
command line is not (`check_config_file_petsc`, called on the table as read from the
file, before any `--set`):
- no viewer that writes a file or a socket: a value `TYPE:FILE[:FORMAT[:MODE]]` with a
  file name (`ksp_view = "ascii:/home/me/.bashrc"` truncated that file before), or of a
  viewer type that writes a default file or connects somewhere (`binary`, `hdf5`, `vtk`,
  `socket`, ...); `true`, `""`, `ascii` or `::FORMAT` (the standard output) stay allowed,
  so `log_view = true` profiles the run;
- no Python type (`pc_type = "python"` with `pc_python_type = "os.abort"` imported and
  called that function before) and no `*_python_type`;
- no option that names a file, a program or a debugger (`options_file`, `history`,
  `log_trace`, `start_in_debugger`, ...).

The user's own command line (`-ksp_view ascii:log.txt`, or `--set petsc.KEY=VALUE`) is
not restricted. Each refusal is one InputError naming the key and what to do instead.
"""

from __future__ import annotations

from pathlib import Path

from app.errors import InputError

FILE_VIEWER_TYPES = frozenset({"binary", "hdf5", "vtk", "vtu", "matlab", "socket", "saws",
                               "glvis", "adios", "adios2", "exodusii", "cgns", "mathematica",
                               "draw"})
"""PETSc viewer types that write a file (a default name when none is given), connect to a
socket or open a window."""

REFUSED_KEYS = frozenset({"options_file", "options_file_yaml", "options_string_yaml",
                          "options_monitor", "history", "log_trace", "info", "python",
                          "start_in_debugger", "on_error_attach_debugger", "debugger",
                          "debugger_nodes", "debugger_pause", "stop_for_debugger", "display",
                          "malloc_dump", "malloc_view", "viewer_binary_filename",
                          "viewer_socket_port", "viewer_socket_machine"})
"""Options that name a file, a program, a display or a debugger."""


def refusal(key: str, value: str) -> str | None:
    """Why a config file may not set `-key value` (None: it may)."""
    name = key.strip().lstrip("-").lower()
    text = str(value).strip()
    if name in REFUSED_KEYS or name.startswith(("viewer_", "debugger_")):
        return "it names a file, a program or a debugger"
    if name.endswith("python_type") or (name.endswith("_type") and text.lower() == "python"):
        return "a Python type imports and calls Python code named in the config"
    parts = text.split(":")
    kind = parts[0].strip().lower()
    if len(parts) > 1 and parts[1].strip():
        return f"the viewer writes the file '{parts[1].strip()}'"
    if kind in FILE_VIEWER_TYPES:
        return f"a '{kind}' viewer writes a file or connects to a socket or a display"
    return None


def check_config_file_petsc(table: object, path: Path | str) -> None:
    """InputError (one line) for the first option of a config file's [petsc] table that
    would write a file or load code (see the module docstring); `table` is the table as
    read from the file (not a table: the config checks report it later)."""
    if not isinstance(table, dict):
        return
    for key, value in table.items():
        if isinstance(value, bool):
            continue
        why = refusal(str(key), str(value))
        if why:
            raise InputError(
                f"config file '{path}': petsc.{key} = {str(value)!r} is not allowed in a "
                f"config file ({why}); give it on the command line (-{str(key).lstrip('-')} "
                f"...) if you mean it")
