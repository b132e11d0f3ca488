"""The geometric Jacobians of the tool and of every link, and the tool's time derivative, by Pinocchio.

Layer 3 (engines: pinocchio), part of the Pinocchio engine (:mod:`manipdyn.engines.pinocchio.engine`):
``computeFrameJacobian`` and ``getFrameJacobianTimeVariation`` in
``LOCAL_WORLD_ALIGNED`` (linear velocity of the frame's origin on top, then
angular velocity, both in base-frame axes), or ``LOCAL`` (the tool's own axes,
``frame="tool"``).  Link ``k``'s Jacobian and its rate are those of a Pinocchio frame at
``T_k = L_k S_k`` on joint ``k`` (``L_k`` the URDF link frame, ``S_k`` from
:meth:`manipdyn.Arm.urdf_link_offsets`), added to a copy of the model once per set of offsets.
The trace form derives the same matrices from ``dT/dq``
(:mod:`manipdyn.engines.lagrange.jacobian`); ``md.crosscheck`` compares them.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..._support.state import as_state, check_result, same_batch
from ...model.reach import check_jacobian_frame, check_link

__all__ = ["PinocchioJacobian"]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_LOCAL = pin.ReferenceFrame.LOCAL


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

    def _link_frames(self):
        """``(model, data, ids)``: a copy of the model with a frame at ``T_k`` on joint k for every link
        (``ids[k - 1]``), built once per ``link_offsets`` (module docstring)."""
        S = self.link_offsets
        key = None if S is None else np.asarray(S, dtype=np.float64).tobytes()
        cached = getattr(self, "_link_frames_cache", None)
        if cached is not None and cached[0] == key:
            return cached[1:]
        m = pin.Model(self.model)
        ids = []
        for k in range(1, self.n + 1):
            place = pin.SE3.Identity() if S is None else pin.SE3(np.array(S[k - 1][:3, :3]), np.array(S[k - 1][:3, 3]))
            ids.append(m.addFrame(pin.Frame(f"manipdyn_link_{k}", k, place, pin.FrameType.OP_FRAME)))
        self._link_frames_cache = (key, m, m.createData(), ids)
        return self._link_frames_cache[1:]

    def _link_jacobian(self, q, frame: str, link) -> np.ndarray:
        k = check_link(link, self.n)
        m, d, ids = self._link_frames()
        ref = _LWA if frame == "world" else _LOCAL
        qb = q[None] if q.ndim == 1 else q
        J = np.array([pin.computeFrameJacobian(m, d, qi, ids[k - 1], ref) for qi in qb]).reshape(len(qb), 6, self.n)
        return check_result(J[0] if q.ndim == 1 else J, "jacobian", q=q)

    def jacobian_dot(self, q, qd, link=None) -> np.ndarray:
        """``dJ/dt`` of :meth:`jacobian` along ``qd``: (6, n) or (N, 6, n)
        (``pin.getFrameJacobianTimeVariation``, ``LOCAL_WORLD_ALIGNED``); of link ``link``'s frame
        ``T_k`` when ``link`` (1..n) is given, as :meth:`jacobian`."""
        q = as_state(q, "q", self.n)
        qd = as_state(qd, "qd", self.n)
        same_batch((q, "q"), (qd, "qd"))
        if link is None:
            m, d, fid = self.model, self.data, self._tool_id()
        else:
            m, d, ids = self._link_frames()
            fid = ids[check_link(link, self.n) - 1]

        def one(qi, vi):
            pin.computeJointJacobiansTimeVariation(m, d, qi, vi)
            pin.updateFramePlacements(m, d)
            return pin.getFrameJacobianTimeVariation(m, d, fid, _LWA).copy()

        if q.ndim == 1:
            return check_result(one(q, qd), "jacobian_dot", q=q, qd=qd)
        Jd = np.array([one(qi, vi) for qi, vi in zip(q, qd)]).reshape(len(q), 6, self.n)
        return check_result(Jd, "jacobian_dot", q=q, qd=qd)
