"""Text files that grow by one entry per step at a cost that does not grow with the file.

A document is `head + entry_1 + sep + entry_2 + ... + entry_n + tail`. The whole
document is written once through a temporary file and a rename (`rewrite`). Each later
entry is one `os.pwrite` of `sep + entry + tail` at the place where the old tail began
(`append`): the bytes before that place never change, and the new text is at least as
long as the old tail (padded with spaces before its final newline when a new tail is
shorter), so the file is the old valid document before the write and the new valid
document after it, and nothing is ever truncated. A process killed with kill -9 never
stops inside one write() of a few kilobytes to a regular file in practice, so a reader
sees either the old or the new document. The cost of a step is the size of its entry,
not of the file.
"""

from __future__ import annotations

import os
from pathlib import Path


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write a file through a temporary file and a rename (never half-written)."""
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


class AppendableDocument:
    """One text file written whole once, then extended in place entry by entry."""

    def __init__(self, path: Path, sep: str = "\n"):
        self.path = Path(path)
        self.sep = sep.encode()
        self.offset = -1  # byte offset where the tail begins; -1: not written yet
        self.end = 0  # file size
        self.n_entries = 0
        self._stamp: tuple[int, int] | None = None

    def _stat(self) -> tuple[int, int] | None:
        try:
            st = os.stat(self.path)
        except FileNotFoundError:
            return None
        return st.st_size, st.st_mtime_ns

    def current(self) -> bool:
        """True when the file is still exactly what this object last wrote."""
        return self.offset >= 0 and self._stat() == self._stamp

    def rewrite(self, head: str, entries: list[str], tail: str) -> None:
        """Write the whole document atomically (rename)."""
        body = head.encode() + self.sep.join(e.encode() for e in entries)
        data = body + tail.encode()
        atomic_write_bytes(self.path, data)
        self.offset, self.end, self.n_entries = len(body), len(data), len(entries)
        self._stamp = self._stat()

    def _covering(self, data: bytes) -> bytes:
        """`data` (written at `offset`) padded to cover the old tail: never leave bytes of
        it behind."""
        if self.end - (self.offset + len(data)) > 0:
            body = data.rstrip(b"\n")
            data = body + b" " * (self.end - self.offset - len(body) - 1) + b"\n"
        return data

    def tail_patch(self, tail: str) -> tuple[int, bytes] | None:
        """(offset, bytes) that replace the tail in one in-place write, as `append` with
        no entries does; None unless `current()`. For a writer that cannot run Python
        (app/_hard_stop.c)."""
        if not self.current():
            return None
        return self.offset, self._covering(tail.encode())

    def append(self, entries: list[str], tail: str) -> None:
        """Add entries and replace the tail with one in-place write (see the module text).

        Only valid when `current()`; the document must already be written."""
        parts = [e.encode() for e in entries]
        lead = self.sep if self.n_entries and parts else b""
        grown = lead + self.sep.join(parts)
        data = self._covering(grown + tail.encode())
        fd = os.open(self.path, os.O_WRONLY)
        try:  # a short write (a disk filling up) is retried: the retry raises its errno
            written = 0
            while written < len(data):
                n = os.pwrite(fd, data[written:], self.offset + written)
                if n <= 0:
                    raise OSError(f"short write to {self.path}")
                written += n
        finally:
            os.close(fd)
        self.offset += len(grown)
        self.end = max(self.end, self.offset - len(grown) + len(data))
        self.n_entries += len(parts)
        self._stamp = self._stat()
