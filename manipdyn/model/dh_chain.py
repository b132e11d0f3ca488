"""A DH table as a URDF-ready chain: where each joint's frame sits, and each DH frame in it.

Layer 1 (model), part of :class:`manipdyn.model.arm.Manipulator` (its ``chain`` and
``urdf_link_offsets``).  The engines that read a chain (Pinocchio, through the generated URDF;
the URDF and MJCF writers) see a DH arm only through these two functions.
"""
from __future__ import annotations

import numpy as np

from .._support.errors import ModelError
from .kinematics import rot_x, rot_z, trans
from .links import ChainJoint

__all__ = ["dh_chain", "dh_link_offsets", "as_transform"]


def as_transform(value, name: str) -> np.ndarray:
    """``value`` as a read-only (4, 4) rigid homogeneous transform (identity for None), else a
    :class:`ModelError` naming ``name``: finite numbers, last row ``[0, 0, 0, 1]``, and a rotation
    block orthonormal with determinant +1 (to 1e-9: a rotation printed to nine digits passes)."""
    if value is None:
        T = np.eye(4)
    else:
        try:
            T = np.array(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise ModelError(f"{name}: expected a 4x4 homogeneous transform (rotation and translation, "
                             f"metres), got {value!r:.80}") from None
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise ModelError(f"{name}: expected a 4x4 homogeneous transform of finite numbers (rotation and "
                             f"translation, metres), got shape {T.shape}")
        if not np.array_equal(T[3], [0.0, 0.0, 0.0, 1.0]):
            raise ModelError(f"{name}: the last row of a homogeneous transform is [0, 0, 0, 1], got {T[3].tolist()}")
        R = T[:3, :3]
        if np.abs(R @ R.T - np.eye(3)).max() > 1e-9 or np.linalg.det(R) < 0:
            raise ModelError(f"{name}: the upper-left 3x3 block must be a rotation (orthonormal, det +1), got "
                             f"{R.tolist()}")
    T.setflags(write=False)
    return T


def dh_link_offsets(links, convention: str) -> np.ndarray:
    """``S_i`` (n, 4, 4): DH frame i = URDF link i frame @ S_i; ``Tx(a_i) Rx(alpha_i)`` for standard DH,
    the identity for modified DH (the URDF link frame IS DH frame i)."""
    if convention == "modified":
        return np.tile(np.eye(4), (len(links), 1, 1))
    return np.array([trans(l.a, 0, 0) @ rot_x(l.alpha) for l in links])


def dh_chain(links, convention: str, qlim, names, offsets=None, base=None, tool=None):
    """``(joints, tool)``: the DH links as :class:`~manipdyn.model.links.ChainJoint` s and the fixed
    transform from the last URDF link to DH frame n (see :meth:`manipdyn.model.arm.Arm.chain`).

    Standard DH: joint i turns about z of frame i-1, so its URDF frame is
    ``T_{i-1} Rz(theta_i) Tz(d_i)``, and DH frame i is that frame (after
    the motion) times ``S_i = Tx(a_i) Rx(alpha_i)``; ``S_i`` moves into the
    next joint's origin, and ``S_n`` into the tool joint.  Modified DH:
    the URDF link frame IS DH frame i.  The fixed offsets theta and d go
    into the origins, so URDF joint positions are the DH joint variables q.
    ``qlim`` (n, 2), ``names`` the n link names, ``offsets`` the ``S_i`` (default :func:`dh_link_offsets`).
    ``base`` (4, 4): the arm's base frame in the world, put before joint 1's origin; ``tool`` (4, 4):
    the tool frame in DH frame n, put after ``S_n`` (both default the identity).
    """
    joints = []
    prev_S = np.eye(4)
    offsets = dh_link_offsets(links, convention) if offsets is None else offsets
    for i, l in enumerate(links):
        S = offsets[i]
        if convention == "standard":
            origin = prev_S @ rot_z(l.theta) @ trans(0, 0, l.d)
        else:
            origin = rot_x(l.alpha) @ trans(l.a, 0, 0) @ rot_z(l.theta) @ trans(0, 0, l.d)
        if i == 0 and base is not None:
            origin = np.asarray(base) @ origin
        body = l.body.transformed(S)  # frame-i data into the URDF link frame
        joints.append(ChainJoint(
            name=f"joint{i + 1}", joint=l.joint, origin=origin, axis=(0.0, 0.0, 1.0),
            body=body, qlim=tuple(qlim[i]), armature=l.armature,
            friction_viscous=l.friction_viscous, friction_coulomb=l.friction_coulomb,
            link_name=names[i],
        ))
        prev_S = S
    return tuple(joints), (prev_S if tool is None else prev_S @ np.asarray(tool))
