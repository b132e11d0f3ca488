"""MuJoCo as an engine: the arm's MJCF (``md.to_mjcf``) compiled and asked for its dynamics.

Layer 3 (engines: mujoco).  ``arm.engine("mujoco")`` (:mod:`.engine`) answers
:class:`manipdyn.DynamicsEngine` through ``mj_fullM``, ``qfrc_bias``, ``mj_inverse`` and
``mj_forward``; it is registered by the package top when the ``mujoco`` extra imports
(:mod:`.deps`).  Shares no code with ``engines.lagrange``, ``engines.pinocchio`` or
``engines.c`` (the independence contract).
May import: ``manipdyn.formats`` (the MJCF writer), ``manipdyn.model``, ``manipdyn._support``.
"""

from .deps import available, mujoco_module
from .engine import NOT_OFFERED, MujocoEngine, mujoco_engine

__all__ = ["MujocoEngine", "mujoco_engine", "NOT_OFFERED", "available", "mujoco_module"]
