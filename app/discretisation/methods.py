"""The registry of bulk methods: a new method is one file of kernels and one entry here.

Each entry names the method (config `analysis.method`, `--method`), the smoothing-domain
counts it accepts (`analysis.sd`, `--sd`; empty when it takes none), its labels and its
kernels: the cell gradients (numpy) and the compiled kernel's constant cell operators.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from app.discretisation import cs_fem, fem_q4
from app.discretisation.elements import b_from_gradients
from app.errors import InputError


@dataclass(frozen=True)
class BulkMethod:
    """One bulk discretisation.

    sd_choices: accepted smoothing-domain counts (() when the method takes none);
    label: long label for a given sd ("CS-FEM-4SD"); short: the study's label ("4SD");
    study_names: names accepted in `study --methods` (besides a bare sd for CS-FEM);
    cell_gradients(xe (n, 4, 2) relative corners, sd) -> (bx, by (n, nc, 4), w (n, nc));
    cell_operators(sd) -> (T, S, gw) for the compiled kernel;
    hourglass(sd): True when the element stiffness has zero-energy (hourglass) modes.
    """

    name: str
    sd_choices: tuple[int, ...]
    label: Callable[[int], str]
    short: Callable[[int], str]
    study_names: tuple[str, ...]
    cell_gradients: Callable[[np.ndarray, int], tuple]
    cell_operators: Callable[[int], tuple]
    hourglass: Callable[[int], bool]

    def check_sd(self, sd: int | None, where: str) -> int:
        """The sd to use; InputError naming `where` when the method does not accept it."""
        if not self.sd_choices:
            return 4 if sd is None else int(sd)
        if isinstance(sd, bool) or not isinstance(sd, int) or sd not in self.sd_choices:
            sep = " " if where.startswith("--") else " = "  # "--sd 7", "analysis.sd = 7"
            raise InputError(f"{where}{sep}{sd!r}: choose one of {list(self.sd_choices)}")
        return sd


BULK_METHODS: dict[str, BulkMethod] = {
    m.name: m for m in (
        BulkMethod("cs-fem", cs_fem.SMOOTHING_DOMAINS, lambda sd: f"CS-FEM-{sd}SD",
                   lambda sd: f"{sd}SD", (), cs_fem.cell_gradients, cs_fem.cell_operators,
                   lambda sd: sd == 1),
        BulkMethod("fem-q4", (), lambda sd: "FEM-Q4", lambda sd: "FEM-Q4", ("q4", "fem-q4"),
                   fem_q4.cell_gradients, fem_q4.cell_operators, lambda sd: False),
    )
}


def bulk_method(name: str, where: str = "analysis.method") -> BulkMethod:
    """The registered method `name`, or an InputError listing the registered ones."""
    try:
        return BULK_METHODS[name]
    except (KeyError, TypeError):
        names = ", ".join(repr(n) for n in BULK_METHODS)
        sep = " " if where.startswith("--") else " = "
        raise InputError(f"{where}{sep}{name!r}: use one of {names}") from None


def cell_gradients(xe: np.ndarray, method: str, sd: int = 4
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gradients and weights of every cell of every element (see `BulkMethod`).

    Gradients and weights do not change under a translation, so the corners are taken
    relative to the first one: far from the origin, absolute coordinates would cost
    digits in the differences of nearby corners (2e-10 relative at x = 10, h = 0.003).
    """
    return bulk_method(method, "method").cell_gradients(xe - xe[:, :1, :], sd)


def strain_matrices(xe: np.ndarray, method: str, sd: int = 4
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Strain matrices and weights of every cell of every element.

    Returns (B (n, n_cells, 3, 8), weights (n, n_cells)).
    """
    bx, by, w = cell_gradients(xe, method, sd)
    n, nc = w.shape
    b = b_from_gradients(bx.reshape(n * nc, 4), by.reshape(n * nc, 4))
    return b.reshape(n, nc, 3, 8), w
