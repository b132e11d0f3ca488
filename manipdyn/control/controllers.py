"""Joint-space tracking controllers with one interface: ``tau = controller(t, q, qd)``.

Layer 6 (control).

Each controller follows a reference trajectory (``trajectory(t) -> (q_d,
qd_d, qdd_d)``, see :mod:`manipdyn.control.trajectory`), bound at
construction or by :meth:`Controller.reset` (which :func:`manipdyn.simulate` calls).
The tracking error is ``e = q_d - q`` (reference minus actual) and
``e_dot = qd_d - qd``.  Gains are scalars or per-joint ``(n,)`` arrays
(diagonal gain matrices).

Torque limits: every controller saturates its output joint by joint,
``tau_i = clip(tau_i, -tau_max_i, tau_max_i)``.  ``tau_max`` (N m or N per
joint, scalar or ``(n,)``; ``inf`` for no limit) comes from the controller's
argument; when it is not given, from the model's own limits where it has
them (a URDF's ``<limit effort>``), else none.  Saturation is applied after
the control law and does not feed back into it: the adaptive estimate keeps
adapting while the torque is saturated (no anti-windup).

* :class:`PD`: ``tau = Kp e + Kd e_dot``.
* :class:`PDGravity`: ``tau = Kp e + Kd e_dot + g(q)``.
* :class:`ComputedTorque`: inverse-dynamics control,
  ``tau = D(q) (qdd_d + Kd e_dot + Kp e) + h(q, qd) + g(q)`` (+ the model's
  friction), one RNEA call on the model (the fast path).
* :class:`SlotineLi`: the adaptive controller of Slotine and Li (1987),
  ``tau = Y(q, qd, qr_d, qr_dd) pi_hat - K_D s`` with the estimate updated by
  ``pi_hat_dot = -Gamma Y^T s``.
"""

from __future__ import annotations

import math

import numpy as np

from .._support.errors import ModelError
from .._support.state import as_state
from .regressor import Regressor

__all__ = ["Controller", "PD", "PDGravity", "ComputedTorque", "SlotineLi",
           "model_torque_limits", "pd_gains", "adaptation_gains"]


def _gain(value, n: int, name: str, positive: bool = False, allow_inf: bool = False,
          nonnegative: bool = False) -> np.ndarray:
    try:
        g = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number or {n} numbers, got {value!r}") from None
    if g.ndim == 0:
        g = np.full(n, float(g))
    if g.shape != (n,):
        raise ValueError(f"{name}: expected a scalar or shape ({n},), got shape {g.shape}")
    if not np.all(np.isfinite(g) | (allow_inf & (g == math.inf))):
        raise ValueError(f"{name}: must be finite, got {g.tolist()}")
    if positive and np.any(g <= 0):
        raise ValueError(f"{name}: must be > 0, got {g.tolist()}")
    if nonnegative and np.any(g < 0):
        raise ValueError(f"{name}: must be >= 0 (a negative gain drives the arm away from the path), "
                         f"got {g.tolist()}")
    return g


def model_torque_limits(arm):
    """The arm's own torque limits (n,) with ``inf`` where it has none, or None.

    DH arms (:class:`manipdyn.Manipulator`) carry none; URDF arms have each
    joint's ``<limit effort>`` (a non-positive effort counts as no limit).
    """
    joints, _ = arm.chain()
    lim = np.array([j.effort if (j.effort is not None and j.effort > 0) else math.inf for j in joints])
    return lim if np.any(np.isfinite(lim)) else None


def pd_gains(arm, wn: float, zeta: float = 1.0, q=None):
    """Per-joint PD gains ``(Kp, Kd)`` for a closed-loop bandwidth ``wn`` (rad/s).

    ``Kp_i = wn^2 D_ii(q)``, ``Kd_i = 2 zeta wn D_ii(q)``: each joint, seen as
    the inertia ``D_ii`` alone, becomes a second-order system with natural
    frequency ``wn`` and damping ratio ``zeta``.  ``q`` defaults to the middle
    of the joint limits.  Units N m/rad and N m s/rad (N/m, N s/m).
    """
    q = np.mean(arm.qlim, axis=1) if q is None else as_state(q, "q", arm.n)
    d = np.diag(arm.mass_matrix(q))
    still = [j + 1 for j in range(len(d)) if not d[j] > 0]
    if still:      # D singular: no gain makes such a joint a second-order system (and no simulation runs)
        raise ModelError(f"{getattr(arm, 'name', '') or 'arm'}: the mass matrix D(q) is singular: joint(s) {still} move "
                         "no mass; give the links after them mass or the joints rotor inertia")
    return wn**2 * d, 2.0 * zeta * wn * d


