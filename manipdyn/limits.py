"""Limits that keep the process alive on hostile or careless input.

Layer: bottom (beside errors).  Every limit is a module attribute: raise it
for an unusual but trusted model, e.g. ``manipdyn.limits.MAX_LINKS = 5000``
before ``md.load``.  A model over a limit is refused with a
:class:`~manipdyn.ModelError` that names the limit and says how to raise it.

Why these numbers: real arms have under 50 links; Pinocchio's URDF reader
recurses once per link and crashes the interpreter (a segfault, not an
exception) on chains of some ten thousand links; the trace-form and
cross-check memory grow with ``n**2`` per state.
"""

from __future__ import annotations

from .errors import ModelError

__all__ = ["MAX_FILE_BYTES", "MAX_LINKS", "MAX_JOINTS", "MAX_FIXED_RUN", "MAX_MAGNITUDE", "over_limit"]

#: largest URDF or model file read, bytes (16 MiB; real ones are under 1 MiB)
MAX_FILE_BYTES = 16 * 1024 * 1024
#: most ``<link>`` (and so ``<joint>``) elements in a URDF
MAX_LINKS = 1000
#: most movable joints in an arm's chain (URDF chain, DH table, model file)
MAX_JOINTS = 300
#: most fixed joints in a row along any root-to-leaf path of a URDF
MAX_FIXED_RUN = 200
#: largest magnitude of any model number (lengths in m, masses in kg, inertias
#: in kg m^2, gear ratios, rotor inertias, friction): products of three of them
#: (m r^2 v^2 ...) stay far from float64 overflow (1.8e308)
MAX_MAGNITUDE = 1e60


def over_limit(where: str, what: str, value, name: str) -> ModelError:
    """The error for ``what`` (= ``value``) beyond the limit ``name`` of this module."""
    limit = globals()[name]
    return ModelError(
        f"{where}: {what} is {value}, over the limit of {limit:g} (manipdyn.limits.{name}); "
        f"if the model is trusted, raise it: manipdyn.limits.{name} = ..."
    )
