"""The optional ``identify`` extra (scipy, cvxpy with the Clarabel and SCS solvers).

Layer 0 (support).

:func:`require` imports one of its modules or raises :class:`MissingExtraError`
with the install command, never a bare ``ImportError`` traceback.
"""

from __future__ import annotations

import importlib

from .errors import MissingExtraError

__all__ = ["MissingExtraError", "require", "INSTALL"]

#: the command that installs what identification needs
INSTALL = "pip install 'manipdyn[identify]' (in a source checkout: pip install -e '.[identify]')"


def require(module: str, what: str):
    """Import ``module`` (e.g. ``"cvxpy"``) or raise :class:`MissingExtraError` saying
    ``what`` needs it and how to install it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingExtraError(
            f"{what} needs the Python package {module!r}, which is not installed "
            f"({exc}); install the identification extra: {INSTALL}"
        ) from None
