"""Progress and error lines into a closed pipe are dropped, not fatal.

The run keeps SIGPIPE ignored, as Python has it (PETSc's start and gmsh.initialize reset
it to the default action, which ended the process silently mid-run, summary.json left
`running`: app/startup/petsc.py, app/mesh/build.py). A write to stdout or stderr whose
reader has gone (`python -m app run ... 2>&1 | head -1`) then raises BrokenPipeError:
here that stream is pointed at /dev/null instead and the run goes on, so its files and
summary.json are written as without the pipe (before: `failed`, `cannot write the
results into OUT: Broken pipe`, or exit 141 and `running`)."""

from __future__ import annotations

import os
import sys
from typing import Any, TextIO


class DroppingPipe:
    """A text stream whose writes after its reader closed the pipe go to /dev/null."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream

    def write(self, text: str) -> int:
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            self._to_devnull()
            return len(text)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._to_devnull()

    def _to_devnull(self) -> None:
        """Point the stream's file descriptor at /dev/null (its buffer then drains there)."""
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, self._stream.fileno())
        finally:
            os.close(null)
        try:
            self._stream.flush()
        except OSError:
            pass

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def drop_closed_pipes() -> None:
    """Wrap sys.stdout and sys.stderr (the command's entry point, app/__main__.py)."""
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        if stream is not None and not isinstance(stream, DroppingPipe):
            setattr(sys, name, DroppingPipe(stream))
