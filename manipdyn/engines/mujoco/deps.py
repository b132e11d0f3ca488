"""The optional ``mujoco`` extra (the MuJoCo wheel) of the MuJoCo engine and simulator.

Layer 3 (engines: mujoco).  :func:`mujoco_module` imports MuJoCo or raises
:class:`~manipdyn._support.errors.MissingExtraError` with the install command, never a bare
``ImportError`` traceback.  Writing MJCF (``md.to_mjcf``) needs no MuJoCo.
"""

from __future__ import annotations

import importlib

from ..._support.deps import install_command, require

__all__ = ["mujoco_module", "available", "INSTALL"]

#: the command that installs MuJoCo for manipdyn
INSTALL = install_command("mujoco")


def available() -> bool:
    """True when the ``mujoco`` package imports."""
    try:
        importlib.import_module("mujoco")
    except ImportError:
        return False
    return True


def mujoco_module():
    """The ``mujoco`` module, or :class:`MissingExtraError` naming the extra to install."""
    return require("mujoco", "MuJoCo as an engine ('mujoco') or as the simulator", "mujoco", "MuJoCo")
