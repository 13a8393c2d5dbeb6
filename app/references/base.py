"""What a closed-form reference receives from a run, and what it gives back."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from app.errors import InputError


@dataclass
class ContactProfile:
    """The first interface's pairs at the last step (m pairs, any order).

    x: (m,) slave positions along the interface (length); p, q: (m,) tractions;
    length: (m,) tributary lengths; p_force, q_force: (m,) pair forces; stick: (m,) bool,
    pairs in contact that did not slip; mu: the interface's friction coefficient;
    E_star: the effective modulus of the two bodies (plane strain or stress); y: (m,) the
    slave positions across (None: not known); tangent: (m, 2) the pairs' unit tangents
    (global axes; None: not known, p is then measured along x), the contact's direction.
    """

    x: np.ndarray
    p: np.ndarray
    q: np.ndarray
    length: np.ndarray
    p_force: np.ndarray
    q_force: np.ndarray
    stick: np.ndarray
    mu: float
    E_star: float
    interface: str
    y: np.ndarray | None = None
    tangent: np.ndarray | None = None


@dataclass
class RunFigures:
    """A run's results a reference compares with: material and plane of the first body,
    thickness, strain energy, the displacements at the [points], the contact profile
    (None without contact) and summary.json's `steps` entries (the load path)."""

    E: float
    nu: float
    plane: str
    thickness: float
    strain_energy: float
    point_values: dict
    contact: ContactProfile | None = None
    steps: list = field(default_factory=list)


@dataclass(frozen=True)
class Reference:
    """One closed form.

    keys: accepted [reference] keys besides `type`, with their defaults (None: required);
    errors(params, figures) -> the summary's `reference` entries (relative errors);
    columns: (summary path, study column) pairs of the errors a study reports;
    overlay(summary_reference, mu) -> {"p": (label, f(x)), "q": (label, f(x))}, the
    closed-form curves for the contact plots (an empty dict when there are none);
    positive, nonzero: numeric keys that must be > 0 or != 0 (every number is finite);
    optional: keys that may be left out (None in `params`).
    """

    name: str
    keys: dict[str, object]
    errors: Callable[[dict, RunFigures], dict]
    columns: tuple[tuple[tuple[str, ...], str], ...]
    overlay: Callable[[dict, float], dict[str, tuple[str, Callable]]] = field(
        default=lambda ref, mu: {})
    needs_contact: bool = False
    positive: tuple[str, ...] = ()
    nonzero: tuple[str, ...] = ()
    optional: tuple[str, ...] = ()

    def params(self, table: dict) -> dict:
        """The [reference] table checked: unknown keys and missing required ones are
        one-line errors; numbers come back as floats."""
        unknown = sorted(set(table) - set(self.keys) - {"type"})
        if unknown:
            raise InputError(f"[reference] type '{self.name}': unknown key(s) {unknown}; "
                             f"use {sorted(self.keys)}")
        out = {}
        for key, default in self.keys.items():
            value = table.get(key, default)
            if value is None and key in self.optional:
                out[key] = None
                continue
            if value is None:
                raise InputError(f"[reference] type '{self.name}' needs {key}")
            if isinstance(default, str) and (not isinstance(value, str) or not value):
                raise InputError(f"[reference] {key} must be a name (got {value!r})")
            if not isinstance(default, str):
                if isinstance(value, bool) or not isinstance(value, int | float):
                    raise InputError(f"[reference] {key} must be a number (got {value!r})")
                value = float(value)
                if not np.isfinite(value) or (key in self.positive and not value > 0) or (
                        key in self.nonzero and value == 0):
                    need = ("> 0" if key in self.positive else "a finite non-zero number"
                            if key in self.nonzero else "a finite number")
                    raise InputError(f"[reference] {key} must be {need} (got {value!r})")
            out[key] = value
        return out

    def compare(self, table: dict, figures: RunFigures) -> dict:
        """The summary's `reference` dict for a run."""
        if self.needs_contact and figures.contact is None:
            raise InputError(f"[reference] type '{self.name}' needs an [[interface]]")
        return {"type": self.name} | self.errors(self.params(table), figures)
