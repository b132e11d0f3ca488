"""The canonical form of a serial chain, and the normal form of one link.

Layer 4 (checks: compare) (compare).

Step 1 of :func:`manipdyn.check.compare.compare`: every arm is brought to one form,

    T(q) = W_0 J(q_1) W_1 J(q_2) ... J(q_n) W_n,

with ``J(q) = Rz(q)`` (revolute) or ``Tz(q)`` (prismatic): every joint frame
gets its z axis on the joint axis.  A prismatic joint has a direction but no
line; its line is put, in both arms alike, through the neighbouring revolute
axes (:func:`place_prismatic_lines`).

Step 3: each link transform ``W`` (z-line to z-line) is split as
``Rz(theta) Tz(d) Tx(a) Rx(alpha) Rz(psi) Tz(e)`` (:func:`split_link`, a
DH-like normal form, unique for skew axes).

Lengths in metres, angles in radians; transforms are 4x4 homogeneous.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...model.kinematics import dh_standard, rot_z, trans, transform_inverse

__all__ = ["Chain", "LinkSplit", "canonical_chain", "place_prismatic_lines", "split_link",
           "joint_motion", "flip", "wrap_angle", "z_frame", "PARALLEL_SIN", "COINCIDENT_LEN"]

_EZ = np.array([0.0, 0.0, 1.0])
#: axes closer than this angle (rad) are treated as parallel: descriptions round
#: pi/2 to 1.5708 or 1.571, which tilts "parallel" axes by up to ~2e-4 rad, and
#: the common normal of nearly parallel axes is meaningless
PARALLEL_SIN = 1e-3
#: parallel axes closer than this (relative to the arm's size) are coincident
COINCIDENT_LEN = 1e-6
_FLIP = np.diag([1.0, -1.0, -1.0, 1.0])  # Rx(pi)


def joint_motion(revolute: bool, q: float) -> np.ndarray:
    """``Rz(q)`` (revolute, q in rad) or ``Tz(q)`` (prismatic, q in m), 4x4."""
    return rot_z(q) if revolute else trans(0.0, 0.0, q)


def flip(sign: int) -> np.ndarray:
    """``Rx(pi)`` for sign -1, identity for +1: ``J(-q) = F J(q) F``."""
    return _FLIP if sign < 0 else np.eye(4)


def wrap_angle(a: float) -> float:
    """Angle in (-pi, pi]."""
    a = math.remainder(a, 2.0 * math.pi)
    return math.pi if a == -math.pi else a


def z_frame(axis) -> np.ndarray:
    """A rotation (4x4) whose z axis is the unit ``axis`` (deterministic choice)."""
    u = np.asarray(axis, dtype=np.float64)
    u = u / np.linalg.norm(u)
    h = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(h, u)
    x /= np.linalg.norm(x)
    y = np.cross(u, x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, y, u])
    return T


@dataclass
class Chain:
    """``T(q) = W[0] J(q_1) W[1] ... J(q_n) W[n]``: n+1 transforms and n joint kinds."""

    W: list            # n+1 transforms (4, 4)
    revolute: list     # n bools

    def fk(self, q) -> np.ndarray:
        """Tool pose (4, 4) in the base frame for one joint vector q (n,)."""
        T = self.W[0]
        for i, r in enumerate(self.revolute):
            T = T @ joint_motion(r, q[i]) @ self.W[i + 1]
        return T

    def frame_at_zero(self, k: int) -> np.ndarray:
        """Joint k's frame (0-based) at q = 0, in the base frame (4, 4)."""
        T = self.W[0]
        for i in range(k):
            T = T @ self.W[i + 1]
        return T

    def lines(self) -> list:
        """Joint lines at q = 0 in the base frame: [(point (3,), direction (3,))]."""
        out, T = [], self.W[0]
        for i in range(len(self.revolute)):
            out.append((T[:3, 3].copy(), T[:3, 2].copy()))
            T = T @ self.W[i + 1]
        return out


def canonical_chain(arm) -> Chain:
    """The z-axis form of ``arm`` (any :class:`manipdyn.model.arm.Arm`), prismatic lines placed."""
    joints, tool = arm.chain()
    n = len(joints)
    Q = [z_frame(j.axis) for j in joints]
    W = [np.asarray(joints[0].origin, dtype=np.float64) @ Q[0]]
    for k in range(n - 1):
        W.append(transform_inverse(Q[k]) @ np.asarray(joints[k + 1].origin, dtype=np.float64) @ Q[k + 1])
    W.append(transform_inverse(Q[n - 1]) @ np.asarray(tool, dtype=np.float64))
    ch = Chain(W=W, revolute=[j.joint == "revolute" for j in joints])
    place_prismatic_lines(ch)
    return ch


