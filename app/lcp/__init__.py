"""Linear complementarity problems: Lemke's method (`lemke`, `LCPResult`)."""

from app.lcp.lemke import STATUSES, LCPResult, default_max_pivots, lemke

__all__ = ["STATUSES", "LCPResult", "default_max_pivots", "lemke"]
