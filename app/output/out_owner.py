"""Whose files are in --out: a run removes the files of an earlier run of this tool, picked
by name (app/output/startup_signals.STALE: summary.json, mesh.h5, step_NNNN.h5,
results.xdmf, contact.xdmf), and writes its own under the same names. A summary.json that
is not this tool's (not a JSON object with `status`: another program's) marks the folder
as someone else's: a run stops before it removes or replaces anything there, and the
start-up signal handler leaves it alone. (Without any summary.json, files under the tool's
names are an earlier run's leftovers and are cleared, tests/test_status.py.)
Stdlib only: the start-up signal handler (startup_signals) uses it before numpy loads."""

from __future__ import annotations

import json
import re
from pathlib import Path


def _ours(summary: Path) -> bool:
    """summary.json written by this tool: a JSON object with `status`."""
    try:
        data = json.loads(summary.read_text())
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and "status" in data


def foreign_files(out: Path, pattern: re.Pattern) -> list[str]:
    """The files of OUT that match `pattern` (this tool's names, `.tmp` ones left aside)
    when OUT holds a summary.json that is not this tool's; else []."""
    summary = Path(out) / "summary.json"
    if not summary.is_file() or _ours(summary):
        return []
    try:
        return sorted(p.name for p in Path(out).iterdir()
                      if pattern.match(p.name) and p.is_file() and not p.name.endswith(".tmp"))
    except OSError:
        return []


def foreign_message(out: Path, names: list[str]) -> str:
    """The one-line error for a run whose --out holds files of the tool's names that it did
    not write."""
    shown = ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
    return (f"--out {out}: holds {shown} of another program (its summary.json is not a "
            "run's of this tool); a run would replace or remove them: choose another --out "
            "or move them")
