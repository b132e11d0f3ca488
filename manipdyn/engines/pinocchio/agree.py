"""Both URDF readers must read the same arm: Pinocchio's model against manipdyn's chain.

Layer 3 (engines: pinocchio) (next to :mod:`manipdyn.engines.pinocchio.engine`, which calls
:func:`check_same_arm` right after Pinocchio has built its model).

manipdyn reads a URDF with its own parser (:mod:`manipdyn.formats.urdf.reader`, lxml);
Pinocchio reads the same text with urdfdom.  Two parsers can read one file
differently (a DOCTYPE default, a tab inside a number, a digit that is not
ASCII...): the two engines would then describe two different arms and every
comparison between them would be meaningless.  So before an engine is
handed out, its model is compared with the chain joint by joint, structure
and numbers: names, types (revolute or prismatic), placements (the fixed
transform from the previous joint frame), axes, position limits where the
file gives them, effort and velocity limits, damping and friction, and each
joint body's mass, centre of mass and inertia (bodies after fixed joints
and locked joints lumped in, by both readers).

Tolerance: both readers compute the same float64 sums (lumping, composing
fixed transforms) in different orders, which differ by a few ulps.  A
quantity agrees when ``|a - b| <= 1e-9 * max(|a|, |b|) + 1e-12 * S`` with
``S`` the arm's scale of that kind of quantity (largest length, mass or
inertia entry of the chain): 1e-9 is a million times the rounding and far
below any reading difference, which changes a number at its first digits.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from ..._support.errors import ModelError
from ...model.inertia import inertia_about_origin_from_com

__all__ = ["check_same_arm", "REL_TOL"]

#: relative tolerance of the reader comparison (see the module docstring)
REL_TOL = 1e-9
#: floor, relative to the arm's scale of the quantity
SCALE_TOL = 1e-12


def _fmt(x) -> str:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 0:
        return repr(float(a))
    return np.array2string(a, precision=12, separator=", ", max_line_width=200)


def _differs(a, b, scale) -> bool:
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        return True
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        return True
    tol = REL_TOL * max(float(np.abs(a).max(initial=0.0)), float(np.abs(b).max(initial=0.0))) + SCALE_TOL * scale
    return bool(np.abs(a - b).max(initial=0.0) > tol)


def _motion_axis(model, data, i):
    """(type letter, unit axis) of joint i from its motion subspace at q = 0."""
    S = np.asarray(data.joints[i].S.matrix() if hasattr(data.joints[i].S, "matrix") else data.joints[i].S,
                   dtype=np.float64).reshape(6, -1)
    if S.shape[1] != 1:
        return "?", S[:, 0]
    v, w = S[:3, 0], S[3:, 0]
    if np.any(w) and not np.any(v):
        return "revolute", w
    if np.any(v) and not np.any(w):
        return "prismatic", v
    return "?", S[:, 0]


def check_same_arm(model, arm, where: str) -> None:
    """Raise :class:`ModelError` if Pinocchio's ``model`` and ``arm.chain()`` describe different arms.

    The message names the joint (or its child link) and gives both readings.
    ``model`` must already be reduced to the chain's joints (locked joints removed).
    """
    joints, _tool = arm.chain()
    n = len(joints)
    names = tuple(model.names)[1:]
    chain_names = tuple(j.name for j in joints)
    if names != chain_names:
        raise ModelError(f"{where}: the two URDF readers disagree on the joints: Pinocchio (urdfdom) "
                         f"reads {list(names)}, manipdyn reads {list(chain_names)}")
    if not (model.nq == model.nv == n):
        raise ModelError(f"{where}: Pinocchio's model has nq={model.nq}, nv={model.nv}; expected {n}")
    data = model.createData()
    pin.forwardKinematics(model, data, np.zeros(model.nq))
    L = max([float(np.abs(j.origin[:3, 3]).max()) for j in joints]
            + [float(np.abs(j.body.com).max()) for j in joints] + [1e-300])
    M = max([j.body.mass for j in joints] + [1e-300])
    Imax = max([float(np.abs(j.body.inertia).max()) for j in joints] + [1e-300])

    def fail(j, what, theirs, ours):
        link = f" (link '{j.link_name}')" if getattr(j, "link_name", "") else ""
        raise ModelError(
            f"{where}: the two URDF readers read joint '{j.name}'{link} differently: {what}: "
            f"Pinocchio (urdfdom) reads {theirs}, manipdyn reads {ours}. The engines would describe "
            "two different arms; check that element of the file (whitespace, DOCTYPE, number format)"
        )

    for k, j in enumerate(joints):
        i = k + 1
        kind, axis = _motion_axis(model, data, i)
        if kind != j.joint:
            fail(j, "joint type", f"{model.joints[i].shortname()} ({kind})", j.joint)
        nrm = float(np.linalg.norm(axis))
        if not (nrm > 0 and math.isfinite(nrm)) or _differs(axis / nrm, j.axis, 1.0):
            fail(j, "axis", _fmt(axis), _fmt(j.axis))
        P = model.jointPlacements[i]
        if _differs(P.translation, j.origin[:3, 3], L):
            fail(j, "origin xyz (from the previous joint frame, fixed joints composed)",
                 _fmt(P.translation), _fmt(j.origin[:3, 3]))
        if _differs(P.rotation, j.origin[:3, :3], 1.0):
            fail(j, "origin rotation", _fmt(P.rotation), _fmt(j.origin[:3, :3]))
        Y = model.inertias[i]
        if _differs(Y.mass, j.body.mass, M):
            fail(j, "mass of the moving body (lumped)", _fmt(Y.mass), _fmt(j.body.mass))
        # first moment m c and the inertia about the joint origin: a massless
        # body's centre of mass is arbitrary (urdfdom puts it at 0)
        mc_p, mc_o = Y.mass * np.asarray(Y.lever), j.body.mass * j.body.com
        if _differs(mc_p, mc_o, M * L):
            fail(j, "centre of mass (as mass x com)", f"mass {_fmt(Y.mass)} at {_fmt(Y.lever)}",
                 f"mass {_fmt(j.body.mass)} at {_fmt(j.body.com)}")
        if _differs(inertia_about_origin_from_com(Y.mass, Y.lever, Y.inertia),
                    j.body.inertia_about_origin(), Imax + M * L * L):
            fail(j, "inertia tensor about the centre of mass", _fmt(Y.inertia), _fmt(j.body.inertia))
        lo, hi = float(model.lowerPositionLimit[k]), float(model.upperPositionLimit[k])
        if j.qlim is not None and lo < hi and _differs((lo, hi), j.qlim, 1.0):
            fail(j, "position limits (lower, upper)", _fmt((lo, hi)), _fmt(j.qlim))
        if j.effort is not None and _differs(model.effortLimit[k], j.effort, 1.0):
            fail(j, "effort limit", _fmt(model.effortLimit[k]), _fmt(j.effort))
        if j.velocity is not None and _differs(model.velocityLimit[k], j.velocity, 1.0):
            fail(j, "velocity limit", _fmt(model.velocityLimit[k]), _fmt(j.velocity))
        if _differs(model.damping[k], j.friction_viscous, 1.0):
            fail(j, "damping (viscous friction)", _fmt(model.damping[k]), _fmt(j.friction_viscous))
        if _differs(model.friction[k], j.friction_coulomb, 1.0):
            fail(j, "friction (Coulomb)", _fmt(model.friction[k]), _fmt(j.friction_coulomb))
