"""Whose files are in --out: a run removes the files of an earlier run of this tool, picked
by name (app/output/startup_signals.STALE: summary.json, mesh.h5, step_NNNN.h5,
results.xdmf, contact.xdmf), and writes its own under the same names. A summary.json that
is not this tool's (not a JSON object with `status`: another program's) marks the folder
as someone else's: a run stops before it removes or replaces anything there, and the
start-up signal handler leaves it alone. (Without any summary.json, files under the tool's
names are an earlier run's leftovers and are cleared, tests/test_status.py.)
Stdlib only: the start-up signal handler (startup_signals) uses it before numpy loads."""

from __future__ import annotations

import errno
import json
import os
import re
import stat
from pathlib import Path
from typing import TextIO


class UnsafeLock(OSError):
    """OUT's lock file is not a plain file (a symbolic link, a FIFO, a folder...): its
    message is the run's one-line error."""


def open_lock(path: Path) -> TextIO:
    """Open (creating it, 0644) the lock file OUT/.lock for appending, never through a
    symbolic link: O_NOFOLLOW, so that a link planted in a shared folder does not make a
    run create or lock a file elsewhere (before, `.lock -> /some/file` created /some/file),
    and O_NONBLOCK, so that a FIFO there does not hang the open. Nothing is written to it.
    Raises UnsafeLock when it is a link or not a regular file, OSError otherwise."""
    flags = (os.O_WRONLY | os.O_CREAT | os.O_APPEND | os.O_NOFOLLOW | os.O_NONBLOCK
             | os.O_CLOEXEC)
    try:
        fd = os.open(path, flags, 0o644)
    except OSError as exc:
        if exc.errno not in (errno.ELOOP, errno.ENXIO, errno.EISDIR):
            raise
    else:
        if stat.S_ISREG(os.fstat(fd).st_mode):
            return os.fdopen(fd, "a")
        os.close(fd)
    why = "is a symbolic link" if os.path.islink(path) else "is not a plain file"
    raise UnsafeLock(f"--out {Path(path).parent}: its lock file {Path(path).name} {why} "
                     "(a run creates a plain file there; it was put there by someone or "
                     "something else): remove it or choose another --out")


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


STUDY_FILES = re.compile(
    r"^(study\.csv|study_tables\.md|richardson\.csv|energy_bracket\.(csv|png)|"
    r"error_vs_(dofs|time)\.png|energy_vs_sd\.png|sweep\.csv|sweep_steps\.csv|"
    r"sweep_[\w.-]+\.png)(\.tmp)?$")
"""The files a study or sweep writes into OUT (its runs' folders aside)."""
RUN_FOLDER = re.compile(r"^(L\d+_[\w-]+|run_\d{3,})$")
"""The folders of a study's runs (L<level>_<label>) and of a sweep's (run_NNN)."""


def planted_links(out: Path) -> list[Path]:
    """OUT's symbolic links under the names a study writes (STUDY_FILES and their `.tmp`,
    RUN_FOLDER, `mesh_cache`): a study takes those names as its own, and through a link
    it wrote outside OUT (a run folder `run_000 -> /elsewhere` got that run's files, a
    dangling `sweep_steps.csv.tmp` made /elsewhere's file). To be removed, not followed."""
    try:
        entries = sorted(Path(out).iterdir())
    except OSError:
        return []
    return [p for p in entries if p.is_symlink() and (
        STUDY_FILES.match(p.name) or RUN_FOLDER.match(p.name) or p.name == "mesh_cache")]


def _keys(summary: Path) -> dict:
    """summary.json's object (empty when it is missing, not JSON or not an object)."""
    try:
        data = json.loads(summary.read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _a_study_run(summary: Path) -> bool:
    """summary.json of one of this tool's runs inside a study (app/run.py's keys), not a
    study's, not another program's that only has a `status`, and not a `run` command's
    (its provenance's argv: the user's own run kept under a run folder's name)."""
    data = _keys(summary)
    prov = data.get("provenance")
    argv = prov.get("argv") if isinstance(prov, dict) else None
    standalone = isinstance(argv, list) and argv[1:2] == ["run"]
    return ({"config", "n_steps", "steps", "status"} <= set(data) and "command" not in data
            and not standalone)


def _written_here(folder: Path) -> bool:
    """The run's summary.json records this folder as the one it was written into
    (provenance `out`, resolved): not a study run's folder copied or moved here by hand,
    nor one of a version that did not record it."""
    prov = _keys(folder / "summary.json").get("provenance")
    written = prov.get("out") if isinstance(prov, dict) else None
    try:
        return isinstance(written, str) and Path(written) == folder.resolve()
    except OSError:
        return False


def _run_folders(out: Path) -> list[Path]:
    """OUT's folders of RUN_FOLDER's names, real folders (not symlinks), that hold a study
    run's summary.json of this tool (_a_study_run)."""
    try:
        entries = sorted(out.iterdir())
    except OSError:
        return []
    return [p for p in entries if RUN_FOLDER.match(p.name) and p.is_dir()
            and not p.is_symlink() and _a_study_run(p / "summary.json")]


def copied_runs(out: Path) -> list[Path]:
    """OUT's folders that look like a study's runs (`_run_folders`) but that no study wrote
    there (`_written_here` fails: copied by hand under a run folder's name, or moved): an
    earlier study's clean-up keeps them, and the study warns, naming them."""
    return [p for p in _run_folders(Path(out)) if not _written_here(p)]


def _a_study(summary: Path) -> bool:
    """summary.json of one of this tool's studies (startup/early_failure.study_head)."""
    data = _keys(summary)
    return data.get("command") == "study" and "status" in data


def earlier_study(out: Path) -> tuple[list[Path], list[Path]]:
    """An earlier study's outputs in OUT: (its files, its run folders). The run folders
    are `_run_folders` whose summary.json records that folder as where it was written
    (`_written_here`; a copy by hand is not the study's: `copied_runs`); the files, of
    STUDY_FILES' names, count only when OUT holds this tool's summary.json or such a
    folder (so a folder of the user's that only happens to hold a study.csv is left as it
    is). Before, a study into an earlier
    study's OUT left that study's extra levels, methods and richardson.csv beside its own,
    and the scripts read them as its own."""
    out = Path(out)
    try:
        entries = sorted(out.iterdir())
    except OSError:
        return [], []
    folders = [p for p in _run_folders(out) if _written_here(p)]
    if not folders and not _a_study(out / "summary.json"):
        return [], []
    return [p for p in entries if p.is_file() and STUDY_FILES.match(p.name)], folders
