"""Excitation trajectories: finite Fourier series optimised for identification.

Layer 5 (identification).

Each joint follows the series of Swevers, Ganseman, Tukel, De Schutter and
Van Brussel (1997), period ``T = duration``, ``w = 2 pi / T``::

    q_j(t) = q0_j + sum_{l=1}^{K} a_jl / (w l) sin(w l t) - b_jl / (w l) cos(w l t)

so ``qd`` and ``qdd`` are series too, and the trajectory is periodic (data
can be averaged over periods, and it starts and ends at the same state).

The coefficients are optimised with scipy (L-BFGS-B from a seeded random
start) to minimise the condition number of the base regressor stacked over
``grid`` samples per period; the gradient is scipy's forward difference,
linearised in the joint states (:func:`_log_cond_and_grad`: 3 n + 1
regressor evaluations per sample instead of 2 n K + 1).  Limits hold by
construction, at every time and not only at the samples: every candidate is
first scaled about ``q0`` (:func:`_feasible`, with the bounds of
:func:`_peaks`) so that

* ``q`` stays inside the joint limits (``arm.qlim``) shrunk by ``margin``
  (default 5 % of the range at each end);
* ``|qd_j| <= vmax_j`` and ``|qdd_j| <= amax_j``.

From rest to rest (issue 31, item 14): a robot cannot start on the series, which is moving
at t = 0.  By default the trajectory ramps in and out: ``q(t) = q0 + e(t) (p(t) - q0)`` with
``p`` the series and ``e`` rising from 0 to 1 over ``ramp`` seconds by the septic smoothstep
``35 u^4 - 84 u^5 + 70 u^6 - 20 u^7`` (``u = t / ramp``), staying 1 over one period, and falling
back over ``ramp`` seconds; so it starts and ends at ``q0`` at rest (``qd = qdd = 0``, and no
jump in the jerk), and position, velocity, acceleration and jerk are continuous (a
discontinuous jerk would put a kink in qdd that a log's low-pass filter rounds off).  ``q`` stays within the joint limits
(``e`` in [0, 1]); the ramps' velocities and accelerations (``e' (p - q0) + e qd_p``, ...) are
bounded at every time like the series' (:func:`_ramp_peaks`), and ``ramp="auto"`` takes
the shortest of ``period / 4, period / 2, period, 2 period`` under which they hold the
limits; where none does, the joint's coefficients are scaled down until they hold.
``ramp=0`` gives the bare periodic series.

The highest harmonic must lie below the Nyquist frequency of the samples
(``K / duration < rate / 2``), and there must be at least as many equations
(samples times n) as base parameters; otherwise :class:`ModelError`.

Default limits, per joint: revolute 1.5 rad/s and 5 rad/s^2, prismatic
0.3 m/s and 1 m/s^2 (comfortable for the bundled arms; give the real
arm's limits).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError
from ..estimation.base import base_parameters, check_base
from .motion_limits import DEFAULT_AMAX, DEFAULT_VMAX, motion_limits

__all__ = ["Excitation", "excitation", "fourier_trajectory", "ramped_trajectory", "DEFAULT_VMAX", "DEFAULT_AMAX"]


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


def _envelope(t, ramp: float, period: float):
    """``e, e', e''`` (N,) of the ramps at times ``t`` (module docstring)."""
    T = period + 2.0 * ramp
    u = np.clip(np.minimum(t, T - t) / ramp, 0.0, 1.0)
    sgn = np.where(t <= T / 2, 1.0, -1.0)              # falling: d/dt of u is -1 / ramp
    e = u**4 * (35 - 84 * u + 70 * u**2 - 20 * u**3)
    inside = (u > 0) & (u < 1)
    e1 = np.where(inside, 140 * u**3 * (1 - u) ** 3, 0.0) * sgn / ramp
    e2 = np.where(inside, 420 * u**2 * (1 - u) ** 2 * (1 - 2 * u), 0.0) / ramp**2
    return e, e1, e2


def ramped_trajectory(t, q0, a, b, period: float, ramp: float):
    """``(q, qd, qdd)`` (N, n) of the series ramped in and out over ``ramp`` s (module docstring);
    the series itself (:func:`fourier_trajectory`) when ``ramp`` is 0."""
    q, qd, qdd = fourier_trajectory(t, q0, a, b, period)
    if not ramp:
        return q, qd, qdd
    e, e1, e2 = (x[:, None] for x in _envelope(np.asarray(t, dtype=np.float64), ramp, period))
    d = q - q0
    return q0 + e * d, e1 * d + e * qd, e2 * d + 2.0 * e1 * qd + e * qdd


