"""Kinematics of serial chains (chapter II, eq. 2.1 to 2.8).

Layer 1 (model): imports nothing of manipdyn but the errors.

Two descriptions of a serial chain are supported:

* Denavit-Hartenberg links, standard (distal, eq. 2.3/2.4) or modified (Craig);
* a generic chain of fixed transforms and joints about arbitrary axes, which
  is what a URDF describes.

Both produce, for a batch of joint states, the link frames ``T_i`` (base
frame, 4x4) and the joint motion generators ``Delta_j`` in the base frame,
which is all the trace-form dynamics needs: ``dT_p/dq_j = Delta_j T_p`` for
``j <= p`` (CONVENTIONS.md, "Computing the trace form fast").

All arrays are float64; lengths in metres, angles in radians.
"""

from __future__ import annotations

import math

import numpy as np


__all__ = [
    "dh_standard",
    "dh_modified",
    "transform_inverse",
    "rot_x", "rot_y", "rot_z", "trans",
    "rpy_to_matrix", "matrix_to_rpy",
    "DHKinematics", "ChainKinematics", "JOINT_TYPES",
]

JOINT_TYPES = ("revolute", "prismatic")


# ---------------------------------------------------------------------------
# Elementary homogeneous transforms
# ---------------------------------------------------------------------------
def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1.0]])


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def trans(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def rpy_to_matrix(rpy) -> np.ndarray:
    """URDF roll-pitch-yaw (fixed axes x, y, z) to a 3x3 rotation: Rz(y) Ry(p) Rx(r)."""
    r, p, y = (float(v) for v in rpy)
    return (rot_z(y) @ rot_y(p) @ rot_x(r))[:3, :3]


def matrix_to_rpy(R: np.ndarray) -> tuple[float, float, float]:
    """Inverse of :func:`rpy_to_matrix` (pitch in [-pi/2, pi/2]); exact round trip
    to rounding, including the gimbal-lock case.

    Pitch is ``atan2(-R20, hypot(R00, R10))`` (an ``asin`` of ``-R20`` loses half the digits
    near +-pi/2: 1e-7 at 1e-7 rad from the lock), yaw ``atan2(R10, R00)``, and roll from
    ``Rz(yaw)^T R = Ry(pitch) Rx(roll)``, whose rows 1 are ``[0, cos roll, -sin roll]`` whatever
    the pitch: so roll takes up what yaw leaves, and at the lock (``hypot(R00, R10)`` lost
    in rounding) yaw is 0 and roll is all of ``roll -/+ yaw``, the one angle defined there."""
    R = np.asarray(R, dtype=np.float64)
    cp = math.hypot(R[0, 0], R[1, 0])
    pitch = math.atan2(-R[2, 0], cp)
    yaw = math.atan2(R[1, 0], R[0, 0]) if cp > _GIMBAL_LOCK else 0.0
    cy, sy = math.cos(yaw), math.sin(yaw)
    roll = math.atan2(sy * R[0, 2] - cy * R[1, 2], cy * R[1, 1] - sy * R[0, 1])
    return roll, pitch, yaw


#: ``cos(pitch)`` below which :func:`matrix_to_rpy` calls it gimbal lock (four float64 roundings of 1)
_GIMBAL_LOCK = 1e-15


def transform_inverse(T: np.ndarray) -> np.ndarray:
    """Inverse of homogeneous transforms, eq. 2.2: ``[[R^T, -R^T p], [0, 1]]``.

    ``T`` has shape ``(..., 4, 4)``; no general matrix inverse is used.
    """
    T = np.asarray(T, dtype=np.float64)
    out = np.zeros_like(T)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def dh_standard(theta, d, a, alpha) -> np.ndarray:
    """Standard DH link transform, eq. 2.3: ``Rz(theta) Tz(d) Tx(a) Rx(alpha)``.

    Arguments broadcast; the result has shape ``broadcast_shape + (4, 4)``.
    Eq. 2.4 (prismatic, ``a = 0``) is the same matrix.
    """
    theta, d, a, alpha = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in (theta, d, a, alpha)))
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    A = np.zeros(theta.shape + (4, 4))
    A[..., 0, 0] = ct
    A[..., 0, 1] = -st * ca
    A[..., 0, 2] = st * sa
    A[..., 0, 3] = a * ct
    A[..., 1, 0] = st
    A[..., 1, 1] = ct * ca
    A[..., 1, 2] = -ct * sa
    A[..., 1, 3] = a * st
    A[..., 2, 1] = sa
    A[..., 2, 2] = ca
    A[..., 2, 3] = d
    A[..., 3, 3] = 1.0
    return A