def adaptation_gains(arm, gamma: float, regressor=None, q=None) -> np.ndarray:
    """A diagonal adaptation gain ``Gamma`` (p,) for :class:`SlotineLi`, scaled to the arm.

    ``Gamma_k = gamma * min_{j <= i} D_jj(q)`` for the 10 parameters of link i
    (the smallest joint inertia among the joints that link's parameters act
    on), and ``gamma * D_jj`` for joint j's armature and friction parameters.

    Why: a parameter error drives joint j through ``D_jj s_j_dot ~ -Y_jk pi_tilde_k``
    while the law feeds back ``pi_tilde_k_dot = -Gamma_k Y_jk s_j``: an oscillator
    with ``omega^2 ~ Gamma_k Y_jk^2 / D_jj``.  A single Gamma for every parameter
    makes the light wrist joints of an arm adapt far faster than its heavy base
    (and the Euler-discretised update unstable at 1 kHz on a UR5); scaling by
    D_jj gives every joint the same adaptation rate, whatever the arm's size.
    ``q`` defaults to the middle of the joint limits; ``regressor`` to
    ``Regressor(arm)``.
    """
    armature, friction = (Regressor.default_flags(arm) if regressor is None
                          else (regressor.armature, regressor.friction))
    q = np.mean(arm.qlim, axis=1) if q is None else as_state(q, "q", arm.n)
    d = np.diag(arm.mass_matrix(q))
    parts = [np.repeat(np.minimum.accumulate(d), 10)]
    if armature:
        parts.append(d)
    if friction:
        parts += [d, d]
    return float(gamma) * np.concatenate(parts)


class Controller:
    """Base class: ``tau = controller(t, q, qd)``, (n,) in, (n,) N m (N) out.

    Parameters
    ----------
    arm : manipdyn.Arm
        The controller's model of the arm (it may differ from the plant).
    trajectory : callable, optional
        ``trajectory(t) -> (q_d, qd_d, qdd_d)``; or bind one with :meth:`reset`.
    tau_max : float or (n,), optional
        Torque limits (see the module docstring).
    """

    name = "controller"

    def __init__(self, arm, trajectory=None, tau_max=None):
        self.arm = arm
        self.n = arm.n
        self.trajectory = None
        if tau_max is None:
            self.tau_max = model_torque_limits(arm)
        else:
            lim = _gain(tau_max, self.n, "tau_max", allow_inf=True)
            if np.any(lim <= 0):
                raise ValueError(f"tau_max: must be > 0 (inf for no limit), got {lim.tolist()}")
            self.tau_max = None if np.all(np.isinf(lim)) else lim
        self.reset(trajectory)

    def reset(self, trajectory=None) -> None:
        """Bind ``trajectory`` (if given) and clear any internal state."""
        if trajectory is not None:
            if getattr(trajectory, "n", self.n) != self.n:
                raise ValueError(f"trajectory: has {trajectory.n} joints, the arm {self.n}")
            self.trajectory = trajectory

    def law(self, t, q, qd, q_d, qd_d, qdd_d) -> np.ndarray:
        """The control law before saturation; subclasses implement it."""
        raise NotImplementedError

    def step(self, t, q, qd, q_d, qd_d, qdd_d) -> np.ndarray:
        """The saturated control law for a reference already evaluated: no validation.

        For loops that validated their inputs once (:func:`manipdyn.simulate` does):
        ``q, qd, q_d, qd_d, qdd_d`` must be finite ``(n,)`` float64 arrays in
        native byte order, and ``t`` must not go back in time without
        :meth:`reset`.  Model calls go to the arm's unchecked Pinocchio path.
        ``controller(t, q, qd)`` is ``step(t, q, qd, *trajectory(t))`` after checking.
        """
        return self._saturate(self._law_unchecked(t, q, qd, q_d, qd_d, qdd_d))

    def _saturate(self, tau):
        lim = self.tau_max
        return tau if lim is None else np.minimum(np.maximum(tau, -lim), lim)

    def _law_unchecked(self, t, q, qd, q_d, qd_d, qdd_d):
        # subclasses whose law calls the model override this with the unchecked calls
        return self.law(t, q, qd, q_d, qd_d, qdd_d)

    def __call__(self, t, q, qd) -> np.ndarray:
        if self.trajectory is None:
            raise ValueError(f"{type(self).__name__}: no trajectory; pass one to the "
                             "constructor or to reset()")
        q = as_state(q, "q", self.n)
        qd = as_state(qd, "qd", self.n)
        if q.ndim != 1 or qd.ndim != 1:
            raise ValueError(f"{type(self).__name__}: one state at a time, q and qd of shape ({self.n},)")
        q_d, qd_d, qdd_d = self.trajectory(t)
        return self._saturate(self.law(t, q, qd, q_d, qd_d, qdd_d))

    def __repr__(self) -> str:
        return f"<{type(self).__name__} for {self.arm.name or 'arm'}>"


