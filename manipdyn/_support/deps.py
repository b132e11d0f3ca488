"""Optional extras: a module of one imported, or :class:`MissingExtraError` with the install command.

Layer 0 (support).

:func:`require` imports a module of an extra (by default ``identify``: scipy, cvxpy with the
Clarabel and SCS solvers) or raises :class:`MissingExtraError` naming what needs it and the
command that installs it (:func:`install_command`), never a bare ``ImportError`` traceback.
The engines' extras (``codegen``, ``mujoco``) go through it too.
"""

from __future__ import annotations

import importlib

from .errors import MissingExtraError

__all__ = ["MissingExtraError", "require", "install_command", "INSTALL"]


def install_command(extra: str) -> str:
    """The command that installs manipdyn's optional extra ``extra``, from PyPI and from a checkout."""
    return f"pip install 'manipdyn[{extra}]' (in a source checkout: pip install -e '.[{extra}]')"


#: the command that installs what identification needs
INSTALL = install_command("identify")


def require(module: str, what: str, extra: str = "identify", label: str = "identification"):
    """Import ``module`` (e.g. ``"cvxpy"``) or raise :class:`MissingExtraError` saying
    ``what`` needs it and how to install the ``extra`` (called the ``label`` extra in the message)."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingExtraError(
            f"{what} needs the Python package {module!r}, which is not installed "
            f"({exc}); install the {label} extra: {install_command(extra)}"
        ) from None