def dh_modified(theta, d, a_prev, alpha_prev) -> np.ndarray:
    """Modified (Craig) DH link transform: ``Rx(alpha_{n-1}) Tx(a_{n-1}) Rz(theta_n) Tz(d_n)``."""
    theta, d, a, alpha = np.broadcast_arrays(
        *(np.asarray(x, dtype=np.float64) for x in (theta, d, a_prev, alpha_prev))
    )
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    A = np.zeros(theta.shape + (4, 4))
    A[..., 0, 0] = ct
    A[..., 0, 1] = -st
    A[..., 0, 3] = a
    A[..., 1, 0] = st * ca
    A[..., 1, 1] = ct * ca
    A[..., 1, 2] = -sa
    A[..., 1, 3] = -sa * d
    A[..., 2, 0] = st * sa
    A[..., 2, 1] = ct * sa
    A[..., 2, 2] = ca
    A[..., 2, 3] = ca * d
    A[..., 3, 3] = 1.0
    return A


# ---------------------------------------------------------------------------
# Batched kinematics providers used by the trace-form engine
# ---------------------------------------------------------------------------
def _cumulative(A: np.ndarray) -> np.ndarray:
    """``T_i = A_1 ... A_i`` (eq. 2.7) for A of shape (B, n, 4, 4)."""
    T = np.empty_like(A)
    prev = A[:, 0]
    T[:, 0] = prev
    for i in range(1, A.shape[1]):  # sequential by nature: one matmul per joint, batched
        prev = prev @ A[:, i]
        T[:, i] = prev
    return T


# Linear map from a rotation axis w to the flattened 4x4 [[w^, 0], [0, 0]]:
# skew(w).reshape(16) = w @ _SKEW_4X4.
_SKEW_4X4 = np.zeros((3, 16))
for _r, _c, _k, _sgn in ((0, 1, 2, -1), (0, 2, 1, 1), (1, 0, 2, 1), (1, 2, 0, -1), (2, 0, 1, -1), (2, 1, 0, 1)):
    _SKEW_4X4[_k, 4 * _r + _c] = _sgn


def _generators(G: np.ndarray, w: np.ndarray, revolute: np.ndarray) -> np.ndarray:
    """Motion generators in the base frame, ``Delta_j = G_j Q_j G_j^{-1}``.

    ``G`` (B, n, 4, 4) is joint j's frame (before or after its own motion:
    the two give the same Delta) and ``w`` (B, n, 3) the joint axis in base
    coordinates, ``w = R_j axis_j``.  For a revolute joint Delta is
    ``[[w^, -w^ p], [0, 0]]`` (p the origin of G_j); for a prismatic joint
    ``[[0, w], [0, 0]]``.  Same matrix as ``G Q G^{-1}``, built without
    inverting G.
    """
    B, n = G.shape[:2]
    rev = revolute[:, None]
    Delta = (np.where(rev, w, 0.0) @ _SKEW_4X4).reshape(B, n, 4, 4)
    Delta[..., :3, 3] = np.where(rev, -(Delta[..., :3, :3] @ G[..., :3, 3:])[..., 0], w)
    return Delta


def _dh_coefficients(a, alpha, convention: str) -> np.ndarray:
    """Constant matrices K (n, 4, 16) with ``A_n = [cos th, sin th, d, 1] @ K_n``.

    Eq. 2.3 (standard) and Craig's modified transform are linear in
    ``cos(theta_n)``, ``sin(theta_n)`` and ``d_n`` once a and alpha are fixed;
    this writes each A matrix as that linear combination, element by element
    as the equations print them, so all links of a batch are one matmul.
    """
    n = len(a)
    K = np.zeros((n, 4, 4, 4))  # [link, coefficient (c, s, d, 1), row, col]
    ca, sa = np.cos(alpha), np.sin(alpha)
    C, S, Dd, One = 0, 1, 2, 3
    if convention == "standard":
        # [[c, -s ca, s sa, a c], [s, c ca, -c sa, a s], [0, sa, ca, d], [0, 0, 0, 1]]
        K[:, C, 0, 0] = 1.0
        K[:, S, 0, 1] = -ca
        K[:, S, 0, 2] = sa
        K[:, C, 0, 3] = a
        K[:, S, 1, 0] = 1.0
        K[:, C, 1, 1] = ca
        K[:, C, 1, 2] = -sa
        K[:, S, 1, 3] = a
        K[:, One, 2, 1] = sa
        K[:, One, 2, 2] = ca
        K[:, Dd, 2, 3] = 1.0
    else:
        # [[c, -s, 0, a], [s ca, c ca, -sa, -sa d], [s sa, c sa, ca, ca d], [0, 0, 0, 1]]
        K[:, C, 0, 0] = 1.0
        K[:, S, 0, 1] = -1.0
        K[:, One, 0, 3] = a
        K[:, S, 1, 0] = ca
        K[:, C, 1, 1] = ca
        K[:, One, 1, 2] = -sa
        K[:, Dd, 1, 3] = -sa
        K[:, S, 2, 0] = sa
        K[:, C, 2, 1] = sa
        K[:, One, 2, 2] = ca
        K[:, Dd, 2, 3] = ca
    K[:, One, 3, 3] = 1.0
    return K.reshape(n, 4, 16)


