"""Optional extras: a module of one imported, or :class:`MissingExtraError` with the install command.

Layer 0 (support).

:func:`require` imports a module of an extra (by default ``identify``: scipy, cvxpy with the
Clarabel and SCS solvers) or raises :class:`MissingExtraError` naming what needs it and the
command that installs it (:func:`install_command`), never a bare ``ImportError`` traceback.
The engines' extras (``codegen``, ``mujoco``) go through it too.  A **core** dependency missing
(:data:`CORE`: a Python without the package's own dependencies, e.g. not the venv it was installed in) is
told in one line by :func:`missing_core`, which the command's start-up hook prints
(:mod:`.interrupt`).
"""

from __future__ import annotations

import importlib

from .errors import MissingExtraError

__all__ = ["MissingExtraError", "require", "install_command", "INSTALL", "CORE", "missing_core"]

#: the core dependencies: module imported -> the distribution pip installs (pyproject.toml's dependencies)
CORE = {"numpy": "numpy", "pinocchio": "pin", "yourdfpy": "yourdfpy", "lxml": "lxml",
        "example_robot_data": "example-robot-data"}


def missing_core(exc) -> str | None:
    """The one line that says a core dependency (:data:`CORE`) is not installed in this Python, for the
    :class:`ModuleNotFoundError` ``exc``; None for any other error."""
    import sys

    name = (getattr(exc, "name", None) or "").split(".")[0]
    if not isinstance(exc, ModuleNotFoundError) or name not in CORE:
        return None
    return (f"manipdyn: the Python running it ({sys.executable}) does not have manipdyn's dependency "
            f"{CORE[name]!r} (module {name!r}); run manipdyn with the Python it was installed into (its venv), or "
            "install it there: pip install manipdyn (in a source checkout: pip install -e .)")


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
