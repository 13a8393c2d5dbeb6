"""The run's status on a signal that comes while a long PETSc call holds the GIL.

A MUMPS factorization or a solve is one C call that does not release Python's GIL, so
neither Python's signal handlers nor the run's watchdog thread (app/output/status.py)
can act until it returns; on several ranks mpiexec kills the job first (Open MPI:
SIGKILL 1 s after the SIGTERM it forwards), and summary.json said `running`. Around such
calls `armed()` installs the C handler of app/_hard_stop.c, which writes the summary the
watchdog would have written (status `interrupted`, the reason), prints its line and exits
with 130 / 143.

Only where the watchdog would stop the job at once (rank 0 of several) and only while a
run has registered what to write (`set_provider`); elsewhere `armed()` does nothing. If
the C library was not built (no compiler at install), the status is as before.
"""

from __future__ import annotations

import ctypes
import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

Provider = Callable[[str], tuple[Path, int, bytes, str]]
"""signal name -> what the interrupted run writes: summary.json's path, the byte offset of
an in-place write of its new tail (-1: the whole file through a rename), the bytes, the
stderr line."""

Extra = Callable[[str, str], tuple[Path | None, bytes, str]]
"""(signal name, the stderr line) -> a further file the handler writes whole, after the
summary: its path (None: no file) and bytes, and a line it prints after the stderr line
("" for none, else ending in a newline): a study's own summary.json
(app/studies/batch_status.py), a sweep's sweep.csv and `sweep:` line (app/studies/sweep.py)."""

_PROVIDER: list[Provider] = []
_EXTRA: list[Extra] = []
_PENDING: list[Callable[[], str | None]] = []
_DEPTH = [0]
_LIB: list[ctypes.CDLL | None] = []


def _library() -> ctypes.CDLL | None:
    """app/_hard_stop.c as built by `pip install -e .`, or None."""
    if not _LIB:
        from app.petsc_lib import built_library  # (imports PETSc: not before cli's init)

        lib = built_library("app._hard_stop")
        try:
            if lib is not None:
                lib.hard_stop_arm.argtypes = [ctypes.c_char_p, ctypes.c_char_p,
                                              ctypes.c_longlong,
                                              ctypes.c_char_p, ctypes.c_size_t,
                                              ctypes.c_char_p, ctypes.c_size_t,
                                              ctypes.c_char_p, ctypes.c_char_p]
                lib.hard_stop_arm.restype = ctypes.c_int
                lib.hard_stop_disarm.argtypes = []
                lib.hard_stop_disarm.restype = None
        except AttributeError:  # an older build without these functions
            lib = None
        texts = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_size_t,
                 ctypes.c_char_p, ctypes.c_size_t]
        for name, more in (("hard_stop_extra", []), ("hard_stop_add", [ctypes.c_char_p] * 2)):
            fn = getattr(lib, name, None)  # (absent from a build before it)
            if fn is not None:
                fn.argtypes = texts + more
                fn.restype = ctypes.c_int
        _LIB.append(lib)
    return _LIB[0]


def available() -> bool:
    """Whether the C handler was built."""
    return _library() is not None


def set_provider(provider: Provider | None,
                 pending: Callable[[], str | None] | None = None) -> None:
    """Register (or with None remove) what an armed signal writes: the run's guard.
    `pending()` names a signal Python recorded but nothing acted on yet (or None)."""
    _PROVIDER.clear()
    _PENDING.clear()
    if provider is not None:
        _PROVIDER.append(provider)
        if pending is not None:
            _PENDING.append(pending)


def add_extra(extra: Extra) -> None:
    """Register a further file (and line) an armed signal writes after the run's summary,
    in the order added (a study's summary.json, then a sweep's sweep.csv, while their runs
    run); kept across runs, unlike `set_provider`."""
    _EXTRA.append(extra)


