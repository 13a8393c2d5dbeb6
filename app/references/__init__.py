"""Closed-form references a run is checked against: one file per reference, one entry in
REFERENCES. The formulas live in app/closed_form.py; a reference adds what run, study and
the pictures need: its [reference] keys, its error function, its study columns and the
curves overlaid on the contact plots.

Adding a reference: write app/references/NAME.py with a `Reference` instance (see
hertz.py), and add it to REFERENCES below.
"""

from __future__ import annotations

from app.errors import InputError
from app.references import cattaneo, hertz, mindlin, timoshenko
from app.references.base import ContactProfile, Reference, RunFigures

REFERENCES: dict[str, Reference] = {
    r.name: r for r in (timoshenko.REFERENCE, hertz.REFERENCE, cattaneo.REFERENCE,
                        mindlin.REFERENCE)
}

__all__ = ["REFERENCES", "ContactProfile", "Reference", "RunFigures", "reference"]


def reference(name: object) -> Reference:
    """The registered reference `name`, or a one-line InputError listing them."""
    try:
        return REFERENCES[name]  # type: ignore[index]
    except (KeyError, TypeError):
        raise InputError(f"[reference] type = {name!r}: use one of "
                         f"{', '.join(map(repr, REFERENCES))}") from None
