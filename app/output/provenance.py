"""Provenance of a run for summary.json: what ran, with which inputs, where and when."""

from __future__ import annotations

import datetime
import json
import platform
import subprocess
import sys
from pathlib import Path
from typing import Any

from petsc4py import PETSc

from app.blas_threads import record as blas_record

ROOT = Path(__file__).resolve().parents[2]
"""The checkout holding the code (app/output/provenance.py -> the project folder)."""


def git_version(root: Path = ROOT) -> dict | None:
    """{"commit", "dirty"} of the checkout holding the code, or None outside git."""
    try:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"],
                                capture_output=True, text=True, timeout=10)
        if commit.returncode != 0:
            return None
        status = subprocess.run(["git", "-C", str(root), "status", "--porcelain",
                                 "--untracked-files=no"], capture_output=True, text=True,
                                timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return {"commit": commit.stdout.strip(), "dirty": bool(status.stdout.strip())}


def app_version(root: Path = ROOT) -> str | None:
    """The project's version: from the pyproject.toml of the checkout holding the code,
    else from the installed distribution's metadata; None if neither is found."""
    import tomllib
    from importlib import metadata

    try:
        project = tomllib.loads((root / "pyproject.toml").read_text())["project"]
        if project.get("name") == "csfem-contact" and "version" in project:
            return str(project["version"])
    except (OSError, KeyError, TypeError, ValueError):
        pass
    try:
        return metadata.version("csfem-contact")
    except metadata.PackageNotFoundError:
        return None


def jsonable(value: Any) -> Any:
    """A copy that json can write (TOML dates and times become ISO strings)."""
    return json.loads(json.dumps(value, default=str))


def provenance(raw: dict, overrides: list[str], ranks: int) -> dict:
    """The resolved config (after --set), the overrides, the PETSc options in force, the
    project version, the start time (UTC, ISO 8601), the number of ranks and the BLAS
    threads (`blas_threads`: app/blas_threads.py)."""
    return {
        "start_time": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "ranks": ranks,
        "argv": list(sys.argv),
        "overrides": list(overrides),
        "config_resolved": jsonable(raw),
        "petsc_options": {k: str(v) for k, v in sorted(PETSc.Options().getAll().items())},
        "version": {"app": app_version(),
                    "git": git_version(),
                    "python": platform.python_version(),
                    "petsc": ".".join(map(str, PETSc.Sys.getVersion()))},
        "host": platform.node(),
        "blas_threads": blas_record(),
    }
