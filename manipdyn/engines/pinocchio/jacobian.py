"""The geometric Jacobians of the tool and of every link, and the tool's time derivative, by Pinocchio.

Layer 3 (engines: pinocchio), part of the Pinocchio engine (:mod:`manipdyn.engines.pinocchio.engine`):
``computeFrameJacobian`` and ``getFrameJacobianTimeVariation`` in
``LOCAL_WORLD_ALIGNED`` (linear velocity of the frame's origin on top, then
angular velocity, both in base-frame axes), or ``LOCAL`` (the tool's own axes,
``frame="tool"``).  Link ``k``'s Jacobian is joint ``k``'s (``getJointJacobian``,
at the URDF link frame ``L_k``) moved to the frame ``link_poses`` gives,
``T_k = L_k S_k`` (``S_k`` from :meth:`manipdyn.Arm.urdf_link_offsets`): the same
angular rows, and ``v_p = v_o + w x (p - o)`` for its origin ``p``.  The trace form derives the same
matrices from ``dT/dq`` (:mod:`manipdyn.engines.lagrange.jacobian`); ``md.crosscheck``
compares them.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..._support.state import as_state, check_result, same_batch
from ...model.reach import check_jacobian_frame, check_link

__all__ = ["PinocchioJacobian"]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_LOCAL = pin.ReferenceFrame.LOCAL


def _skew(p):
    """(B, 3) -> (B, 3, 3) with ``skew(p) w = p x w``."""
    z = np.zeros(p.shape[0])
    return np.stack((z, -p[:, 2], p[:, 1], p[:, 2], z, -p[:, 0], -p[:, 1], p[:, 0], z), axis=1).reshape(-1, 3, 3)


class PinocchioJacobian:
    """Mixin of :class:`manipdyn.engines.pinocchio.engine.PinocchioEngine`: ``jacobian``, ``jacobian_dot``."""

    #: ``S_k`` (n, 4, 4) of the frames :meth:`jacobian` gives with ``link=`` (None: the URDF link frames)
    link_offsets = None

    def _tool_id(self) -> int:
        return self.model.getFrameId(self.tool_frame)

    def jacobian(self, q, frame: str = "world", link=None) -> np.ndarray:
        """Geometric Jacobian of the tool frame (``fkine``), or of link ``link``: (6, n) or (N, 6, n).

        Linear velocity of the frame's origin on top, angular velocity below, in base-frame
        axes (``frame="world"``, ``pin.LOCAL_WORLD_ALIGNED``) or the frame's own
        (``frame="tool"``, ``pin.LOCAL``); SI units.  ``link`` is 1..n: the frame
        ``T_k`` of :meth:`manipdyn.Arm.link_poses` (columns after k are zero), when the engine
        knows the arm's offsets ``S_k`` (``link_offsets``: set by ``arm.pinocchio`` and
        ``arm.engine("pinocchio")``).  An engine built by hand from a ``pin.Model`` has none and
        gives joint k's URDF link frame ``L_k``: the same frame for a modified-DH or URDF arm,
        not for a standard-DH one (``T_k = L_k S_k``, ``S_k = Trans_x(a_k) Rot_x(alpha_k)``);
        set ``engine.link_offsets = arm.urdf_link_offsets()`` there.
        """
        frame = check_jacobian_frame(frame)
        q = as_state(q, "q", self.n)
        if link is not None:
            return self._link_jacobian(q, frame, link)
        m, d, fid, ref = self.model, self.data, self._tool_id(), (_LWA if frame == "world" else _LOCAL)

        def one(qi):
            return pin.computeFrameJacobian(m, d, qi, fid, ref).copy()

        J = one(q) if q.ndim == 1 else np.array([one(qi) for qi in q]).reshape(len(q), 6, self.n)
        return check_result(J, "jacobian", q=q)

    def _link_jacobian(self, q, frame: str, link) -> np.ndarray:
        m, d, k = self.model, self.data, check_link(link, self.n)
        qb = q[None] if q.ndim == 1 else q
        J, T = np.empty((len(qb), 6, self.n)), np.empty((len(qb), 4, 4))
        for b, qi in enumerate(qb):
            pin.computeJointJacobians(m, d, qi)                    # also the joint placements oMi
            J[b] = pin.getJointJacobian(m, d, k, _LWA).reshape(6, self.n)
            T[b] = d.oMi[k].homogeneous
        if self.link_offsets is not None:                          # L_k -> T_k = L_k S_k
            S = self.link_offsets[k - 1]
            J[:, :3] -= _skew(T[:, :3, :3] @ S[:3, 3]) @ J[:, 3:]     # v_p = v_o + w x (p - o)
            T = T @ S
        if frame == "tool":                                        # rows in T_k's own axes: R^T v, R^T w
            Rt = np.swapaxes(T[:, :3, :3], 1, 2)
            J = np.concatenate((Rt @ J[:, :3], Rt @ J[:, 3:]), axis=1)
        return check_result(J[0] if q.ndim == 1 else J, "jacobian", q=q)

    def jacobian_dot(self, q, qd) -> np.ndarray:
        """``dJ/dt`` of :meth:`jacobian` along ``qd``: (6, n) or (N, 6, n)
        (``pin.getFrameJacobianTimeVariation``, ``LOCAL_WORLD_ALIGNED``)."""
        q = as_state(q, "q", self.n)
        qd = as_state(qd, "qd", self.n)
        same_batch((q, "q"), (qd, "qd"))
        m, d, fid = self.model, self.data, self._tool_id()

        def one(qi, vi):
            pin.computeJointJacobiansTimeVariation(m, d, qi, vi)
            pin.updateFramePlacements(m, d)
            return pin.getFrameJacobianTimeVariation(m, d, fid, _LWA).copy()

        if q.ndim == 1:
            return check_result(one(q, qd), "jacobian_dot", q=q, qd=qd)
        Jd = np.array([one(qi, vi) for qi, vi in zip(q, qd)]).reshape(len(q), 6, self.n)
        return check_result(Jd, "jacobian_dot", q=q, qd=qd)
