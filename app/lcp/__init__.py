"""Linear complementarity problems: Lemke's method (`lemke`, `LCPResult`).

`from app.lcp import lemke` gives the solver function; the module `app.lcp.lemke` is its
driver. The other modules, by concern: result, scaling, pivoting, revised (the fast core),
tableau (the reference core), crash (cold-start basis), recovery (the one recovery step
after a failed run), balance (two-sided balancing), repair (symmetric basis repair); exact
and audit: the adversarial checker of scripts/check_lcp.py (not used by lemke; its cases
are app.interface.audit_cases).
"""

from app.lcp.lemke import STATUSES, LCPResult, default_max_pivots, lemke

__all__ = ["STATUSES", "LCPResult", "default_max_pivots", "lemke"]