def remove_extra(extra: Extra) -> None:
    """Undo `add_extra(extra)`."""
    if extra in _EXTRA:
        _EXTRA.remove(extra)


@contextmanager
def armed() -> Iterator[None]:
    """Around a long C call: a signal then writes the interrupted summary from C and
    exits (see the module). Nested uses arm once."""
    lib = _library()
    ok = not _DEPTH[0] and bool(_PROVIDER) and lib is not None and _arm(lib)
    if ok and _PENDING and (name := _PENDING[0]()):
        # it came just before the handler was armed: the watchdog thread would wait for
        # the GIL through the call below, so hand the signal to the C handler now
        signal.pthread_kill(threading.get_ident(), getattr(signal, name))
    _DEPTH[0] += 1
    try:
        yield
    finally:
        _DEPTH[0] -= 1
        if ok:
            lib.hard_stop_disarm()


def disarm() -> None:
    """Put back the handlers `armed` replaced now (another thread ends the job); a no-op
    when nothing is armed. `armed` disarms again at its end (harmless)."""
    lib = _library()
    if lib is not None:
        lib.hard_stop_disarm()


def arm_exit(line_int: str, line_term: str, stay: bool = False) -> bool:
    """Arm the C handler with no file to write, for good (the job's end: see
    app/output/late_signals.py): SIGINT / SIGTERM print the line (may be empty) and exit
    with 130 / 143; with `stay` they do nothing (a rank other than 0). Whether it is
    armed (False: not built, or armed already)."""
    lib = _library()
    arm = getattr(lib, "hard_stop_arm_exit", None)  # (absent from a build before it)
    if arm is None or _DEPTH[0]:
        return False
    arm.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_int]
    arm.restype = ctypes.c_int
    return arm(line_int.encode(), line_term.encode(), int(stay)) == 0


def rearm_address() -> int | None:
    """The address of the C function that installs the armed handler again (for
    PetscRegisterFinalize), or None (not built)."""
    fn = getattr(_library(), "hard_stop_rearm", None)
    return None if fn is None else ctypes.cast(fn, ctypes.c_void_p).value


def _texts(extra: Extra, line_int: str, line_term: str) -> tuple | None:
    """An extra's texts for SIGINT and SIGTERM; None when it fails (a stop then goes
    without that file: the run's solve must not fail for it)."""
    try:
        return extra("SIGINT", line_int), extra("SIGTERM", line_term)
    except Exception:  # noqa: BLE001 (whatever it is, the solve goes on)
        return None


def _arm(lib: ctypes.CDLL) -> bool:
    """Install the C handler with the provider's texts; whether it is armed."""
    path, offset, text_int, line_int = _PROVIDER[0]("SIGINT")
    _, offset_term, text_term, line_term = _PROVIDER[0]("SIGTERM")
    if offset_term != offset:  # the two must be alike; the whole file otherwise
        raise ValueError("hard_stop provider: one offset for both signals")
    more = [m for e in _EXTRA if (m := _texts(e, line_int, line_term)) is not None]
    add, with_lines = getattr(lib, "hard_stop_add", None), True
    if add is None:  # a build before it: the first file only, without its line
        more = [m for m in more if m[0][0] is not None][:1]
        add, with_lines = getattr(lib, "hard_stop_extra", None), False
    for (xpath, xint, lint), (_, xterm, lterm) in more if add is not None else ():
        files = ((str(xpath.with_name(xpath.name + ".tmp")).encode(), str(xpath).encode())
                 if xpath is not None else (None, None))
        lines = (lint.encode(), lterm.encode()) if with_lines else ()
        add(*files, xint, len(xint), xterm, len(xterm), *lines)
    tmp = path.with_name(path.name + ".tmp")
    return lib.hard_stop_arm(str(tmp).encode(), str(path).encode(), offset, text_int,
                             len(text_int), text_term, len(text_term), line_int.encode(),
                             line_term.encode()) == 0
