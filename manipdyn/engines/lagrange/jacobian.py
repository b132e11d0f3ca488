"""The tool frame's geometric Jacobian from the chapter's ``dT/dq`` (eq. 2.5 to 2.8).

Layer 3 (engines: lagrange), part of the trace-form engine (:mod:`manipdyn.engines.lagrange.engine`).
Shares no code with Pinocchio's ``computeFrameJacobian``; ``md.crosscheck``
holds the two to each other.

The tool pose is ``T = T_n X`` (``X`` fixed), so eq. 2.7 and the regrouped
derivative of CONVENTIONS.md give ``dT/dq_j = Delta_j T`` for every joint
``j``, with ``Delta_j`` the joint's motion generator in the base frame,
``[[w_j^, v_j], [0, 0]]``.  A point fixed in the tool frame (eq. 2.8, ``r = T p``)
moves with ``dr/dq_j = Delta_j r``; at the tool origin ``p = 0`` that is the
last column of ``Delta_j T``, and the frame turns with ``w_j``.  So column ``j``
of the Jacobian is

    J[:3, j] = (Delta_j T)[:3, 3]     (linear velocity of the tool origin, base axes)
    J[3:, j] = vee(Delta_j[:3, :3])   (angular velocity, base axes),

Pinocchio's ``LOCAL_WORLD_ALIGNED``.  Link ``k``'s Jacobian is the same with
``T_k`` for ``T`` and zero columns after ``k`` (link ``k`` moves with joints 1..k
only); ``frame="tool"`` gives the rows in the frame's own axes, ``R^T v`` and
``R^T w`` (``R`` the frame's rotation, eq. 2.2).  Its time derivative follows from
``dDelta_j/dt = [S_{j-1}, Delta_j]`` and ``dT/dt = S_n T`` with
``S_m = sum_{k <= m} Delta_k qd_k`` (the same identity as the engine's Coriolis
matrix): ``d(Delta_j T)/dt = ([S_{j-1}, Delta_j] + Delta_j S_n) T``; link ``k``'s, with
``T_k`` and ``S_k`` for ``T`` and ``S_n``.
"""

from __future__ import annotations

import numpy as np

from ...model.reach import check_jacobian_frame, check_link

__all__ = ["TraceFormJacobian"]


def _columns(X: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(B, 6, n): linear parts ``X[..., :3, 3]`` on top, ``vee(R[..., :3, :3])`` below."""
    lin = X[..., :3, 3]
    ang = np.stack((R[..., 2, 1], R[..., 0, 2], R[..., 1, 0]), axis=-1)
    return np.concatenate((lin, ang), axis=-1).swapaxes(1, 2)


class TraceFormJacobian:
    """Mixin of :class:`manipdyn.engines.lagrange.engine.TraceFormEngine`: ``jacobian``, ``jacobian_dot``."""

    def jacobian(self, q, frame: str = "world", link=None) -> np.ndarray:
        """Geometric Jacobian of the tool frame (``fkine``), or of link ``link``: (6, n) or (N, 6, n).

        Rows 0-2: the frame origin's linear velocity per joint rate (m/s per rad/s,
        or per m/s for a prismatic joint); rows 3-5: the frame's angular velocity
        (rad/s per joint rate, 0 for a prismatic joint); in base-frame axes
        (``frame="world"``, Pinocchio's ``LOCAL_WORLD_ALIGNED``) or the frame's own
        (``frame="tool"``, ``LOCAL``).  ``link`` is 1..n, the frame ``T_k`` of
        ``link_poses``.  From ``dT/dq_j = Delta_j T`` (module docstring).
        """
        local = check_jacobian_frame(frame) == "tool"
        k = None if link is None else check_link(link, self.n)
        return self._call(lambda qb: self._k_jacobian(qb, local, k), "jacobian", q=q)

    def jacobian_dot(self, q, qd, link=None) -> np.ndarray:
        """``dJ/dt`` along ``qd`` of :meth:`jacobian`: (6, n) or (N, 6, n), SI per second; of link
        ``link``'s frame ``T_k`` when ``link`` (1..n) is given.

        The frame's spatial acceleration (same point and axes) is ``J qdd + Jdot qd``.
        """
        k = None if link is None else check_link(link, self.n)
        return self._call(lambda qb, qdb: self._k_jacobian_dot(qb, qdb, k), "jacobian_dot", q=q, qd=qd)

    def _k_jacobian(self, q, local=False, link=None):
        T, Delta = self._kin.frames(q)
        Tt = self._kin.tool(T) if link is None else T[:, link - 1]     # (B, 4, 4)
        J = _columns(Delta @ Tt[:, None], Delta)
        if link is not None:
            J[:, :, link:] = 0.0                                      # dT_k/dq_j = 0 for j > k
        if local:
            Rt = np.swapaxes(Tt[:, :3, :3], 1, 2)
            J = np.concatenate((Rt @ J[:, :3], Rt @ J[:, 3:]), axis=1)
        return J

    def _k_jacobian_dot(self, q, qd, link=None):
        T, Delta = self._kin.frames(q)
        Tt = self._kin.tool(T) if link is None else T[:, link - 1]
        V = Delta * qd[:, :, None, None]                          # Delta_k qd_k
        S = np.cumsum(V, axis=1)                                  # S_m
        Sprev = S - V                                             # S_{j-1}
        Ddot = Sprev @ Delta - Delta @ Sprev                      # dDelta_j/dt
        m = S.shape[1] if link is None else link                  # dT_k/dt = S_k T_k
        X = (Ddot + Delta @ S[:, m - 1:m]) @ Tt[:, None]          # d(Delta_j T)/dt
        Jd = _columns(X, Ddot)
        if link is not None:
            Jd[:, :, link:] = 0.0                                 # columns after k stay zero
        return Jd
