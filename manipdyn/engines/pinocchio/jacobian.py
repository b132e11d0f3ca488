"""The tool frame's geometric Jacobian and its time derivative, by Pinocchio.

Layer 3 (engines: pinocchio), part of the Pinocchio engine (:mod:`manipdyn.engines.pinocchio.engine`):
``computeFrameJacobian`` and ``getFrameJacobianTimeVariation`` in
``LOCAL_WORLD_ALIGNED`` (linear velocity of the frame's origin on top, then
angular velocity, both in base-frame axes).  The trace form derives the same
matrices from ``dT/dq`` (:mod:`manipdyn.engines.lagrange.jacobian`); ``md.crosscheck``
compares them.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..._support.state import as_state, check_result, same_batch

__all__ = ["PinocchioJacobian"]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


class PinocchioJacobian:
    """Mixin of :class:`manipdyn.engines.pinocchio.engine.PinocchioEngine`: ``jacobian``, ``jacobian_dot``."""

    def _tool_id(self) -> int:
        return self.model.getFrameId(self.tool_frame)

    def jacobian(self, q) -> np.ndarray:
        """Geometric Jacobian of the tool frame (``fkine``): (6, n) or (N, 6, n).

        Linear velocity of the tool origin on top, angular velocity below, both in
        base-frame axes (``pin.LOCAL_WORLD_ALIGNED``); SI units.
        """
        q = as_state(q, "q", self.n)
        m, d, fid = self.model, self.data, self._tool_id()

        def one(qi):
            return pin.computeFrameJacobian(m, d, qi, fid, _LWA).copy()

        J = one(q) if q.ndim == 1 else np.array([one(qi) for qi in q]).reshape(len(q), 6, self.n)
        return check_result(J, "jacobian", q=q)

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
