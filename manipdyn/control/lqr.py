"""Time-varying LQR tracking of a reference path, linearised along it.

Layer 6 (control).

:class:`LQR` is a :class:`~manipdyn.control.Controller` (``tau =
controller(t, q, qd)``).  Once, when its reference is bound (at construction
or by :meth:`~manipdyn.control.Controller.reset` with a new trajectory), it

1. samples the reference on the grid ``t_k = t_start + k dt``, k = 0..N
   (``N = round((t_end - t_start) / dt)``, ``dt`` the controller period);
2. computes the feed-forward torque, the model's inverse dynamics on the
   reference, ``tau_ref[k] = ID(q_d[k], qd_d[k], qdd_d[k])`` (friction and
   rotor inertias included: the fast path);
3. linearises the model about each ``(q_d[k], qd_d[k], tau_ref[k])`` and
   discretises by zero-order hold over ``dt``
   (:meth:`manipdyn.Arm.linearize` with ``dt``): ``(A_k, B_k)``, (2n, 2n) and (2n, n),
   for the deviation ``dx = (q - q_d, qd - qd_d)`` and ``du = tau - tau_ref``;
4. solves the discrete algebraic Riccati equation (DARE) of the final sample
   (the reference ends at rest) for the terminal cost ``P_N``, by the
   structure-preserving doubling algorithm, and runs the backward Riccati
   recursion over the horizon (NumPy only), in Joseph form::

       K_k = (R + B_k^T P_{k+1} B_k)^-1 B_k^T P_{k+1} A_k
       P_k = (A_k - B_k K_k)^T P_{k+1} (A_k - B_k K_k) + Q + K_k^T R K_k

   which minimises ``sum_k dx_k^T Q dx_k + du_k^T R du_k`` for the linearised
   deviation dynamics.

The law is then ``tau = tau_ref(t) - K(t) dx`` (before saturation), with
``tau_ref(t)`` the model's inverse dynamics of the reference given at ``t``
(one RNEA call, exact at any ``t``) and ``K(t)`` the gain of the grid sample
at or before ``t``, held over the sample period (zero-order hold, as the
simulation holds the torque); before ``t_start`` the first gain, from the
last sample on the terminal (DARE) gain, which keeps the arm at the end point.

The gains depend only on the controller's model, the reference, ``dt``, ``Q``
and ``R``: never on the plant, so a Monte-Carlo study builds them once per
process and every run, wherever it runs, uses the same numbers.
"""

from __future__ import annotations

import math

import numpy as np

from .._support.state import as_state
from .controllers import Controller

__all__ = ["LQR", "lqr_weights", "solve_dare"]


def lqr_weights(arm, wn: float, q=None):
    """Default LQR weights ``(Q, R)`` for a closed-loop bandwidth ``wn`` (rad/s).

    Per joint i, with ``D_ii`` the model's joint inertia at ``q`` (default the
    middle of the joint limits)::

        Q = diag(wn^4, ..., wn^4, 2 wn^2, ..., 2 wn^2)   (positions, then velocities)
        R = diag(1 / D_ii^2)

    so the cost of a step is ``sum_i wn^4 e_i^2 + 2 wn^2 e_dot_i^2 + (du_i / D_ii)^2``:
    every term in (rad/s^2)^2 (or (m/s^2)^2), the torque counted by the
    acceleration it gives the joint alone.  For a joint seen as the inertia
    ``D_ii`` alone (a double integrator) the continuous-time optimum of these
    weights is ``Kp = wn^2 D_ii``, ``Kd = 2 wn D_ii``: critically damped at the
    bandwidth ``wn``, the tuning of the other demo controllers
    (:func:`manipdyn.control.pd_gains`).  The LQR itself uses the full coupled
    model.  Units: Q in 1/s^4 (positions) and 1/s^2 (velocities), R in
    1/(kg m^2)^2 (1/kg^2 for prismatic joints).  Returns ``Q`` (2n,) and ``R``
    (n,), diagonals.
    """
    wn = float(wn)
    if not (math.isfinite(wn) and wn > 0):
        raise ValueError(f"wn: expected a positive finite bandwidth in rad/s, got {wn!r}")
    q = np.mean(arm.qlim, axis=1) if q is None else as_state(q, "q", arm.n)
    d = np.diag(arm.mass_matrix(q))
    n = arm.n
    Q = np.concatenate([np.full(n, wn**4), np.full(n, 2.0 * wn**2)])
    return Q, 1.0 / d**2


