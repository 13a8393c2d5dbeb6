"""A disk that fills up during an in-place append gives its errno (No space left on
device), not `short write`."""

import errno
import os

import pytest

import app.output.append as append
from app.output.append import AppendableDocument


def test_a_short_write_then_a_full_disk_reports_enospc(tmp_path, monkeypatch):
    """Linux writes what fits and returns the count; only the next write fails with
    ENOSPC. Before, the first short count became OSError('short write to ...') without
    an errno, and the run's error read `short write to .../contact.xdmf` (a 200 kB tmpfs)."""
    doc = AppendableDocument(tmp_path / "d.txt")
    doc.rewrite("head\n", ["a"], "\ntail\n")
    real = os.pwrite
    calls = []

    def filling(fd, data, offset):
        calls.append(len(data))
        if len(calls) == 1:
            return real(fd, data[:3], offset)  # what still fitted
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(append.os, "pwrite", filling)
    with pytest.raises(OSError) as info:
        doc.append(["b" * 50], "\ntail\n")
    assert info.value.errno == errno.ENOSPC and len(calls) == 2


def test_short_writes_are_completed(tmp_path, monkeypatch):
    doc = AppendableDocument(tmp_path / "d.txt")
    doc.rewrite("head\n", ["a"], "\ntail\n")
    real = os.pwrite
    monkeypatch.setattr(append.os, "pwrite", lambda fd, data, off: real(fd, data[:5], off))
    doc.append(["b" * 50, "c"], "\ntail\n")
    assert (tmp_path / "d.txt").read_text() == "head\na\n" + "b" * 50 + "\nc\ntail\n"