class PD(Controller):
    """``tau = Kp e + Kd e_dot`` (no model); ``Kp`` N m/rad, ``Kd`` N m s/rad, per joint."""

    name = "PD"

    def __init__(self, arm, kp, kd, trajectory=None, tau_max=None):
        self.kp = _gain(kp, arm.n, "kp", nonnegative=True)
        self.kd = _gain(kd, arm.n, "kd", nonnegative=True)
        super().__init__(arm, trajectory, tau_max)

    def law(self, t, q, qd, q_d, qd_d, qdd_d):
        return self.kp * (q_d - q) + self.kd * (qd_d - qd)


class PDGravity(PD):
    """``tau = Kp e + Kd e_dot + g(q)``: PD plus the model's gravity torque."""

    name = "PD+gravity"

    def law(self, t, q, qd, q_d, qd_d, qdd_d):
        return self.kp * (q_d - q) + self.kd * (qd_d - qd) + self.arm.gravity_torque(q)

    def _law_unchecked(self, t, q, qd, q_d, qd_d, qdd_d):
        g = self.arm.pinocchio.unchecked.gravity_torque(q)
        return self.kp * (q_d - q) + self.kd * (qd_d - qd) + g


class ComputedTorque(Controller):
    """Inverse-dynamics control: ``tau = ID_model(q, qd, qdd_d + Kd e_dot + Kp e)``.

    With a perfect model the error obeys ``e_ddot + Kd e_dot + Kp e = 0``
    (``Kp`` in 1/s^2, ``Kd`` in 1/s; defaults: bandwidth 10 rad/s, critically
    damped).  Through the fast path this is one RNEA call,
    ``D(q) v + h(q, qd) + g(q)`` plus the model's friction.
    """

    name = "computed torque"

    def __init__(self, arm, kp=100.0, kd=20.0, trajectory=None, tau_max=None):
        self.kp = _gain(kp, arm.n, "kp", nonnegative=True)
        self.kd = _gain(kd, arm.n, "kd", nonnegative=True)
        super().__init__(arm, trajectory, tau_max)

    def law(self, t, q, qd, q_d, qd_d, qdd_d):
        v = qdd_d + self.kd * (qd_d - qd) + self.kp * (q_d - q)
        return self.arm.inverse_dynamics(q, qd, v)

    def _law_unchecked(self, t, q, qd, q_d, qd_d, qdd_d):
        v = qdd_d + self.kd * (qd_d - qd) + self.kp * (q_d - q)
        return self.arm.pinocchio.unchecked.inverse_dynamics(q, qd, v)


