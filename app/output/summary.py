"""summary.json written at a cost per step that does not grow with the number of steps.

The file is `{head keys, "steps": [...], trailing keys}`. The head keys (what ran, sizes,
routes) do not change while the steps run; the trailing keys (TRAILING: the running
energies, timings, status) do. While the head is unchanged and steps are only added, one
in-place write adds the new steps and replaces the trailing keys (app/output/append.py);
anything else (the first write, a failure, the final summary) rewrites the whole file
through a temporary file and a rename. A reader or a kill -9 always finds valid JSON with
every completed step.
"""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

from app.output.append import AppendableDocument

TRAILING = ("strain_energy", "strain_energy_by_body", "timings", "status")
"""Top-level keys that change from step to step; written after `steps`."""


def _indent(text: str, prefix: str) -> str:
    return textwrap.indent(text, prefix)[len(prefix):]


class SummaryWriter:
    """Writes successive versions of one run's summary dict to one path."""

    def __init__(self, path: Path):
        self.doc = AppendableDocument(Path(path), sep=",\n")
        self._head: str | None = None
        self._steps: list | None = None

    @staticmethod
    def _head_text(summary: dict, skip: tuple[str, ...] = ()) -> str:
        head = {k: v for k, v in summary.items()
                if k != "steps" and k not in TRAILING and k not in skip}
        opening = json.dumps(head, indent=2)[:-2] + ",\n" if head else "{\n"
        return opening + '  "steps": [\n'

    @staticmethod
    def _tail_text(summary: dict, keys: tuple[str, ...] = TRAILING) -> str:
        tail = "\n  ]"
        for key in keys:
            if key in summary:
                tail += f',\n  "{key}": ' + _indent(json.dumps(summary[key], indent=2), "  ")
        return tail + "\n}\n"

    def tail_patch(self, summary: dict, extra: tuple[str, ...]) -> tuple[int, bytes] | None:
        """(offset, bytes) of one in-place write that turns the file into `summary`, whose
        head and steps are those last written and whose keys `extra` (e.g. "error") go
        after the trailing keys; None when the file is not that (then write it whole)."""
        steps = summary.get("steps", [])
        if (steps is not self._steps or len(steps) != self.doc.n_entries
                or self._head_text(summary, extra) != self._head):
            return None
        return self.doc.tail_patch(self._tail_text(summary, TRAILING + extra))

    def write(self, summary: dict) -> None:
        """Write the summary: append the new steps' entries when the head is unchanged
        since the last write of the same run, else rewrite the whole file."""
        steps = summary.get("steps", [])
        head_text = self._head_text(summary)
        tail = self._tail_text(summary)
        same_run = steps is self._steps and head_text == self._head
        if same_run and self.doc.current() and len(steps) >= self.doc.n_entries:
            new = steps[self.doc.n_entries:]
            self.doc.append([_step_text(s) for s in new], tail)
        else:
            self.doc.rewrite(head_text, [_step_text(s) for s in steps], tail)
        self._head, self._steps = head_text, steps


def _step_text(step: dict) -> str:
    return textwrap.indent(json.dumps(step, indent=2), "    ")


_WRITERS: dict[Path, SummaryWriter] = {}


def tail_patch(path: Path, summary: dict, extra: tuple[str, ...]) -> tuple[int, bytes] | None:
    """SummaryWriter.tail_patch of the writer of `path` (None if there is none)."""
    writer = _WRITERS.get(Path(path).resolve())
    return None if writer is None else writer.tail_patch(summary, extra)


def write_summary(path: Path, summary: dict) -> None:
    """Write `summary` to `path` (see the module text). Successive calls for the same
    summary dict (the same run) append; any other dict rewrites the file."""
    key = Path(path).resolve()
    writer = _WRITERS.get(key)
    if writer is None:
        writer = _WRITERS[key] = SummaryWriter(key)
    writer.write(summary)
