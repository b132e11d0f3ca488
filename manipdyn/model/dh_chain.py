"""A DH table as a URDF-ready chain: where each joint's frame sits, and each DH frame in it.

Layer 1 (model), part of :class:`manipdyn.model.arm.Manipulator` (its ``chain`` and
``urdf_link_offsets``).  The engines that read a chain (Pinocchio, through the generated URDF;
the URDF and MJCF writers) see a DH arm only through these two functions.
"""
from __future__ import annotations

import numpy as np

from .kinematics import rot_x, rot_z, trans
from .links import ChainJoint

__all__ = ["dh_chain", "dh_link_offsets"]


def dh_link_offsets(links, convention: str) -> np.ndarray:
    """``S_i`` (n, 4, 4): DH frame i = URDF link i frame @ S_i; ``Tx(a_i) Rx(alpha_i)`` for standard DH,
    the identity for modified DH (the URDF link frame IS DH frame i)."""
    if convention == "modified":
        return np.tile(np.eye(4), (len(links), 1, 1))
    return np.array([trans(l.a, 0, 0) @ rot_x(l.alpha) for l in links])


def dh_chain(links, convention: str, qlim, names, offsets=None):
    """``(joints, tool)``: the DH links as :class:`~manipdyn.model.links.ChainJoint` s and the fixed
    transform from the last URDF link to DH frame n (see :meth:`manipdyn.model.arm.Arm.chain`).

    Standard DH: joint i turns about z of frame i-1, so its URDF frame is
    ``T_{i-1} Rz(theta_i) Tz(d_i)``, and DH frame i is that frame (after
    the motion) times ``S_i = Tx(a_i) Rx(alpha_i)``; ``S_i`` moves into the
    next joint's origin, and ``S_n`` into the tool joint.  Modified DH:
    the URDF link frame IS DH frame i.  The fixed offsets theta and d go
    into the origins, so URDF joint positions are the DH joint variables q.
    ``qlim`` (n, 2), ``names`` the n link names, ``offsets`` the ``S_i`` (default :func:`dh_link_offsets`).
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
        body = l.body.transformed(S)  # frame-i data into the URDF link frame
        joints.append(ChainJoint(
            name=f"joint{i + 1}", joint=l.joint, origin=origin, axis=(0.0, 0.0, 1.0),
            body=body, qlim=tuple(qlim[i]), armature=l.armature,
            friction_viscous=l.friction_viscous, friction_coulomb=l.friction_coulomb,
            link_name=names[i],
        ))
        prev_S = S
    return tuple(joints), prev_S
