"""matplotlib for the study and sweep plots: the Agg backend (no display), imported once."""

from __future__ import annotations

import warnings
from types import ModuleType


def pyplot() -> ModuleType:
    """matplotlib.pyplot on Agg. Its import warns "Unable to import Axes3D" where a second
    matplotlib's mpl_toolkits is on the path (the venv sees Debian's packages, e.g. those
    ParaView brings); the plots use no 3D axes, so that warning is not shown to users."""
    import matplotlib

    matplotlib.use("Agg")
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Unable to import Axes3D")
        import matplotlib.pyplot as plt
    return plt