class DHKinematics:
    """Link frames and generators of a DH chain, computed from the A matrices."""

    def __init__(self, links, convention: str, base=None, tool=None):
        self.n = len(links)
        self.convention = convention
        #: the base frame in the world (T_i = base A_1 .. A_i) and the tool in DH frame n; None: identity
        self._base = None if base is None or np.array_equal(base, np.eye(4)) else np.asarray(base, dtype=np.float64)
        self._tool = None if tool is None or np.array_equal(tool, np.eye(4)) else np.asarray(tool, dtype=np.float64)
        self.revolute = np.array([l.joint == "revolute" for l in links])
        self.a = np.array([l.a for l in links])
        self.alpha = np.array([l.alpha for l in links])
        self.d = np.array([l.d for l in links])
        self.theta = np.array([l.theta for l in links])
        self._K = _dh_coefficients(self.a, self.alpha, convention)
        self._eye = np.eye(4)

    def A(self, q: np.ndarray) -> np.ndarray:
        """All link transforms A_1..A_n (eq. 2.3 or Craig's), (B, n, 4, 4), for q (B, n)."""
        B, n = q.shape
        th = np.where(self.revolute, q + self.theta, self.theta)
        coef = np.empty((B, n, 1, 4))
        coef[..., 0, 0] = np.cos(th)
        coef[..., 0, 1] = np.sin(th)
        coef[..., 0, 2] = np.where(self.revolute, self.d, q + self.d)
        coef[..., 0, 3] = 1.0
        return (coef @ self._K).reshape(B, n, 4, 4)

    def poses(self, q: np.ndarray) -> np.ndarray:
        """``T_1 .. T_n`` (eq. 2.7), (B, n, 4, 4), in the world: the base transform first."""
        T = _cumulative(self.A(q))
        return T if self._base is None else self._base @ T

    def tool(self, T: np.ndarray) -> np.ndarray:
        return T[:, -1] if self._tool is None else T[:, -1] @ self._tool

    def frames(self, q: np.ndarray):
        """Return ``(T, Delta)``: link frames and base-frame generators, (B, n, 4, 4) each."""
        T = self.poses(q)
        if self.convention == "standard":
            # joint j moves about z of frame j-1: Delta_j = T_{j-1} Q T_{j-1}^{-1}
            G = np.empty_like(T)
            G[:, 0] = self._eye if self._base is None else self._base
            G[:, 1:] = T[:, :-1]
        else:
            # modified DH: joint j moves about z of frame j itself
            G = T
        return T, _generators(G, G[..., :3, 2], self.revolute)


def _axis_motion(axis: np.ndarray, revolute: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Joint motions M_j(q_j), (B, n, 4, 4): Rodrigues rotations or translations."""
    B, n = q.shape
    M = np.zeros((B, n, 4, 4))
    M[..., 3, 3] = 1.0
    qr = np.where(revolute, q, 0.0)
    c, s = np.cos(qr), np.sin(qr)
    x, y, z = axis[:, 0], axis[:, 1], axis[:, 2]
    C = 1.0 - c
    M[..., 0, 0] = c + x * x * C
    M[..., 0, 1] = x * y * C - z * s
    M[..., 0, 2] = x * z * C + y * s
    M[..., 1, 0] = y * x * C + z * s
    M[..., 1, 1] = c + y * y * C
    M[..., 1, 2] = y * z * C - x * s
    M[..., 2, 0] = z * x * C - y * s
    M[..., 2, 1] = z * y * C + x * s
    M[..., 2, 2] = c + z * z * C
    qp = np.where(revolute, 0.0, q)
    M[..., :3, 3] = qp[..., None] * axis
    return M


class ChainKinematics:
    """Link frames and generators of a generic chain of fixed transforms and joints."""

    def __init__(self, joints, tool: np.ndarray):
        self.n = len(joints)
        self.revolute = np.array([j.joint == "revolute" for j in joints])
        self.axis = np.array([j.axis for j in joints])
        self.origins = np.array([j.origin for j in joints])
        self.tool_T = np.asarray(tool, dtype=np.float64)

    def poses(self, q: np.ndarray) -> np.ndarray:
        A = self.origins[None] @ _axis_motion(self.axis, self.revolute, q)
        return _cumulative(A)

    def tool(self, T: np.ndarray) -> np.ndarray:
        return T[:, -1] @ self.tool_T

    def frames(self, q: np.ndarray):
        T = self.poses(q)
        w = (T[..., :3, :3] @ self.axis[:, :, None])[..., 0]
        return T, _generators(T, w, self.revolute)
