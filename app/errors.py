"""Errors the application reports to the user as one line (no traceback)."""


class InputError(Exception):
    """Bad input (config, mesh, parameter): the message names the thing to fix."""


class SolveError(Exception):
    """A solve that cannot give a right answer (singular stiffness, no equilibrium)."""
