"""The optional ``mujoco`` extra (the MuJoCo wheel) of the MuJoCo engine and simulator.

Layer 3 (engines: mujoco).  :func:`mujoco_module` imports MuJoCo or raises
:class:`~manipdyn._support.errors.MissingExtraError` with the install command, never a bare
``ImportError`` traceback.  Writing MJCF (``md.to_mjcf``) needs no MuJoCo.
"""

from __future__ import annotations

import re

from ..._support.deps import MissingExtraError, install_command, require
from ..._support.errors import ModelNoteWarning, warn_at_caller

__all__ = ["mujoco_module", "available", "INSTALL", "MuJoCoWarning"]

#: the oldest MuJoCo (major, minor) manipdyn runs on, as pyproject.toml's ``mujoco`` extra says: ``mj_fullM(m, d, dst)``
#: is 3.10's; before 3.14 the compiler's principal axes of a full inertia are off by ~1e-7 (D, h: 3e-9 relative)
MINIMUM = (3, 14)

#: the command that installs MuJoCo for manipdyn
INSTALL = install_command("mujoco")


def available() -> bool:
    """True when a MuJoCo manipdyn runs on imports (:func:`mujoco_module` would return it)."""
    try:
        mujoco_module()
    except MissingExtraError:
        return False
    return True


class MuJoCoWarning(ModelNoteWarning):
    """A warning of MuJoCo's own (``Inertia matrix is too close to singular``, ``Nan, Inf or huge value in
    QPOS``), routed through Python's warnings (:func:`mujoco_module`): never printed raw, never into
    ``./MUJOCO_LOG.TXT``."""


def _warn(text) -> None:
    """MuJoCo's ``mju_warning`` as a :class:`MuJoCoWarning` at the user's call, its "Time = ..." tail
    dropped so that the same warning at many steps is one (``warnings`` and the CLI show a line once)."""
    msg = re.sub(r"\s*Time = [-+0-9.eE]+\.?\s*$", "", " ".join(str(text).split()))
    warn_at_caller(f"MuJoCo: {msg}", MuJoCoWarning)


def mujoco_module():
    """The ``mujoco`` module, or :class:`MissingExtraError` naming the extra to install.  MuJoCo's own
    warnings go through Python's (:class:`MuJoCoWarning`), not to stdout and ``./MUJOCO_LOG.TXT``."""
    mj = require("mujoco", "MuJoCo as an engine ('mujoco') or as the simulator", "mujoco", "MuJoCo")
    if tuple(map(int, mj.__version__.split(".")[:2])) < MINIMUM:       # why: MINIMUM's comment
        raise MissingExtraError(f"manipdyn needs MuJoCo {MINIMUM[0]}.{MINIMUM[1]} or later, not {mj.__version__}: "
                                f"{INSTALL}")
    if getattr(mj, "get_mju_user_warning", lambda: None)() is not _warn and hasattr(mj, "set_mju_user_warning"):
        mj.set_mju_user_warning(_warn)
    return mj