def _weight(W, m: int, name: str, definite: bool) -> np.ndarray:
    """A symmetric (m, m) weight from a scalar, a diagonal (m,) or a matrix (m, m)."""
    try:
        W = np.array(W, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number, ({m},) or ({m}, {m}) numbers, got {W!r:.60}") from None
    if W.ndim == 0:
        W = np.full(m, float(W))
    if W.ndim == 1:
        if W.shape != (m,):
            raise ValueError(f"{name}: expected a scalar, shape ({m},) or ({m}, {m}), got shape {W.shape}")
        W = np.diag(W)
    if W.shape != (m, m):
        raise ValueError(f"{name}: expected a scalar, shape ({m},) or ({m}, {m}), got shape {W.shape}")
    if not np.all(np.isfinite(W)):
        raise ValueError(f"{name}: must be finite")
    if not np.allclose(W, W.T, rtol=1e-12, atol=0.0):
        raise ValueError(f"{name}: must be symmetric")
    eig = np.linalg.eigvalsh(W)
    scale = max(1.0, float(np.abs(eig).max()))
    if definite and eig.min() <= 0:
        raise ValueError(f"{name}: must be positive definite, smallest eigenvalue {eig.min():.3g}")
    if not definite and eig.min() < -1e-12 * scale:
        raise ValueError(f"{name}: must be positive semi-definite, smallest eigenvalue {eig.min():.3g}")
    return 0.5 * (W + W.T)


def solve_dare(A, B, Q, R, tol: float = 1e-12, max_iter: int = 60) -> np.ndarray:
    """The stabilising solution ``P`` of the discrete algebraic Riccati equation (NumPy only).

    ``P = A^T P A - A^T P B (R + B^T P B)^-1 B^T P A + Q``, for ``A`` (m, m),
    ``B`` (m, k), ``Q`` (m, m) >= 0, ``R`` (k, k) > 0, by the
    structure-preserving doubling algorithm (Chu, Fan, Lin and Wang,
    "Structure-preserving algorithms for periodic discrete-time algebraic
    Riccati equations", Int. J. Control 77(8), 2004)::

        W = I + G_j H_j
        A_{j+1} = A_j W^-1 A_j
        G_{j+1} = G_j + A_j W^-1 G_j A_j^T
        H_{j+1} = H_j + A_j^T H_j W^-1 A_j

    from ``A_0 = A``, ``G_0 = B R^-1 B^T``, ``H_0 = Q``; ``H_j -> P``
    quadratically (iteration j covers 2^j steps of the Riccati recursion).
    Stops when ``||H_{j+1} - H_j|| <= tol ||H_{j+1}||`` and the gain
    ``K = (R + B^T P B)^-1 B^T P A`` makes ``A - B K`` stable (spectral radius
    < 1); raises ValueError (naming the pair) otherwise, or when it has not
    converged in ``max_iter`` doublings (a pair that is not stabilisable).
    """
    A = A0 = np.asarray(A, dtype=np.float64)
    B = np.asarray(B, dtype=np.float64)
    m = A.shape[0]
    G = B @ np.linalg.solve(R, B.T)
    H = np.array(Q, dtype=np.float64)
    eye = np.eye(m)
    for _ in range(max_iter):
        W = eye + G @ H
        WA = np.linalg.solve(W, A)                 # W^-1 A
        WG = np.linalg.solve(W, G)                 # W^-1 G
        H_new = H + A.T @ H @ WA
        G = G + A @ WG @ A.T
        A = A @ WA
        H_new = 0.5 * (H_new + H_new.T)
        G = 0.5 * (G + G.T)
        if not np.all(np.isfinite(H_new)):     # an unstabilisable mode: the cost grows without bound
            break
        if np.linalg.norm(H_new - H) <= tol * np.linalg.norm(H_new):
            K = np.linalg.solve(R + B.T @ H_new @ B, B.T @ H_new @ A0)
            rho = np.abs(np.linalg.eigvals(A0 - B @ K)).max()
            if np.isfinite(rho) and rho < 1.0:      # the stabilising solution, not a near-overflow
                return H_new
            break
        H = H_new
    raise ValueError("A, B: the discrete Riccati equation has no finite solution or did not converge "
                     f"in {max_iter} doublings (is the pair stabilisable?)")


class LQR(Controller):
    """Time-varying LQR tracking, linearised along the reference (module docstring).

    ``tau = tau_ref(t) - K(t) (x - x_ref(t))``, ``x = (q, qd)``, ``tau_ref`` the
    model's inverse dynamics on the reference, ``K(t)`` (n, 2n) from the
    backward Riccati recursion over the reference's horizon.

    Parameters
    ----------
    arm : manipdyn.Arm
        The controller's model: its feed-forward, its linearisation, its gains.
    Q : float, (2n,) or (2n, 2n)
        State weight, symmetric positive semi-definite, on ``dx = (q - q_d, qd - qd_d)``
        (positions first).  Default :func:`lqr_weights` at ``wn``.
    R : float, (n,) or (n, n)
        Torque weight, symmetric positive definite, on ``tau - tau_ref``.
        Default :func:`lqr_weights` at ``wn``.
    wn : float
        Bandwidth (rad/s) of the default weights (default 10, as the demo).
    dt : float
        Controller period, s (default 1e-3): the grid of the gains and the
        zero-order hold of the discretisation; use the simulation's step.
    trajectory : Trajectory, optional
        The reference: needs ``t_start`` and ``t_end`` (every
        :class:`manipdyn.control.Trajectory` has them) and to take an array of times.
        The gains are computed when it is bound (here or by ``reset``).
    tau_max : float or (n,), optional
        Torque limits (saturation after the law, :mod:`~manipdyn.control.controllers`).

    Attributes (once a reference is bound): ``t_grid`` (N+1,) s, ``K`` (N+1, n, 2n)
    (``K[N]`` the terminal DARE gain), ``tau_ref`` (N+1, n) N m, ``P0`` (2n, 2n), the
    cost-to-go matrix at ``t_start``.
    """

    name = "LQR"

    def __init__(self, arm, Q=None, R=None, wn: float = 10.0, dt: float = 1e-3, trajectory=None,
                 tau_max=None):
        n = arm.n
        if isinstance(dt, bool) or not isinstance(dt, (int, float, np.integer, np.floating)) \
                or not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt: expected a positive finite controller period in seconds, got {dt!r:.60}")
        self.dt = float(dt)
        if Q is None or R is None:
            Q0, R0 = lqr_weights(arm, wn)
            Q = Q0 if Q is None else Q
            R = R0 if R is None else R
        self.Q = _weight(Q, 2 * n, "Q", definite=False)
        self.R = _weight(R, n, "R", definite=True)
        self._bound = None
        super().__init__(arm, trajectory, tau_max)

    def reset(self, trajectory=None) -> None:
        """Bind ``trajectory`` (computing its gains when it is a new one); no state to clear.

        A reference the gains cannot be computed for is refused (ValueError)
        and the previous one stays bound.
        """
        if trajectory is not None and trajectory is not self._bound:
            if getattr(trajectory, "n", self.n) != self.n:
                raise ValueError(f"trajectory: has {trajectory.n} joints, the arm {self.n}")
            self._design(trajectory)
            self._bound = trajectory
        super().reset(trajectory)

    def _design(self, traj) -> None:
        t0, t1 = getattr(traj, "t_start", None), getattr(traj, "t_end", None)
        if t0 is None or t1 is None or not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
            raise ValueError("trajectory: LQR needs a reference with a finite span t_start < t_end "
                             "(a manipdyn.control.Trajectory)")
        N = max(1, int(round((t1 - t0) / self.dt)))
        t = t0 + np.arange(N + 1) * self.dt
        q_d, qd_d, qdd_d = (np.asarray(r, dtype=np.float64) for r in traj(t))
        if q_d.shape != (N + 1, self.n):
            raise ValueError(f"trajectory: expected ({N + 1}, {self.n}) samples for an array of times, "
                             f"got {q_d.shape}")
        # a batch (a forked worker runs it on one thread: pinocchio_engine._POOL_PID)
        tau = self.arm.inverse_dynamics(q_d, qd_d, qdd_d)
        A, B = self.arm.linearize(q_d, qd_d, tau, dt=self.dt)
        Q, R = self.Q, self.R
        n2 = 2 * self.n
        K = np.empty((N + 1, self.n, n2))
        P = solve_dare(A[N], B[N], Q, R)
        K[N] = np.linalg.solve(R + B[N].T @ P @ B[N], B[N].T @ P @ A[N])
        for k in range(N - 1, -1, -1):
            Ak, Bk = A[k], B[k]
            PB = P @ Bk
            Kk = np.linalg.solve(R + Bk.T @ PB, PB.T @ Ak)
            Acl = Ak - Bk @ Kk
            P = Acl.T @ P @ Acl + Q + Kk.T @ R @ Kk
            P = 0.5 * (P + P.T)
            K[k] = Kk
        if not np.all(np.isfinite(K)):
            raise ValueError("Q, R: the Riccati recursion along the reference is not finite")
        self.t_grid, self.K, self.tau_ref, self.P0 = t, K, tau, P
        self._t0, self._N = float(t0), N
        self._Klist = list(K)

    def gain(self, t) -> np.ndarray:
        """``K(t)`` (n, 2n): the gain of the grid sample at or before ``t`` (held)."""
        if self.trajectory is None:
            raise ValueError("LQR: no trajectory; pass one to the constructor or to reset()")
        return self._Klist[self._index(t)]

    def _index(self, t) -> int:
        # the sample at or before t; 1e-6 of a period absorbs the rounding of k * dt
        k = math.floor((t - self._t0) / self.dt + 1e-6)
        return 0 if k < 0 else (self._N if k > self._N else k)

    def law(self, t, q, qd, q_d, qd_d, qdd_d):
        dx = np.concatenate([q - q_d, qd - qd_d])
        return self.arm.inverse_dynamics(q_d, qd_d, qdd_d) - self._Klist[self._index(t)] @ dx

    def _law_unchecked(self, t, q, qd, q_d, qd_d, qdd_d):
        dx = np.concatenate([q - q_d, qd - qd_d])
        ff = self.arm.pinocchio.unchecked.inverse_dynamics(q_d, qd_d, qdd_d)
        return ff - self._Klist[self._index(t)] @ dx
