"""What a path the user gave (config file, --out, --mesh-cache, mesh.file, -log_view
file) is on disk, without a traceback.

`Path.exists()`, `is_file()` and `is_dir()` swallow only "not found" errors: a name longer
than the file system allows (ENAMETOOLONG), a loop of symbolic links or a folder without
search permission raised `OSError` out of the checks, and `--out` with a 300-character
folder name ended in a traceback, exit 1 (scripts/fuzz_inputs.py found it).
"""

from __future__ import annotations

import errno
import stat
from pathlib import Path

from app.errors import InputError, cut_middle

_ABSENT = (errno.ENOENT, errno.ENOTDIR)
"""Errors that mean: nothing is there (a part of the path is missing or is a file)."""


def path_kind(path: Path | str, what: str) -> str | None:
    """'file', 'dir' or 'other' (a device, fifo, socket) for what is at `path`, None when
    nothing is; a path that cannot be looked up is an InputError naming `what` (e.g.
    "--out", "config file") and the reason."""
    try:
        mode = Path(path).stat().st_mode
    except OSError as exc:
        if exc.errno in _ABSENT:
            return None
        raise InputError(f"{what} '{_short(str(path))}': {exc.strerror or exc}") from None
    except ValueError as exc:  # an embedded NUL character
        raise InputError(f"{what} '{_short(str(path))}': {exc}") from None
    if stat.S_ISREG(mode):
        return "file"
    return "dir" if stat.S_ISDIR(mode) else "other"


def _short(text: str, limit: int = 120) -> str:
    """`text` cut in the middle to at most about `limit` characters."""
    return text if len(text) <= limit else cut_middle(text, limit - 50, 25)
