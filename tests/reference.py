"""Plain-loop transcription of chapter II (eq. 2.1 to 2.39): the executable reference.

Written to be read beside the chapter, not to be fast.  It shares no code with
``manipdyn``'s engine: the only things it takes from ``manipdyn`` are the
fields of the ``DHLink`` objects it is given (joint, a, alpha, d, theta, mass,
com, inertia, motor_inertia, gear_ratio), read as plain numbers.

Indices are 1-based, as in the chapter: ``T[0]`` is the base frame (identity),
``T[i]`` is link i's frame, and the loops run ``for i in range(1, n + 1)``.

Equation numbers are the chapter's; CONVENTIONS.md fixes what it leaves loose
(the modified-DH A matrix, the derivatives of the link poses through the
Q matrices, the product-of-inertia sign of eq. 2.21).
"""

from __future__ import annotations

import math

import numpy as np

# ---------------------------------------------------------------------------
# Kinematics (section 2.2)
# ---------------------------------------------------------------------------


def A_standard(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    """Eq. 2.3: standard (distal) DH link transform, element by element.

    ``A_n = Rot_z(theta_n) Trans_z(d_n) Trans_x(a_n) Rot_x(alpha_n)``.  Eq. 2.4
    (prismatic) is the same matrix with ``a_n = 0``; CONVENTIONS.md says to use
    eq. 2.3's translation for any ``a_n``.
    """
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(alpha), math.sin(alpha)
    return np.array([
        [ct, -st * ca,  st * sa, a * ct],
        [st,  ct * ca, -ct * sa, a * st],
        [0.0,      sa,       ca,      d],
        [0.0,     0.0,      0.0,    1.0],
    ])


def A_modified(theta: float, d: float, a_prev: float, alpha_prev: float) -> np.ndarray:
    """Modified (Craig) DH link transform, element by element.

    ``A_n = Rot_x(alpha_{n-1}) Trans_x(a_{n-1}) Rot_z(theta_n) Trans_z(d_n)``
    (J. J. Craig, "Introduction to Robotics", 3rd ed., eq. 3.6).
    """
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(alpha_prev), math.sin(alpha_prev)
    return np.array([
        [ct,       -st,      0.0,  a_prev],
        [st * ca,  ct * ca,  -sa, -sa * d],
        [st * sa,  ct * sa,   ca,  ca * d],
        [0.0,      0.0,      0.0,     1.0],
    ])


def A_matrix(link, q: float, convention: str) -> np.ndarray:
    """A_n(q_n) of one link: revolute ``theta_n = q_n + theta``, prismatic ``d_n = q_n + d``."""
    if link.joint == "revolute":
        theta, d = q + link.theta, link.d
    else:
        theta, d = link.theta, q + link.d
    if convention == "standard":
        return A_standard(theta, d, link.a, link.alpha)
    return A_modified(theta, d, link.a, link.alpha)


def transform_inverse(T: np.ndarray) -> np.ndarray:
    """Eq. 2.2: the inverse of eq. 2.1 from its columns n, o, a, p."""
    n, o, a, p = T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3]
    return np.array([
        [n[0], n[1], n[2], -(p @ n)],
        [o[0], o[1], o[2], -(p @ o)],
        [a[0], a[1], a[2], -(p @ a)],
        [0.0,  0.0,  0.0,  1.0],
    ])


def link_poses(links, convention: str, q) -> list[np.ndarray]:
    """Eq. 2.5 to 2.7: ``T_i = A_1 A_2 ... A_i``; returns ``[T_0 = I, T_1, ..., T_n]``."""
    n = len(links)
    T = [np.eye(4)]
    for i in range(1, n + 1):
        T.append(T[i - 1] @ A_matrix(links[i - 1], float(q[i - 1]), convention))
    return T


def Q_matrix(joint: str) -> np.ndarray:
    """Generator of a joint's motion about/along its z axis (CONVENTIONS.md).

    Revolute about z: ``Q[0,1] = -1, Q[1,0] = 1``; prismatic along z: ``Q[2,3] = 1``.
    """
    Q = np.zeros((4, 4))
    if joint == "revolute":
        Q[0, 1] = -1.0
        Q[1, 0] = 1.0
    else:
        Q[2, 3] = 1.0
    return Q