#: suprema of |e^(k)| of the smoothstep per unit u, k = 0..4 (35/16; 7.51319 at u = 0.2764,
#: rounded up; 52.5 at u = 1/2; 840 at both ends)
_SMOOTHSTEP_SUP = (1.0, 2.1875, 7.5132, 52.5, 840.0)


def _ramp_peaks(a, b, period: float, ramp: float, points: int = 4000):
    """Bounds (n,) on ``max |qd|`` and ``max |qdd|`` over both ramps at every time: the maximum
    over ``points`` samples of each plus ``h^2 / 8`` times a bound on the second derivative (the
    third and fourth of q, by Leibniz from the envelope's and the series' suprema), as
    :func:`_peaks` bounds the series.  (The ramp out is no mirror of the ramp in: it rides
    the series from ``ramp`` to ``2 ramp``, modulo the period.)"""
    K = a.shape[-1]
    wl = 2.0 * math.pi / period * np.arange(1, K + 1)
    h = np.linspace(0.0, ramp, points)
    t = np.concatenate((h, ramp + period + h))
    _, qd, qdd = ramped_trajectory(t, np.zeros(a.shape[0]), a, b, period, ramp)
    amp = np.hypot(a, b)
    P = [np.sum(amp * wl ** (k - 1), axis=-1) for k in range(5)]      # sup |d^k (p - q0)|
    E = [c / ramp**k for k, c in enumerate(_SMOOTHSTEP_SUP)]
    binom = ((1,), (1, 1), (1, 2, 1), (1, 3, 3, 1), (1, 4, 6, 4, 1))
    sup = [sum(c * E[k - j] * P[j] for j, c in enumerate(binom[k])) for k in range(5)]   # sup |d^k (q - q0)|
    gap = (ramp / (points - 1)) ** 2 / 8.0
    return np.abs(qd).max(axis=0) + gap * sup[3], np.abs(qdd).max(axis=0) + gap * sup[4]


def _check_ramp(ramp, rate: float) -> None:
    """A :class:`ModelError` naming ``ramp`` unless it is ``"auto"``, 0 or finite seconds of at least one
    sample (``1 / rate``): a shorter ramp is a jump, whose acceleration (1 / ramp^2) would scale the
    series down to nothing, or overflow."""
    if isinstance(ramp, str) and ramp == "auto":
        return
    if isinstance(ramp, (bool, np.bool_)) or not isinstance(ramp, numbers.Real) or not (
            math.isfinite(float(ramp)) and ramp >= 0):
        raise ModelError(f"ramp: expected seconds >= 0 or 'auto', got {ramp!r:.40}")
    if 0 < ramp < 1.0 / rate:
        raise ModelError(f"ramp: {float(ramp):g} s is shorter than one sample (1 / rate = {1.0 / rate:g} s); "
                         "expected 0 (no ramp), 'auto', or at least one sample")


def _with_ramp(a, b, period: float, ramp, vmax, amax):
    """``(a, b, ramp)``: the ramp's length (``"auto"``: module docstring) and the coefficients,
    each joint's scaled down where its ramps would break ``vmax`` or ``amax``."""
    if isinstance(ramp, str):
        for T in (period / 4, period / 2, period, 2 * period):
            v, acc = _ramp_peaks(a, b, period, T)
            if np.all(v <= vmax) and np.all(acc <= amax):
                return a, b, T
        ramp = 2 * period
    ramp = float(ramp)
    if ramp == 0:
        return a, b, 0.0
    v, acc = _ramp_peaks(a, b, period, ramp)
    s = np.minimum.reduce([np.ones_like(v), vmax / np.maximum(v, 1e-300), amax / np.maximum(acc, 1e-300)])
    s = np.where(s < 1.0, s * (1.0 - 1e-9), 1.0)       # strictly inside, after rounding
    return a * s[:, None], b * s[:, None], ramp


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
    ramp : float
        Seconds of each ramp (in, and out), 0 for the bare series (module docstring); the
        samples cover ``ramp + period + ramp`` seconds, at rest at both ends when ``ramp > 0``.
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
    ramp: float = 0.0

    @property
    def duration(self) -> float:
        """Seconds from start to end: ``ramp + period + ramp``."""
        return self.period + 2.0 * self.ramp

    def sample(self, t):
        """``(q, qd, qdd)`` at times ``t`` (N,) s: the series, ramped in and out (module docstring)."""
        return ramped_trajectory(t, self.q0, self.a, self.b, self.period, self.ramp)

    def to_csv(self, path) -> None:
        """Write ``t,q1..qn,qd1..qdn,qdd1..qddn`` (SI units), atomically."""
        from ...formats.logs.data import write_trajectory_csv

        write_trajectory_csv(path, self.t, self.q, self.qd, self.qdd)


