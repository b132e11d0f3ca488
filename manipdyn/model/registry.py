"""The engine registry and the words an arm is described with.

Layer 1 (model), part of :mod:`manipdyn.model.arm` (whose names these are: ``from
manipdyn.model.arm import register_engine, DEFAULT_QLIM, ...`` as before).  Engines plug into
the model from above through :func:`register_engine`, and the layers above back the arm's
deprecated conveniences through :func:`register_service`, so the model imports neither;
:class:`TraceFormData` is what the trace-form engine reads of an arm; :data:`DEFAULT_QLIM` the
joint limits of a link that gives none; :data:`Convention` the two DH conventions.
"""
from __future__ import annotations

import math
from typing import Callable, Literal, NamedTuple, get_args

import numpy as np

__all__ = ["Convention", "CONVENTIONS", "REQUIRED", "ENGINE_FACTORIES", "SERVICES", "register_engine",
           "register_service", "TraceFormData", "DEFAULT_QLIM", "joint_letters"]

#: the two DH conventions; there is no default (see :class:`manipdyn.model.arm.Manipulator`)
Convention = Literal["standard", "modified"]
CONVENTIONS = get_args(Convention)
REQUIRED: Convention = "<required>"  # type: ignore[assignment]  # sentinel: convention not given

#: engine factories by name (``"lagrange"``, ``"pinocchio"``), registered by
#: the engine modules when they are imported (``import manipdyn`` imports them)
ENGINE_FACTORIES: dict[str, Callable] = {}
#: functions of the layers above that the deprecated convenience methods call
#: (``"save"``, ``"write_urdf"``, ``"to_urdf"``, ``"crosscheck"``)
SERVICES: dict[str, Callable] = {}


def register_engine(name: str, factory: Callable) -> None:
    """Make ``arm.<name>`` build an engine with ``factory(arm)`` on first use.

    This is how an engine plugs into the model without the model importing it.
    """
    ENGINE_FACTORIES[name] = factory


def register_service(name: str, fn: Callable) -> None:
    """Back a deprecated convenience method (``arm.save`` ...) with ``fn(arm, ...)``."""
    SERVICES[name] = fn


class TraceFormData(NamedTuple):
    """What the trace-form engine needs of an arm (:meth:`manipdyn.model.arm.Arm.trace_form_data`).

    kinematics : DHKinematics or ChainKinematics
        Link frames T_i and joint generators, batched.
    J : (n, 4, 4)
        Pseudo-inertias (eq. 2.21) in the frames ``kinematics`` produces.
    armature : (n,)
        Reflected rotor inertias ``R_kk^2 Jm_k``, kg m^2 (kg for prismatic joints).
    friction : Friction or None
        The friction law (:class:`manipdyn.model.drive.Friction`); the transmission and
        the rotors' ``Jm`` are ``arm.transmission`` and ``arm.motor_inertia``.
    """

    kinematics: object
    J: np.ndarray
    armature: np.ndarray
    friction: object

#: joint-limit defaults used when a link has no ``qlim``: revolute +-pi rad,
#: prismatic +-1 m.  They bound the states the cross-check draws.
DEFAULT_QLIM = {"revolute": (-math.pi, math.pi), "prismatic": (-1.0, 1.0)}


def joint_letters(joint_types) -> str:
    """``("revolute", "prismatic")`` -> ``"RP"``."""
    return "".join("R" if t == "revolute" else "P" for t in joint_types)