def _neighbour_lines(ch: Chain, k: int) -> list:
    """Revolute neighbours' lines (next joint first) in joint k's frame at q = 0."""
    Tk_inv = transform_inverse(ch.frame_at_zero(k))
    lines = ch.lines()
    out = []
    for j in (k + 1, k - 1):
        if 0 <= j < len(ch.revolute) and ch.revolute[j]:
            p, d = lines[j]
            out.append(((Tk_inv @ np.append(p, 1.0))[:3], Tk_inv[:3, :3] @ d))
    return out


def _line_point(neighbours: list, eps: float):
    """Where a prismatic joint's line crosses its xy plane, from its neighbours; None if undefined."""
    for p, d in neighbours:
        if math.hypot(d[0], d[1]) < eps:      # a parallel neighbour: share its line
            return p[:2]
    if len(neighbours) == 2:                  # else the crossing of the two projections
        (p1, d1), (p2, d2) = neighbours
        A = np.column_stack([d1[:2], -d2[:2]])
        if abs(np.linalg.det(A)) > eps:
            s = np.linalg.solve(A, p2[:2] - p1[:2])
            return p1[:2] + s[0] * d1[:2]
    return None


def place_prismatic_lines(ch: Chain, eps: float = 1e-9) -> None:
    """Give every prismatic joint a line defined by the arm's geometry alone (in place).

    A prismatic joint moves along a direction; where its 'axis line' sits is
    a free choice of each description.  Put it, in the joint frame's xy plane,
    on a neighbouring revolute axis parallel to it (next joint first), else at
    the crossing of the projections of the previous and next revolute axes on
    the plane normal to the motion.  Without such neighbours it stays where
    the description put it (and a remaining mismatch shows in the report).
    """
    for k, revolute in enumerate(ch.revolute):
        if revolute:
            continue
        shift = _line_point(_neighbour_lines(ch, k), eps)
        if shift is None:
            continue
        S = trans(shift[0], shift[1], 0.0)
        ch.W[k] = ch.W[k] @ S
        ch.W[k + 1] = transform_inverse(S) @ ch.W[k + 1]


@dataclass
class LinkSplit:
    """``G = Rz(theta) Tz(d) Tx(a) Rx(alpha) Rz(psi) Tz(e)``; kind skew | parallel | coincident."""

    kind: str
    theta: float
    d: float
    a: float
    alpha: float
    psi: float
    e: float

    @property
    def c(self) -> float:
        return math.cos(self.alpha)


def _common_normal(G: np.ndarray, s_ang: float):
    """theta, d, a of the common normal of z and G's z axis (skew lines)."""
    z2, p = G[:3, 2], G[:3, 3]
    nvec = np.cross(_EZ, z2) / s_ang
    theta = math.atan2(nvec[1], nvec[0])
    # feet of the common normal: (0, 0, d) on the z axis, p + t z2 on the other line
    b = float(z2[2])
    dd, ee = -p[2], float(z2 @ -p)
    den = 1.0 - b * b
    d = (b * ee - dd) / den
    t = (ee - b * dd) / den
    a = float((p + t * z2 - np.array([0.0, 0.0, d])) @ nvec)
    return theta, d, a


def split_link(G: np.ndarray, len_scale: float) -> LinkSplit:
    """``G = Rz(theta) Tz(d) Tx(a) Rx(alpha) Rz(psi) Tz(e)`` for a transform between z-lines.

    Skew axes: the common normal makes the form unique.  Parallel axes (within
    ``PARALLEL_SIN``; then the form holds to that angle only): theta
    is the direction of the offset between them, d = 0 by convention (only
    d + cos(alpha) e is defined).  Coincident axes: theta = 0, a = 0, d = 0.
    ``len_scale`` (m) is the arm's size, for the coincidence test.
    """
    z2, p = G[:3, 2], G[:3, 3]
    s_ang = float(np.linalg.norm(np.cross(_EZ, z2)))
    cz = float(z2[2])
    if s_ang > PARALLEL_SIN:
        theta, d, a = _common_normal(G, s_ang)
        alpha, kind = math.atan2(s_ang, cz), "skew"
    else:
        alpha = 0.0 if cz > 0 else math.pi
        rxy = math.hypot(p[0], p[1])
        d = 0.0
        if rxy > COINCIDENT_LEN * len_scale:
            theta, a, kind = math.atan2(p[1], p[0]), rxy, "parallel"
        else:
            theta, a, kind = 0.0, 0.0, "coincident"
    N = dh_standard(theta, d, a, alpha)               # Rz(theta) Tz(d) Tx(a) Rx(alpha), eq. 2.3
    Rm = transform_inverse(N) @ G
    psi = math.atan2(Rm[1, 0], Rm[0, 0])
    return LinkSplit(kind, theta, d, a, alpha, psi, float(Rm[2, 3]))