#: points per period of the highest harmonic on which the limits are checked (see _peaks)
LIMIT_POINTS = 50


def _peaks(a, b, period):
    """Bounds on ``max (q - q0)``, ``max (q0 - q)``, ``max |qd|``, ``max |qdd|`` over ALL
    times, each (..., n), for coefficients ``a``, ``b`` (..., n, K).

    Evaluated on a grid of ``M = LIMIT_POINTS * K`` points per period, plus the
    gap between grid points: at a maximum t* of a smooth periodic f, f'(t*) = 0,
    and the nearest grid point is within dt / 2, so ``max f <= max_grid f +
    dt^2 / 8 sup |f''|``; ``sup |f''|`` is bounded by the sum of its harmonics'
    amplitudes.  The gap term is below ``pi^2 / (2 LIMIT_POINTS^2)`` (0.2 %) of
    the sum of the amplitudes, so the bound is tight.
    """
    K = a.shape[-1]
    M = LIMIT_POINTS * K
    w = 2.0 * math.pi / period
    wl = w * np.arange(1, K + 1)
    t = np.arange(M) * (period / M)
    S, C = np.sin(np.outer(wl, t)), np.cos(np.outer(wl, t))     # (K, M)
    q = (a / wl) @ S - (b / wl) @ C                               # (..., n, M)
    qd = a @ C + b @ S
    qdd = (b * wl) @ C - (a * wl) @ S
    amp = np.hypot(a, b)                                         # |harmonic l| of qd
    gap = (period / M) ** 2 / 8.0
    sq, sqd, sqdd = (gap * np.sum(amp * wl**p, axis=-1) for p in (1, 2, 3))  # sup |f''| terms
    return (q.max(axis=-1) + sq, -q.min(axis=-1) + sq, np.abs(qd).max(axis=-1) + sqd,
            np.abs(qdd).max(axis=-1) + sqdd)


def _feasible(q0, a, b, period, vmax, amax, lo, hi):
    """Scale (a, b) (..., n, K) joint by joint about q0 so that every limit holds at
    every time, not only at samples (:func:`_peaks`)."""
    up, dn, vd, ad = _peaks(a, b, period)
    tiny = 1e-300
    s = np.minimum.reduce([np.ones_like(up), (hi - q0) / np.maximum(up, tiny),
                           (q0 - lo) / np.maximum(dn, tiny), vmax / np.maximum(vd, tiny),
                           amax / np.maximum(ad, tiny)])
    s = np.maximum(s, 0.0) * (1.0 - 1e-9)             # strictly inside, after rounding
    return a * s[..., None], b * s[..., None]


