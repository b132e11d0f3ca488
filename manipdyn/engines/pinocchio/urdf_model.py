"""Pinocchio's model of an arm: from the arm's own URDF, or the URDF generated from its chain.

Layer 3 (engines: pinocchio), part of :mod:`manipdyn.engines.pinocchio.engine` (importable from
there as before).  Before the engine serves, :func:`manipdyn.engines.pinocchio.agree.check_same_arm`
compares Pinocchio's reading of the URDF with manipdyn's own.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..._support.errors import ModelError
from ...formats.urdf.writer import arm_to_urdf
from .agree import check_same_arm

__all__ = ["model_from_urdf", "model_for_arm"]


def model_from_urdf(urdf_text: str, gravity, armature=None) -> "pin.Model":
    """Build a fixed-base ``pin.Model`` from URDF text, with the given gravity (m/s^2)."""
    model = pin.buildModelFromXML(urdf_text)
    model.gravity.linear = np.asarray(gravity, dtype=np.float64)
    if armature is not None:
        model.armature = np.asarray(armature, dtype=np.float64)
    return model


def model_for_arm(arm) -> "pin.Model":
    """Pinocchio's model of ``arm``: from the original URDF text when the arm came
    from a file (reduced by locking its off-chain joints at ``pin.neutral``, 0),
    otherwise from the URDF generated from the arm's chain."""
    where = getattr(arm, "source", "") or arm.name or "arm"
    armature = arm.armature if arm.transmission.is_diagonal else np.diag(arm.rotor_inertia)
    if arm.source_urdf is None:
        model = model_from_urdf(arm_to_urdf(arm), arm.gravity, armature)
        check_same_arm(model, arm, where)
        return model
    try:
        model = pin.buildModelFromXML(arm.source_urdf)
    except (RuntimeError, ValueError) as exc:
        msg = " ".join(str(exc).split())
        raise ModelError(f"{where}: Pinocchio's URDF reader (urdfdom) refuses the file that manipdyn "
                         f"read: {msg}") from None
    if arm.locked_joints:
        ids = []
        for nm in arm.locked_joints:
            if not model.existJointName(nm):
                raise ModelError(f"{where}: Pinocchio's model has no joint {nm!r} to lock")
            ids.append(model.getJointId(nm))
        model = pin.buildReducedModel(model, ids, pin.neutral(model))
    check_same_arm(model, arm, where)  # both readers must read the same arm (joints, order, nq, ...)
    model.gravity.linear = np.array(arm.gravity)
    model.armature = np.array(armature)
    return model
