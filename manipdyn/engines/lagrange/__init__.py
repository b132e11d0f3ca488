"""The slow path: the trace-form Lagrange-Euler dynamics of chapter II (eq. 2.37 to 2.39).

Layer 3 (engines: lagrange).  ``engine`` (``TraceFormEngine``: D, h, g regrouped by link),
``derivatives`` (their closed-form derivatives) and ``drive`` (coupled rotors and
the friction law, coded from CONVENTIONS.md without Pinocchio).
May import: ``manipdyn.engines.protocol``, ``manipdyn.model``, ``manipdyn._support``.
"""