def _log_cond_and_grad(regressor, base, x, unpack, q0, period, tg):
    """``log cond`` of the stacked base regressor on the grid ``tg`` at ``x``, and its gradient.

    The gradient is the forward difference scipy would take (step
    ``sqrt(eps) max(1, |x_k|)``), linearised in the state: coefficient k moves
    only its joint j's samples, by ``(dq_j, dqd_j, dqdd_j)`` (through the
    feasibility scaling too, computed exactly), so
    ``d log cond = sum_t g_q[t, j] dq_j + g_qd[t, j] dqd_j + g_qdd[t, j] dqdd_j``
    with ``g = <d log cond / dY, dY/d(state)>``.  ``Y`` is linear in qdd and
    quadratic in qd, so 3 n + 1 regressor calls per sample replace 2 n K + 1
    (``d log s = (Y v)^T (dY v) / s^2`` for a singular pair ``(s, v)``).
    Returns ``(value, grad)``; ``(inf, None)`` if the regressor is singular.
    """
    from scipy.linalg import eigh

    a, b = unpack(x)
    q, qd, qdd = fourier_trajectory(tg, q0, a, b, period)
    T, n = q.shape
    eq, ed = 1e-7, 1e-7                                # forward-difference steps in q and qd
    eye = np.eye(n)
    Q = np.concatenate([q[None], q[None] + eq * eye[:, None],
                        np.broadcast_to(q, (2 * n, T, n))]).reshape(-1, n)
    QD = np.concatenate([np.broadcast_to(qd, (n + 1, T, n)), qd[None] + ed * eye[:, None],
                         np.broadcast_to(qd, (n, T, n))]).reshape(-1, n)
    QDD = np.concatenate([np.broadcast_to(qdd, (2 * n + 1, T, n)), qdd[None] + eye[:, None]]).reshape(-1, n)
    Y = regressor(Q, QD, QDD).reshape(3 * n + 1, T, n, -1)   # full columns
    Y0 = base.regressor(Y[0])                                  # base columns, (T, n, r)
    # singular values and vectors from the r x r Gram matrix: one matrix product and a
    # small symmetric eigenproblem (scipy's MRRR driver), far cheaper than an SVD of
    # the tall Y0, whose LAPACK call can take 100x longer when BLAS threads contend.
    # Its eigenvalues carry an absolute error ~eps s_max^2: exact enough while the
    # condition number is below ~1e6; beyond that the SVD of R (Y0 = Q R) is used.
    Yf = Y0.reshape(-1, base.count)
    lam, W = eigh(Yf.T @ Yf, driver="evr")
    if lam[0] > 1e-12 * lam[-1]:
        s = np.sqrt(lam[[-1, 0]])
        V = W[:, [-1, 0]]                              # (r, 2): the largest and smallest pairs
    else:
        _, sv, Vt = np.linalg.svd(np.linalg.qr(Yf, mode="r"))
        s, V = sv[[0, -1]], Vt[[0, -1]].T
    if not s[-1] > 0:
        return math.inf, None
    value = math.log(s[0] / s[-1])
    YVw = (Y0 @ V) * np.array([1.0 / s[0] ** 2, -1.0 / s[-1] ** 2])   # (T, n, 2)
    Vf = np.zeros((Y.shape[-1], 2))
    Vf[base.independent] = V                           # Y_full @ Vf == Y_base @ V: no copy of columns

    def contract(dY):                                  # dY (n, T, n, p) -> (T, n)
        return ((dY @ Vf) * YVw[None]).sum(axis=(2, 3)).T

    gq = contract((Y[1:n + 1] - Y[0]) / eq)            # error ~eq |d2Y/dq2|
    gqd = contract((Y[n + 1:2 * n + 1] - Y[0]) / ed)   # error ed |Q(e_j)|: Y is quadratic in qd
    gqdd = contract(Y[2 * n + 1:] - Y[0])              # exact: Y is linear in qdd (step 1)
    # the coefficient perturbations, through the feasibility scaling
    h = math.sqrt(np.finfo(float).eps) * np.where(x >= 0, 1.0, -1.0) * np.maximum(1.0, np.abs(x))
    xs = x[None] + np.diag(h)
    h = (xs - x[None]).diagonal()
    ak, bk = unpack(xs)                                 # (p, n, K)
    K = a.shape[1]
    j = np.arange(x.size) % (n * K) // K                # the joint of coefficient k
    w_ = 2.0 * math.pi / period
    wl = w_ * np.arange(1, K + 1)
    S, C = np.sin(np.outer(tg, wl)), np.cos(np.outer(tg, wl))
    da, db = ak[np.arange(x.size), j] - a[j], bk[np.arange(x.size), j] - b[j]   # (p, K)
    dq = S @ (da / wl).T - C @ (db / wl).T              # (T, p)
    dqd = C @ da.T + S @ db.T
    dqdd = -S @ (da * wl).T + C @ (db * wl).T
    grad = (np.sum(gq[:, j] * dq, axis=0) + np.sum(gqd[:, j] * dqd, axis=0)
            + np.sum(gqdd[:, j] * dqdd, axis=0)) / h
    return value, grad


