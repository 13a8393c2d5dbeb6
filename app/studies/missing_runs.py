"""Which runs of a convergence study have no row: what an interrupted study's tables list.

A study interrupted by SIGINT / SIGTERM writes the tables and plots of the runs that
completed (app/studies/convergence.py). Without this list, study_tables.md read like a study planned
that way: nothing said that the run in progress stopped and the later ones never ran.
Plain Python; no MPI.
"""

from __future__ import annotations

import json
import math
from pathlib import Path


def planned_runs(first_level: int, last: int, reference_levels: int, labels: list[str],
                 ref_label: str) -> list[tuple[int, str]]:
    """(level, method label) of every run the study plans, in its order: every method at
    levels first_level..last - reference_levels, the reference method alone beyond."""
    return [(level, lab) for level in range(first_level, last + 1) for lab in labels
            if level <= last - reference_levels or lab == ref_label]


def level_tag(level: int, first: int, last: int) -> str:
    """How a study's progress, failure and missing-run lines name a level: `level 2 of
    0..2` for the last of `--levels 3`, the index of the L2_<method> folders and of
    study.csv's `level` column, with the range run (before, `level 2/2` read as the
    second of two levels)."""
    return f"level {level} of {first}..{last}"


def missing_runs(out: Path, planned: list[tuple[int, str]], done: set[tuple[int, str]],
                 failures: list[str], last: int, since: float = -math.inf) -> list[str]:
    """One line per planned run with no row (`done`: (level, label) of the rows) and not
    already among `failures` (lines "level l of first..last LABEL: ..."): "interrupted" (or the
    status of its OUT/L<l>_<label>/summary.json) for a run that started, "not run" for
    one that did not. since: the study's start (time.time()); an older summary.json is
    an earlier study's (same --out), not this run's."""
    out_lines = []
    first = min((level for level, _ in planned), default=0)
    for level, lab in planned:
        tag = f"{level_tag(level, first, last)} {lab}"
        if (level, lab) in done or any(f.startswith(tag + ":") for f in failures):
            continue
        summary = Path(out) / f"L{level}_{lab}" / "summary.json"
        status = _status(summary, since)
        out_lines.append(f"{tag}: " + (f"{status} (see {summary.parent.name}/summary.json)"
                                       if status else "not run (the study was interrupted)"))
    return out_lines


def missing_combinations(out: Path, keys: list[str], combos: list[tuple[str, ...]],
                         rows: list[dict], value, since: float = -math.inf,
                         stopped: int | None = None) -> list[dict]:
    """The sweep.csv rows of the combinations an interrupted sweep has no row for: their
    swept values (`value`: text -> the rows' value, app.studies.sweep._value) and status
    "interrupted" (or the status of OUT/run_<i>/summary.json) for the run it stopped,
    "not run" for the ones it never started (since: as `missing_runs`). stopped: the
    index of the run a signal is to stop, "interrupted" whatever its summary says now
    (the texts app/_hard_stop.c writes are prepared while it says `running`)."""
    have = [tuple(r.get(k) for k in keys) for r in rows]
    out_rows = []
    for i, combo in enumerate(combos):
        params = {k: value(v) for k, v in zip(keys, combo, strict=True)}
        if tuple(params.values()) in have:
            continue
        status = ("interrupted" if i == stopped else "not run" if stopped is not None
                  and i > stopped else
                  _status(Path(out) / f"run_{i:03d}" / "summary.json", since) or "not run")
        out_rows.append({**params, "status": status,
                         "error": "the sweep was interrupted"})
    return out_rows


def _status(summary: Path, since: float) -> str | None:
    """The status of a run's summary.json ("interrupted" if it has none), or None when
    there is no such file or it was written before `since` (time.time() seconds: an
    earlier batch's run in the same folder, which this batch never started)."""
    try:
        if summary.stat().st_mtime < since:
            return None
        return json.loads(summary.read_text()).get("status", "interrupted")
    except (OSError, ValueError):
        return None
