"""Excitation trajectories: finite Fourier series optimised for identification.

Layer: application (identification).

Each joint follows the series of Swevers, Ganseman, Tukel, De Schutter and
Van Brussel (1997), period ``T = duration``, ``w = 2 pi / T``::

    q_j(t) = q0_j + sum_{l=1}^{K} a_jl / (w l) sin(w l t) - b_jl / (w l) cos(w l t)

so ``qd`` and ``qdd`` are series too, and the trajectory is periodic (data
can be averaged over periods, and it starts and ends at the same state).

The coefficients are optimised with scipy (L-BFGS-B from a seeded random
start) to minimise the condition number of the base regressor stacked over
the trajectory's samples.  Limits hold by construction: every candidate is
first scaled about ``q0`` (:func:`_feasible`) so that, on the sample grid,

* ``q`` stays inside the joint limits (``arm.qlim``) shrunk by ``margin``
  (default 5 % of the range at each end);
* ``|qd_j| <= vmax_j`` and ``|qdd_j| <= amax_j``.

Default limits, per joint: revolute 1.5 rad/s and 5 rad/s^2, prismatic
0.3 m/s and 1 m/s^2 (comfortable for the bundled arms; give the real
arm's limits).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from .base import base_parameters

__all__ = ["Excitation", "excitation", "fourier_trajectory", "DEFAULT_VMAX", "DEFAULT_AMAX"]

#: default velocity limit: revolute (rad/s), prismatic (m/s)
DEFAULT_VMAX = {"revolute": 1.5, "prismatic": 0.3}
#: default acceleration limit: revolute (rad/s^2), prismatic (m/s^2)
DEFAULT_AMAX = {"revolute": 5.0, "prismatic": 1.0}


def fourier_trajectory(t, q0, a, b, period: float):
    """``(q, qd, qdd)``, each (N, n), of the Fourier series at times ``t`` (N,) s.

    ``q0`` (n,), ``a`` and ``b`` (n, K): the coefficients of the module docstring.
    """
    t = np.asarray(t, dtype=np.float64)
    a, b = np.atleast_2d(a), np.atleast_2d(b)
    K = a.shape[1]
    w = 2.0 * math.pi / period
    wl = w * np.arange(1, K + 1)                    # (K,)
    s, c = np.sin(np.outer(t, wl)), np.cos(np.outer(t, wl))  # (N, K)
    q = q0 + s @ (a / wl).T - c @ (b / wl).T
    qd = c @ a.T + s @ b.T
    qdd = -s @ (a * wl).T + c @ (b * wl).T
    return q, qd, qdd


@dataclass
class Excitation:
    """An optimised excitation trajectory.

    Attributes
    ----------
    q0 : (n,)
        Offsets (rad or m).
    a, b : (n, K)
        Fourier coefficients (rad/s or m/s).
    period : float
        Period = duration (s).
    t : (N,)
        Sample times (s), ``k / rate``.
    q, qd, qdd : (N, n)
        The samples.
    condition_number : float
        Of the base regressor stacked over the samples.
    n_base : int
        Number of base parameters.
    """

    q0: np.ndarray
    a: np.ndarray
    b: np.ndarray
    period: float
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    condition_number: float
    n_base: int

    def sample(self, t):
        """``(q, qd, qdd)`` at times ``t`` (N,) s."""
        return fourier_trajectory(t, self.q0, self.a, self.b, self.period)

    def to_csv(self, path) -> None:
        """Write ``t,q1..qn,qd1..qdn,qdd1..qddn`` (SI units), atomically."""
        from .data import write_trajectory_csv

        write_trajectory_csv(path, self.t, self.q, self.qd, self.qdd)


def _limits(arm, vmax, amax, margin):
    n = arm.n

    def per_joint(value, default, what):
        if value is None:
            return np.array([default[t] for t in arm.joint_types])
        v = np.asarray(value, dtype=np.float64).reshape(-1)
        if v.size not in (1, n):
            raise ModelError(f"{what}: expected 1 or {n} values, got {v.size}")
        v = np.broadcast_to(v, (n,)).copy()
        if not np.all(np.isfinite(v)) or np.any(v <= 0):
            raise ModelError(f"{what}: expected positive finite limits (one or {n} values), got {value!r}")
        return v

    vmax = per_joint(vmax, DEFAULT_VMAX, "vmax")
    amax = per_joint(amax, DEFAULT_AMAX, "amax")
    if not 0 <= margin < 0.5:
        raise ModelError(f"margin: expected a fraction in [0, 0.5), got {margin!r}")
    lo, hi = arm.qlim[:, 0], arm.qlim[:, 1]
    span = hi - lo
    return vmax, amax, lo + margin * span, hi - margin * span


def _feasible(q0, a, b, period, t, vmax, amax, lo, hi):
    """Scale (a, b) joint by joint about q0 so that every limit holds on the grid ``t``."""
    q, qd, qdd = fourier_trajectory(t, np.zeros_like(q0), a, b, period)
    tiny = 1e-300
    room_up = (hi - q0) / np.maximum(q.max(axis=0), tiny)
    room_dn = (q0 - lo) / np.maximum(-q.min(axis=0), tiny)
    s = np.minimum.reduce([np.ones_like(q0), room_up, room_dn,
                           vmax / np.maximum(np.abs(qd).max(axis=0), tiny),
                           amax / np.maximum(np.abs(qdd).max(axis=0), tiny)])
    s = np.maximum(s, 0.0) * (1.0 - 1e-9)             # strictly inside, after rounding
    return a * s[:, None], b * s[:, None]


def excitation(arm, duration: float = 10.0, harmonics: int = 5, rate: float = 100.0, seed: int = 0,
               vmax=None, amax=None, margin: float = 0.05, armature: bool = False,
               friction: bool = False, iterations: int = 60, grid: int = 120,
               progress=None, base=None) -> Excitation:
    """Optimise a Fourier-series excitation trajectory for ``arm``.

    Parameters
    ----------
    arm : manipdyn.Arm
        Kinematics and joint limits (``arm.qlim``).
    duration : float
        Period and length of the trajectory, s.
    harmonics : int
        K, harmonics per joint.
    rate : float
        Sample rate of the returned samples, Hz.
    seed : int
        Seed of the random start.
    vmax, amax : float or (n,), optional
        Velocity and acceleration limits per joint (defaults: module docstring).
    margin : float
        Fraction of each joint's range kept free at both ends.
    armature, friction : bool
        Excite those parameters too (they join the base regressor).
    iterations : int
        L-BFGS-B iterations.
    grid : int
        Samples per period on which the condition number and limits are
        evaluated during the optimisation (the final figure uses all samples).
    progress : callable, optional
        ``progress(done, total)`` after each iteration.
    base : BaseParameters, optional
        Reuse a :func:`base_parameters` result (same armature/friction flags).
    """
    from ._deps import require

    optimize = require("scipy.optimize", "excitation")
    for name, v in (("duration", duration), ("rate", rate)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ModelError(f"{name}: expected a positive number, got {v!r}")
    if isinstance(harmonics, bool) or not isinstance(harmonics, (int, np.integer)) or harmonics < 1:
        raise ModelError(f"harmonics: expected a positive integer, got {harmonics!r}")
    n, K = arm.n, int(harmonics)
    vmax, amax, lo, hi = _limits(arm, vmax, amax, margin)
    q0 = 0.5 * (lo + hi)
    if base is None:
        base = base_parameters(arm, armature=armature, friction=friction)
    elif (base.armature, base.friction) != (bool(armature), bool(friction)):
        raise ModelError("base: computed with other armature/friction flags than this excitation")
    tg = np.arange(grid) * (duration / grid)

    def unpack(x):
        a, b = x[:n * K].reshape(n, K), x[n * K:].reshape(n, K)
        return _feasible(q0, a, b, duration, tg, vmax, amax, lo, hi)

    def cond(a, b, t):
        q, qd, qdd = fourier_trajectory(t, q0, a, b, duration)
        Y = base.regressor(arm.lagrange.regressor(q, qd, qdd, armature=armature, friction=friction))
        s = np.linalg.svd(Y.reshape(-1, base.count), compute_uv=False)
        return s[0] / s[-1] if s[-1] > 0 else np.inf

    def objective(x):
        c = cond(*unpack(x), tg)
        return math.log(c) if math.isfinite(c) else 1e3

    rng = np.random.default_rng(seed)
    x0 = rng.uniform(-1.0, 1.0, 2 * n * K) * np.tile(np.repeat(vmax, K), 2)
    done = [0]

    def callback(_x):
        done[0] += 1
        if progress is not None:
            progress(min(done[0], iterations), iterations)

    x = x0
    if iterations > 0:
        res = optimize.minimize(objective, x0, method="L-BFGS-B", callback=callback,
                                options={"maxiter": int(iterations)})
        x = res.x if objective(res.x) <= objective(x0) else x0
    a, b = unpack(x)
    if progress is not None:
        progress(iterations, iterations)
    t = np.arange(int(round(duration * rate))) / rate
    # limits hold on the optimisation grid; re-scale on the output samples too
    a, b = _feasible(q0, a, b, duration, np.concatenate([tg, t]), vmax, amax, lo, hi)
    q, qd, qdd = fourier_trajectory(t, q0, a, b, duration)
    return Excitation(q0=q0, a=a, b=b, period=float(duration), t=t, q=q, qd=qd, qdd=qdd,
                      condition_number=float(cond(a, b, t)), n_base=base.count)
