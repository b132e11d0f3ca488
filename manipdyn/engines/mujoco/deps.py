"""The optional ``mujoco`` extra (the MuJoCo wheel) of the MuJoCo engine and simulator.

Layer 3 (engines: mujoco).  :func:`mujoco_module` imports MuJoCo or raises
:class:`~manipdyn._support.errors.MissingExtraError` with the install command, never a bare
``ImportError`` traceback.  Writing MJCF (``md.to_mjcf``) needs no MuJoCo.
"""

from __future__ import annotations

import importlib

from ..._support.errors import MissingExtraError

__all__ = ["mujoco_module", "available", "INSTALL"]

#: the command that installs MuJoCo for manipdyn
INSTALL = "pip install 'manipdyn[mujoco]' (from a checkout: pip install -e '.[mujoco]')"


def available() -> bool:
    """True when the ``mujoco`` package imports."""
    try:
        importlib.import_module("mujoco")
    except ImportError:
        return False
    return True


def mujoco_module():
    """The ``mujoco`` module, or :class:`MissingExtraError` naming the extra to install."""
    try:
        return importlib.import_module("mujoco")
    except ImportError as exc:
        raise MissingExtraError(
            f"the 'mujoco' engine and simulator need the Python package 'mujoco', which is not installed "
            f"({exc}); install the MuJoCo extra: {INSTALL}") from None