class SlotineLi(Controller):
    """Adaptive control of Slotine and Li, in regressor form.

    J.-J. E. Slotine and W. Li, "On the adaptive control of robot
    manipulators", Int. J. Robotics Research 6(3):49-59, 1987 (also Slotine
    and Li, "Applied Nonlinear Control", 1991, sec. 9.2).  With their sign
    conventions, ``q_tilde = q - q_d`` (so ``q_tilde = -e``)::

        s      = q_tilde_dot + Lambda q_tilde          (sliding variable)
        qr_d   = qd_d - Lambda q_tilde                 (reference velocity)
        qr_dd  = qdd_d - Lambda q_tilde_dot
        tau    = Y(q, qd, qr_d, qr_dd) pi_hat - K_D s
        pi_hat_dot = -Gamma Y^T s

    ``Y pi = D(q) qr_dd + C(q, qd) qr_d + g(q)`` (+ armature and friction
    columns) is :class:`Regressor`, with C the Christoffel Coriolis matrix, for
    which ``dD/dt - 2C`` is skew-symmetric: the property the Lyapunov function
    ``V = 1/2 (s^T D s + pi_tilde^T Gamma^-1 pi_tilde)`` needs
    (``V_dot = -s^T K_D s``, so s -> 0 and q -> q_d).

    Parameters
    ----------
    arm : manipdyn.Arm
        The model: its kinematics and its parameters, the initial estimate.
    lam : float or (n,)
        ``Lambda``, 1/s: the error decays as ``exp(-Lambda t)`` once s = 0.
    kd : float or (n,)
        ``K_D``, N m s/rad (N s/m).
    gamma : float, (p,) or (p, p)
        Adaptation gain ``Gamma`` (positive; a vector is a diagonal; a scalar
        is ``gamma * I``).  :func:`adaptation_gains` scales a diagonal to the arm.
    pi0 : (p,), optional
        Initial estimate; default the model's :meth:`Regressor.parameters`.

    Discrete time: the estimate is integrated by forward Euler between calls,
    ``pi_hat(t_k) = pi_hat(t_{k-1}) + (t_k - t_{k-1}) pi_hat_dot(t_{k-1})``, as a
    digital controller sampling at the simulation step would; :meth:`reset`
    returns it to ``pi0``.  The current estimate is ``pi_hat`` (p,).
    """

    name = "adaptive (Slotine-Li)"

    def __init__(self, arm, lam, kd, gamma, pi0=None, trajectory=None, tau_max=None,
                 armature=None, friction=None):
        n = arm.n
        self.regressor = Regressor(arm, armature=armature, friction=friction)
        p = self.regressor.p
        self.lam = _gain(lam, n, "lam", positive=True)
        self.kd = _gain(kd, n, "kd", positive=True)
        G = np.array(gamma, dtype=np.float64)
        if G.ndim == 0:
            G = np.full(p, float(G))
        if G.shape not in ((p,), (p, p)) or not np.all(np.isfinite(G)):
            raise ValueError(f"gamma: expected a scalar, ({p},) or ({p}, {p}), finite, got shape {G.shape}")
        if G.ndim == 1 and np.any(G < 0):
            raise ValueError("gamma: must be >= 0")
        self.gamma = G
        self.pi0 = self.regressor.parameters() if pi0 is None else np.array(pi0, dtype=np.float64)
        if self.pi0.shape != (p,):
            raise ValueError(f"pi0: expected shape ({p},), got {self.pi0.shape}")
        super().__init__(arm, trajectory, tau_max)

    def reset(self, trajectory=None) -> None:
        super().reset(trajectory)
        self.pi_hat = self.pi0.copy()
        self._t_last = None
        self._rate = None

    def law(self, t, q, qd, q_d, qd_d, qdd_d):
        if self._t_last is not None:
            dt = t - self._t_last
            if dt < 0:
                raise ValueError(f"SlotineLi: time went back from {self._t_last} to {t}; call reset()")
            self.pi_hat += dt * self._rate
        self._t_last = t
        lam = self.lam
        qt = q - q_d
        qtd = qd - qd_d
        s = qtd + lam * qt
        Y = self.regressor._unchecked(q, qd, qd_d - lam * qt, qdd_d - lam * qtd)
        G = self.gamma
        Ys = Y.T @ s
        self._rate = -(G * Ys if G.ndim == 1 else G @ Ys)
        return Y @ self.pi_hat - self.kd * s
