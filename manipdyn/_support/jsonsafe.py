"""Strict JSON of computed results: every non-finite float as null.

Layer 0 (support).  ``json.dumps`` writes ``NaN`` and ``Infinity``, which strict JSON readers refuse;
a quantity that could not be computed (a run that diverged, a horizon no start state reached) is
null instead.
"""

from __future__ import annotations

import math

__all__ = ["finite_or_null"]


def finite_or_null(x):
    """``x`` with every non-finite float replaced by None (recursively through dicts, lists and tuples;
    a tuple comes back as a list)."""
    if isinstance(x, dict):
        return {k: finite_or_null(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [finite_or_null(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x
