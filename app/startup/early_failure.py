"""Bad input found before PETSc starts: OUT/summary.json says `failed` with the error too.

Two kinds stop a command before PETSc runs (so before app/startup/input_failure.py, which needs
it, can record them): a command line that argparse refuses (`--levels x`, `--reference
bogus`, `--single-dash-option` ...) and PETSc options that PETSc refuses at its start
(`-options_file /missing`, app/startup/petsc.py). Before, both left no summary.json, or the
earlier run's `completed` one. Here the config and --out of such a command line are read
without the type and choice checks (the same grammar), and rank 0 of the launcher writes
the summary with OUT's lock, as the start-up signal handler does
(app/output/startup_signals.py). Stdlib only.
"""

from __future__ import annotations

import argparse
import datetime
import sys
from collections.abc import Callable
from pathlib import Path

from app.output import startup_signals


class UsageError(Exception):
    """argparse's error (the parser whose usage to print, the message)."""

    def __init__(self, parser: argparse.ArgumentParser, message: str):
        super().__init__(message)
        self.parser = parser
        self.message = message


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors raise UsageError instead of exiting."""

    def error(self, message: str):
        raise UsageError(self, message)


def study_head(kind: str, config: Path | str) -> dict:
    """The first keys of a study's summary.json (kind: convergence or sweep)."""
    return {"command": "study", "study": kind, "config": str(config)}


Folder = Callable[[argparse.Namespace, Path], Callable[[], Path] | None]
"""(args, default OUT) -> a function giving OUT created and checked, or None (app/cli.py's
_out_folder)."""


def usage_failure(exc: UsageError, parser: Callable[[], argparse.ArgumentParser],
                  argv: list[str], folder: Folder) -> int:
    """argparse's usage and error line (on stderr, as argparse prints them), after the
    failure is recorded in the command's OUT; returns the exit status 2."""
    args = _lenient(parser(), argv)
    message = exc.message if args is None else record(args, exc.message, folder)
    if startup_signals.launcher_rank() == 0:  # once, not once per rank (before: n times)
        exc.parser.print_usage(sys.stderr)
        print(f"{exc.parser.prog}: error: {message}", file=sys.stderr)
    return 2


def record(args: argparse.Namespace, reason: str, folder: Folder) -> str:
    """Record `reason` in the OUT of a `run` or `study` command line (launcher rank 0);
    returns `reason`, with why no summary.json was written when OUT is not usable. Nothing
    to write without --out when the config is no file (as for bad input after the start)."""
    from app.errors import InputError

    command, config = getattr(args, "command", None), getattr(args, "config", None)
    if command not in ("run", "study") or config is None or startup_signals.launcher_rank():
        return reason
    config = Path(config)
    out = folder(args, Path("out") / (config.stem if command == "run"
                                      else f"study_{config.stem}"))
    if out is None:
        return reason
    head = ({"config": str(config), "n_steps": None, "steps": []} if command == "run" else
            study_head("sweep" if args.sweep else "convergence", config))
    head["provenance"] = {
        "start_time": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "argv": list(sys.argv), "overrides": [a for a in args.set or [] if a is not None]}
    try:
        why = startup_signals.record_failure(out(), reason, head)
    except InputError as unusable:
        why = str(unusable)
    return reason if why is None else f"{reason}; no summary.json written: {why}"


def _lenient(parser: argparse.ArgumentParser, argv: list[str]) -> argparse.Namespace | None:
    """`argv` parsed by `parser` without its type and choice checks (values stay text) and
    with an option's value optional (`--levels --out OUT`); None if even that fails (no
    command, no config)."""
    stack = [parser]
    while stack:
        for action in stack.pop()._actions:
            if isinstance(action, argparse._SubParsersAction):
                stack.extend(action.choices.values())
                continue
            action.type, action.choices = None, None
            if action.option_strings and action.nargs is None:
                action.nargs = "?"
    try:
        args, _ = parser.parse_known_args(argv)
    except (UsageError, SystemExit):
        return None
    if isinstance(getattr(args, "config", None), str):
        args.config = Path(args.config)
    return args