def excitation(arm, duration: float = 10.0, harmonics: int = 5, rate: float = 100.0, seed: int = 0,
               vmax=None, amax=None, margin: float = 0.05, armature: bool = False,
               friction: bool = False, iterations: int = 60, grid: int = 120,
               progress=None, base=None, ramp="auto") -> Excitation:
    """Optimise a Fourier-series excitation trajectory for ``arm``.

    Parameters
    ----------
    arm : manipdyn.Arm
        Kinematics and joint limits (``arm.qlim``).
    duration : float
        The series' period, s: one period is optimised and sampled; with the ramps
        (``ramp``) the samples cover ``ramp + duration + ramp`` seconds
        (:attr:`Excitation.duration`).
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
    ramp : float or "auto"
        Seconds of the ramp in and of the ramp out, from and to rest at ``q0`` (module
        docstring); ``"auto"`` (the default) the shortest that keeps ``vmax`` and ``amax``;
        0 for the bare periodic series (which starts moving); otherwise at least one sample
        (``1 / rate``).  The samples cover
        ``ramp + duration + ramp`` seconds.
    """
    from ..._support.deps import require

    optimize = require("scipy.optimize", "excitation")
    for name, v in (("duration", duration), ("rate", rate)):
        # any real number (a numpy int64 or float32 too), not a bool
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real) or not (
                math.isfinite(float(v)) and v > 0):
            raise ModelError(f"{name}: expected a positive number, got {v!r}")
    duration, rate = float(duration), float(rate)
    for name, v in (("harmonics", harmonics), ("grid", grid)):
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ModelError(f"{name}: expected a positive integer, got {v!r}")
    harmonics, grid = int(harmonics), int(grid)
    _check_ramp(ramp, rate)
    longest = (5.0 if isinstance(ramp, str) else 1.0 + 2.0 * float(ramp) / duration) * duration * rate
    if longest > limits.MAX_EXCITATION_SAMPLES:          # refused before minutes of optimisation
        raise limits.over_limit("ramp", "the number of samples", f"up to {longest:.0f} with the ramps "
                                f"({'auto: up to 2 periods each' if isinstance(ramp, str) else f'{ramp:g} s each'})",
                                "MAX_EXCITATION_SAMPLES")
    n, K = arm.n, int(harmonics)
    vmax, amax, lo, hi = motion_limits(arm, vmax, amax, margin)
    q0 = 0.5 * (lo + hi)
    samples = int(round(duration * rate))
    if base is None:
        base = base_parameters(arm, armature=armature, friction=friction)
    else:
        check_base(base, arm, armature, friction)
    for what, count in (("duration * rate", samples), ("grid", grid)):
        if count * n < base.count:
            raise ModelError(f"{what}: {count} samples give {count * n} equations, too few for the "
                             f"{base.count} base parameters (at least {-(-base.count // n)} samples needed)")
    if K / duration >= rate / 2:
        raise ModelError(f"harmonics: the highest harmonic, {K} / {duration:g} s = {K / duration:g} Hz, "
                         f"is at or above the Nyquist frequency of the samples, rate / 2 = {rate / 2:g} Hz, "
                         "and would alias; use fewer harmonics, a longer duration or a higher rate")
    if grid <= 2 * K:
        raise ModelError(f"grid: {grid} points per period cannot resolve {K} harmonics without "
                         f"aliasing; expected more than {2 * K}")
    tg = np.arange(grid) * (duration / grid)
    # the optimisation's regressor: Pinocchio's (4x faster per state here than the
    # trace form, and equal to it to rounding; benchmarks/bench_identification.py)
    fast = arm.pinocchio.regressor

    def reg(q, qd, qdd):
        return fast(q, qd, qdd, armature=armature, friction=friction)

    def unpack(x):
        x = np.asarray(x)
        a = x[..., :n * K].reshape(x.shape[:-1] + (n, K))
        b = x[..., n * K:].reshape(x.shape[:-1] + (n, K))
        return _feasible(q0, a, b, duration, vmax, amax, lo, hi)

    def cond(a, b, t, ramp):
        q, qd, qdd = ramped_trajectory(t, q0, a, b, duration, ramp)
        Y = base.regressor(arm.lagrange.regressor(q, qd, qdd, armature=armature, friction=friction))
        s = np.linalg.svd(Y.reshape(-1, base.count), compute_uv=False)
        return s[0] / s[-1] if s[-1] > 0 else np.inf

    PENALTY = 1e3                                       # log cond of a singular regressor

    def objective(x):
        value, grad = _log_cond_and_grad(reg, base, x, unpack, q0, duration, tg)
        if not math.isfinite(value):
            return PENALTY, np.zeros_like(x)
        return value, grad

    rng = np.random.default_rng(seed)
    x0 = rng.uniform(-1.0, 1.0, 2 * n * K) * np.tile(np.repeat(vmax, K), 2)
    done = [0]

    def callback(_x):
        done[0] += 1
        if progress is not None:
            progress(min(done[0], iterations), iterations)

    x = x0
    if iterations > 0:
        res = optimize.minimize(objective, x0, method="L-BFGS-B", jac=True, callback=callback,
                                options={"maxiter": int(iterations)})
        x = res.x if objective(res.x)[0] <= objective(x0)[0] else x0
    a, b = unpack(x)
    a, b, ramp = _with_ramp(a, b, duration, ramp, vmax, amax)
    if progress is not None:
        progress(iterations, iterations)
    t = np.arange(int(round((duration + 2 * ramp) * rate)) + (1 if ramp else 0)) / rate   # ends at rest
    q, qd, qdd = ramped_trajectory(t, q0, a, b, duration, ramp)
    return Excitation(q0=q0, a=a, b=b, period=float(duration), t=t, q=q, qd=qd, qdd=qdd,
                      condition_number=float(cond(a, b, t, ramp)), n_base=base.count, ramp=ramp)