class Chain:
    """Link poses of one state and their first and second derivatives.

    ``dT(p, j)`` is ``dT_p/dq_j`` and ``d2T(p, j, k)`` is ``d2T_p/(dq_j dq_k)``,
    by CONVENTIONS.md "Derivatives of the link poses":

    * standard DH: joint j moves about z of frame j-1, so
      ``dT_p/dq_j = T_{j-1} Q_j T_{j-1}^{-1} T_p`` for ``j <= p``;
    * modified DH: joint j moves about z of frame j (after its motion), so
      ``dT_p/dq_j = T_j Q_j T_j^{-1} T_p`` for ``j <= p``;
    * ``dT_p/dq_j = 0`` for ``j > p`` (the remark after eq. 2.31);
    * the second derivative nests the same way: for ``j <= k <= p``
      ``d2T_p/dq_j dq_k = [T_. Q_j T_.^{-1}] [T_. Q_k T_.^{-1}] T_p``.
    """

    def __init__(self, links, convention: str, q):
        self.links = list(links)
        self.n = len(self.links)
        self.convention = convention
        self.T = link_poses(self.links, convention, q)

    def joint_frame(self, j: int) -> np.ndarray:
        """The frame whose z axis joint j moves about/along."""
        return self.T[j - 1] if self.convention == "standard" else self.T[j]

    def generator(self, j: int) -> np.ndarray:
        """``T_. Q_j T_.^{-1}``: joint j's motion seen in the base frame."""
        F = self.joint_frame(j)
        return F @ Q_matrix(self.links[j - 1].joint) @ transform_inverse(F)

    def dT(self, p: int, j: int) -> np.ndarray:
        """``dT_p / dq_j``."""
        if j > p:
            return np.zeros((4, 4))
        return self.generator(j) @ self.T[p]

    def d2T(self, p: int, j: int, k: int) -> np.ndarray:
        """``d2T_p / (dq_j dq_k)``, symmetric in (j, k)."""
        if j > k:
            j, k = k, j
        if k > p:
            return np.zeros((4, 4))
        return self.generator(j) @ self.generator(k) @ self.T[p]


# ---------------------------------------------------------------------------
# Link inertia (eq. 2.20, 2.21)
# ---------------------------------------------------------------------------


def pseudo_inertia(link) -> np.ndarray:
    """Eq. 2.21 written out, from the link's mass, COM and tensor about the COM.

    The chapter's terms are moments about the ORIGIN of frame i (eq. 2.20
    integrates ``r r^T`` with ``r`` measured from that origin):

    * the tensor about the origin by the parallel-axis theorem,
      ``I_O = I_C + m (|c|^2 E - c c^T)`` (tensor sign);
    * ``I_xx = integral (y^2 + z^2) dm = I_O[0, 0]`` (and y, z likewise);
    * the chapter's product ``I_xy = +integral x y dm = -I_O[0, 1]``
      (the tensor's off-diagonal element has the opposite sign).
    """
    m = float(link.mass)
    c = np.asarray(link.com, dtype=float)
    I_C = np.asarray(link.inertia, dtype=float)
    I_O = I_C + m * ((c @ c) * np.eye(3) - np.outer(c, c))
    Ixx, Iyy, Izz = I_O[0, 0], I_O[1, 1], I_O[2, 2]
    Ixy, Ixz, Iyz = -I_O[0, 1], -I_O[0, 2], -I_O[1, 2]
    mx, my, mz = m * c[0], m * c[1], m * c[2]
    return np.array([
        [(-Ixx + Iyy + Izz) / 2, Ixy, Ixz, mx],
        [Ixy, (Ixx - Iyy + Izz) / 2, Iyz, my],
        [Ixz, Iyz, (Ixx + Iyy - Izz) / 2, mz],
        [mx, my, mz, m],
    ])


def armature(link) -> float:
    """Reflected rotor inertia ``G^2 J_m`` (CONVENTIONS.md, Pinocchio's armature).

    The chapter leaves the actuators' kinetic energy out of eq. 2.22 but says it
    "could be easily included": ``K_rotor = 1/2 G^2 J_m qd^2`` per joint, which
    adds ``G^2 J_m`` to ``D_ii``.
    """
    return float(link.gear_ratio) ** 2 * float(link.motor_inertia)


# ---------------------------------------------------------------------------
# Dynamics (eq. 2.22 to 2.39), one state q (n,), qd (n,), qdd (n,)
# ---------------------------------------------------------------------------


def _homogeneous_gravity(gravity) -> np.ndarray:
    """``g = [g_x, g_y, g_z, 0]`` in the base frame (eq. 2.23)."""
    gx, gy, gz = (float(v) for v in gravity)
    return np.array([gx, gy, gz, 0.0])


