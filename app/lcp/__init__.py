"""Linear complementarity problems: Lemke's method (`lemke`, `LCPResult`).

`from app.lcp import lemke` gives the solver function; the module `app.lcp.lemke` is its
driver. The other modules, by concern: result, scaling, pivoting, revised (the fast core),
tableau (the reference core), crash (cold-start basis), repair (symmetric basis repair).
"""

from app.lcp.lemke import STATUSES, LCPResult, default_max_pivots, lemke

__all__ = ["STATUSES", "LCPResult", "default_max_pivots", "lemke"]