def mass_matrix(links, convention, q) -> np.ndarray:
    """``D_ij = sum_{p=max(i,j)}^{n} tr(dT_p/dq_j J_p dT_p/dq_i^T)`` (eq. 2.39), plus rotors."""
    ch = Chain(links, convention, q)
    n = ch.n
    J = [None] + [pseudo_inertia(l) for l in links]
    D = np.zeros((n, n))
    for i in range(1, n + 1):
        for j in range(1, n + 1):
            s = 0.0
            for p in range(max(i, j), n + 1):
                s += np.trace(ch.dT(p, j) @ J[p] @ ch.dT(p, i).T)
            D[i - 1, j - 1] = s
    for i in range(1, n + 1):
        D[i - 1, i - 1] += armature(links[i - 1])
    return D


def coriolis_tensor(links, convention, q) -> np.ndarray:
    """``D_ijk = sum_{p=max(i,j,k)}^{n} tr(d2T_p/(dq_j dq_k) J_p dT_p/dq_i^T)`` (eq. 2.39).

    Returned as an array ``Dijk[i-1, j-1, k-1]``.
    """
    ch = Chain(links, convention, q)
    n = ch.n
    J = [None] + [pseudo_inertia(l) for l in links]
    Dijk = np.zeros((n, n, n))
    for i in range(1, n + 1):
        for j in range(1, n + 1):
            for k in range(1, n + 1):
                s = 0.0
                for p in range(max(i, j, k), n + 1):
                    s += np.trace(ch.d2T(p, j, k) @ J[p] @ ch.dT(p, i).T)
                Dijk[i - 1, j - 1, k - 1] = s
    return Dijk


def coriolis_torque(links, convention, q, qd) -> np.ndarray:
    """``h_i = sum_j sum_k D_ijk qd_j qd_k`` (eq. 2.39)."""
    Dijk = coriolis_tensor(links, convention, q)
    n = len(links)
    h = np.zeros(n)
    for i in range(1, n + 1):
        s = 0.0
        for j in range(1, n + 1):
            for k in range(1, n + 1):
                s += Dijk[i - 1, j - 1, k - 1] * qd[j - 1] * qd[k - 1]
        h[i - 1] = s
    return h


def gravity_torque(links, convention, gravity, q) -> np.ndarray:
    """``D_i = sum_{p=i}^{n} -m_p g^T dT_p/dq_i r_bar_p`` (eq. 2.39; r_bar as corrected
    in CONVENTIONS.md, "Typesetting slips")."""
    ch = Chain(links, convention, q)
    n = ch.n
    g = _homogeneous_gravity(gravity)
    out = np.zeros(n)
    for i in range(1, n + 1):
        s = 0.0
        for p in range(i, n + 1):
            m_p = float(links[p - 1].mass)
            r_bar = np.append(np.asarray(links[p - 1].com, dtype=float), 1.0)
            s += -m_p * (g @ ch.dT(p, i) @ r_bar)
        out[i - 1] = s
    return out


def inverse_dynamics(links, convention, gravity, q, qd, qdd) -> np.ndarray:
    """``tau = D(q) qdd + h(q, qd) + g(q)`` (eq. 2.39)."""
    D = mass_matrix(links, convention, q)
    h = coriolis_torque(links, convention, q, qd)
    g = gravity_torque(links, convention, gravity, q)
    n = len(links)
    tau = np.zeros(n)
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += D[i, j] * qdd[j]
        tau[i] = s + h[i] + g[i]
    return tau


def dynamics_terms(links, convention, gravity, q, qd):
    """``(D, h, g)`` of eq. 2.39 for one state."""
    return (mass_matrix(links, convention, q),
            coriolis_torque(links, convention, q, qd),
            gravity_torque(links, convention, gravity, q))


def kinetic_energy(links, convention, q, qd) -> float:
    """Eq. 2.22: ``K = 1/2 sum_i tr(sum_j sum_k dT_i/dq_j J_i dT_i/dq_k^T qd_j qd_k)``, plus rotors."""
    ch = Chain(links, convention, q)
    n = ch.n
    K = 0.0
    for i in range(1, n + 1):
        J_i = pseudo_inertia(links[i - 1])
        for j in range(1, i + 1):
            for k in range(1, i + 1):
                K += 0.5 * np.trace(ch.dT(i, j) @ J_i @ ch.dT(i, k).T) * qd[j - 1] * qd[k - 1]
    for i in range(1, n + 1):
        K += 0.5 * armature(links[i - 1]) * qd[i - 1] ** 2
    return K


def potential_energy(links, convention, gravity, q) -> float:
    """Eq. 2.24: ``P = -sum_i m_i g^T T_i r_bar_i``."""
    T = link_poses(links, convention, q)
    g = _homogeneous_gravity(gravity)
    P = 0.0
    for i in range(1, len(links) + 1):
        r_bar = np.append(np.asarray(links[i - 1].com, dtype=float), 1.0)
        P += -float(links[i - 1].mass) * (g @ T[i] @ r_bar)
    return P
