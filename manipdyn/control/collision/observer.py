"""The residuals a collision detector watches: the generalized-momentum observer and the direct residual.

Layer 6 (control: collision).

Both estimate the **external joint torque** ``tau_ext``, the torque that something other than the
drives applies to the arm (a force ``f`` at the tool gives ``tau_ext = J^T f``), N m (N for a
prismatic joint), so that with ``tau_meas`` the drives' measured torque::

    M(q) qdd + C(q, qd) qd + g(q) + tau_f(qd) = tau_meas + tau_ext

``M`` holds the rotor inertia and ``tau_f`` is the model's own friction law, as in every other
call (``arm.inverse_dynamics``).

* :func:`direct_residual`: ``tau_model(q, qd, qdd) - tau_meas``, sample by sample; it needs the
  acceleration, so its noise is the differentiated signal's.
* :func:`momentum_residual`: De Luca and Mattone's observer on ``p = M(q) qd``::

      r = K (p(t) - p(0) - integral of (tau_meas + C(q, qd)^T qd - g(q) - tau_f + r) dt)

  since ``dp/dt = tau_meas + tau_ext + C^T qd - g - tau_f``, ``dr/dt = K (tau_ext - r)``: a first-order
  follower of ``tau_ext`` with time constant ``1/K``, and no acceleration.  Offline it is evaluated
  as written, ``C^T qd`` from Pinocchio's ``computeCoriolisMatrix``, the integral by the trapezoid
  rule over each sample period, and the loop ``r' = K (x - r)`` discretized exactly for an input
  held over the period (``r_k = r_(k-1) + (1 - exp(-K dt)) (x_k - r_(k-1))``; forward Euler's
  ``K dt`` in place of ``1 - exp(-K dt)`` is unstable for ``K dt > 2``).
* :class:`MomentumObserver`: the same observer one sample at a time, for a controller's loop.  The
  momentum change over a period less the integral of ``C^T qd`` is, by ``dM/dt = C + C^T``,
  ``M (qd_k - qd_(k-1)) + integral of C qd dt`` (to second order in ``dt``), so each step is one
  inverse-dynamics call, ``tau_model(q_k, qd_k, (qd_k - qd_(k-1)) / dt)``, the engine's fast path with
  friction and rotors: the RNEA identity, no ``C`` matrix.  tests/test_collision.py holds it to the
  offline observer.

A noisy measured velocity: the output low-pass (``velocity_cutoff``)
--------------------------------------------------------------------
The observer differentiates the momentum ``M(q) qd``, and its first-order loop turns a derivative back
into the signal only below ``K``: velocity noise ``n`` above ``K / 2 pi`` reaches ``r`` as ``K M n``,
undamped.  That sets the thresholds of a real log whose ``qd`` is noisy above the motion's band (the
Panda's, resampled from rows the host stamped with jitter: its motion lies below 5 Hz, and its ``qd``
holds 1.4e-3 to 5.6e-3 rad/s RMS in each band from 10-20 to 200-500 Hz, docs/guide/collisions.md).  Two ways to filter:

* **``qd`` alone** through ``F(s) = w / (s + w)``: ``p = M F(qd)`` is no longer the momentum, and with
  the arm's dynamics the observer's input becomes ``tau_ext - M (1 - F) qdd`` (and the same lag in the
  friction and Coriolis terms): a model error, the high-passed acceleration, about ``M qddd / w``, with
  which ``r`` no longer tends to ``tau_ext``.  Measured: on synthetic logs (exact ``qd``) it raised the
  UR5's and Panda's thresholds by up to 8x at 20 Hz and gave false events; on the Panda's log it
  lowered joints 1-4 less than the next way.  Rejected.
* **``qd`` and ``tau`` alike**, which for the linear observer is the same low-pass on its output:
  ``r_f = F(r)``.  No model error (``r_f`` tends to ``tau_ext`` as ``r`` does); velocity noise reaches
  ``r_f`` as ``s K w M / (s + K)(s + w)``, falling as ``1 / f`` above both corners instead of staying at
  ``K M``; the torque sensors' noise is filtered too.  The price: a contact's torque reaches ``r_f``
  through two poles, ``K / (s + K) * w / (s + w)``.  (Filtering the measured ``tau`` and ``qd`` literally
  would leave ``g(q)`` unfiltered against a filtered ``tau``: another lag error; the output filter has none.)

This module does the second: with ``velocity_cutoff`` ``f_c`` > 0, ``r`` is followed by a causal first-order
low-pass at ``f_c`` Hz, ``w = 2 pi f_c``, discretized exactly for a held input
(``r_f,k = r_f,k-1 + (1 - exp(-w dt)) (r_k - r_f,k-1)``, ``r_f,0 = 0``), offline and online alike.  The
cut-off is set by the detection budget, not by the thresholds it gives: at the default gain (K = 100 1/s)
a contact at twice the threshold must be detected within 20 ms including the events' ``min_duration``
(5 ms).  Two poles of ``1/K`` and ``1/w`` reach half a step at ``t`` with
``1 - (K e^(-w t) - w e^(-K t)) / (K - w) = 1/2``: 15.0 ms for ``f_c`` = 20 Hz, so 20 Hz
(:data:`DEFAULT_VELOCITY_CUTOFF`; the budget is met exactly at 20.08 Hz, with the 1 ms of sampling
inside the margin of a contact above twice the threshold) is the lowest cut-off within budget; it lies 4x
above the Panda log's motion.  ``velocity_cutoff=0`` turns it off (``r`` as above, the first-order
follower).  Thresholds record the cut-off they were calibrated with, and
:func:`~manipdyn.control.collision.observe` refuses to compare a residual filtered otherwise with them.
"""

from __future__ import annotations

import math

import numpy as np

from ..._support.errors import ModelError
from ...identification.inputs.options import OptionError, brace_safe
from ...identification.uncertainty.thresholds import DEFAULT_GAIN, low_pass, positive

__all__ = ["MomentumObserver", "momentum_residual", "momentum_input", "observer_output", "direct_residual", "coriolis_transpose_qd", "check_gain",
           "check_velocity_cutoff", "output_low_pass", "DEFAULT_VELOCITY_CUTOFF"]

#: the output low-pass's cut-off by default, Hz (0: none; module docstring: the delay budget at K = 100 1/s)
DEFAULT_VELOCITY_CUTOFF = 20.0
#: samples per chunk of the offline observer's batched calls (memory: chunk * n * n floats)
CHUNK = 4096
_mul, _sub = np.multiply, np.subtract


def check_gain(gain) -> float:
    return positive(gain, "gain", "the observer's gain K in 1/s, a number > 0")


def check_velocity_cutoff(velocity_cutoff, dt=None) -> float:
    """The cut-off, Hz, of the observer's output low-pass (module docstring) as a float, 0 for none;
    None: :data:`DEFAULT_VELOCITY_CUTOFF`.  Below the Nyquist frequency ``0.5 / dt`` when ``dt`` is given."""
    if velocity_cutoff is None:
        velocity_cutoff = DEFAULT_VELOCITY_CUTOFF
    try:
        fc = float(velocity_cutoff)
    except (TypeError, ValueError):
        fc = math.nan
    if not (math.isfinite(fc) and fc >= 0):
        raise OptionError("{}: " + brace_safe(f"expected the cut-off of the observer's low-pass in Hz, a number "
                                              f"> 0 (0 or None: no filter), got {velocity_cutoff!r:.40}"),
                          "velocity_cutoff")
    if fc > 0 and dt is not None and fc >= 0.5 / float(dt):
        raise OptionError("{}: " + f"expected a cut-off below the Nyquist frequency {0.5 / float(dt):g} Hz "
                          f"of the samples, got {fc:g} Hz", "velocity_cutoff")
    return fc


def _velocity_alpha(fc: float, dt: float) -> float:
    return 1.0 - math.exp(-2.0 * math.pi * fc * dt) if fc > 0 else 1.0


def output_low_pass(r, dt: float, velocity_cutoff) -> np.ndarray:
    """``r`` (N, n) through the observer's causal first-order low-pass at ``velocity_cutoff`` Hz (module
    docstring), from rest (``r_f,0 = 0``: ``r_0`` is 0); ``r`` itself (float64) for 0 (None: the default)."""
    r = np.asarray(r, dtype=np.float64)
    fc = check_velocity_cutoff(velocity_cutoff, dt)
    return low_pass(r, dt, 2.0 * math.pi * fc) if fc > 0 else r       # the same held-input first order


def _dt(dt) -> float:
    return positive(dt, "dt", "the sample period in s, a number > 0")


def coriolis_transpose_qd(arm, q, qd) -> np.ndarray:
    """``C(q, qd)^T qd`` (N, n), N m: the momentum observer's Coriolis term (Pinocchio's
    ``computeCoriolisMatrix``, chunked).  ``q``, ``qd`` (N, n)."""
    eng = arm.engine("pinocchio")
    out = np.empty_like(q)
    for a in range(0, len(q), CHUNK):
        C = eng.coriolis_matrix(q[a:a + CHUNK], qd[a:a + CHUNK])
        out[a:a + CHUNK] = np.einsum("kji,kj->ki", C, qd[a:a + CHUNK])
    return out


def _friction(arm, qd) -> np.ndarray:
    return np.asarray(arm.engine("pinocchio").friction_torque(qd), dtype=np.float64).reshape(qd.shape)


def _states(q, qd, tau, n):
    q, qd, tau = (np.asarray(x, dtype=np.float64) for x in (q, qd, tau))
    for name, x in (("q", q), ("qd", qd), ("tau", tau)):
        if x.ndim != 2 or x.shape[1] != n:
            raise ModelError(f"{name}: expected shape (N, {n}), got {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ModelError(f"{name}: expected finite numbers")
    if not len(q) == len(qd) == len(tau):
        raise ModelError(f"q, qd, tau: expected the same number of samples, got {len(q)}, {len(qd)}, {len(tau)}")
    if len(q) < 2:
        raise ModelError("q: expected at least 2 samples")
    return q, qd, tau


def momentum_residual(arm, q, qd, tau, dt: float, gain: float = DEFAULT_GAIN,
                      velocity_cutoff: float | None = DEFAULT_VELOCITY_CUTOFF) -> np.ndarray:
    """The momentum observer's residual ``r`` (N, n), N m, on samples every ``dt`` s (module docstring).

    ``q`` (N, n) rad (m), ``qd`` (N, n) rad/s, ``tau`` (N, n) the measured joint torques, N m; ``gain``
    K, 1/s; ``velocity_cutoff``: Hz of the causal low-pass ``r`` goes through, against the measured
    velocity's noise (module docstring; 0: none, the first-order observer as written above; None: the
    default).
    ``r(0) = 0``: the observer starts at the first sample.
    """
    K, dt = check_gain(gain), _dt(dt)
    fc = check_velocity_cutoff(velocity_cutoff, dt)
    return observer_output(momentum_input(arm, q, qd, tau, dt), dt, K, fc)


def observer_output(x, dt: float, gain: float, velocity_cutoff) -> np.ndarray:
    """The residual (N, n), N m, from the observer's input ``x`` (:func:`momentum_input`): the loop at ``gain``
    K, 1/s, then the output low-pass at ``velocity_cutoff`` Hz (0: none).  One input serves every gain."""
    return output_low_pass(low_pass(x, dt, check_gain(gain)), dt, velocity_cutoff)


def momentum_input(arm, q, qd, tau, dt: float) -> np.ndarray:
    """The observer's input ``x`` (N, n), N m: the external torque over each sample period, ``dp/dt`` less the
    model's ``tau_meas + C^T qd - g - tau_f`` (trapezoid), 0 at the first sample; the residual is ``x``
    through the loop's first order (:func:`observer_output`)."""
    dt = _dt(dt)
    q, qd, tau = _states(q, qd, tau, arm.n)
    p = np.empty_like(q)
    for a in range(0, len(q), CHUNK):
        p[a:a + CHUNK] = np.einsum("kij,kj->ki", arm.mass_matrix(q[a:a + CHUNK]), qd[a:a + CHUNK])
    beta = tau + coriolis_transpose_qd(arm, q, qd) - arm.gravity_torque(q) - _friction(arm, qd)
    x = np.zeros_like(q)
    x[1:] = (p[1:] - p[:-1]) / dt - 0.5 * (beta[1:] + beta[:-1])     # tau_ext over each period
    return x


def direct_residual(arm, q, qd, qdd, tau) -> np.ndarray:
    """``tau_model(q, qd, qdd) - tau`` (N, n), N m: the external torque sample by sample, no filter."""
    q, qd, tau = _states(q, qd, tau, arm.n)
    qdd = np.asarray(qdd, dtype=np.float64)
    if qdd.shape != q.shape:
        raise ModelError(f"qdd: expected shape {q.shape}, got {qdd.shape}")
    return np.asarray(arm.inverse_dynamics(q, qd, qdd), dtype=np.float64) - tau


class MomentumObserver:
    """The momentum observer for a controller's loop: ``r = obs.update(q, qd, tau)`` every ``dt`` s.

    ``arm``: the model (friction law and rotor inertia included); ``dt``: the loop's period, s;
    ``gain``: K, 1/s (``r`` follows the external torque with time constant ``1/K``);
    ``velocity_cutoff``: Hz of the causal first-order low-pass on ``r`` against the measured velocity's
    noise, as in :func:`momentum_residual` (0: none).  Thresholds hold for the observer they were
    calibrated with: ``MomentumObserver(arm, dt, thr.gain, thr.velocity_cutoff)``.  Each
    :meth:`update` takes ``q``, ``qd``, ``tau`` as ``(n,)`` ndarrays of native float64 (rad or m,
    rad/s or m/s, N m or N) and returns the residual ``r`` (n,), N m, the estimated external joint
    torque (module docstring).  The first call starts the observer (``r = 0``).

    For the loop's rate, :meth:`update` allocates nothing of its own: ``r`` is the observer's own
    buffer, overwritten by the next call (copy it to keep it), and the inputs are not validated
    (like ``engine.unchecked``: a wrong dtype or length is the caller's error, a NaN propagates
    into ``r``, and :meth:`reset` clears it).  One call costs one ``arm.inverse_dynamics`` and a
    few array operations (benchmarks/bench_observer.py).
    """

    def __init__(self, arm, dt: float, gain: float = DEFAULT_GAIN,
                 velocity_cutoff: float | None = DEFAULT_VELOCITY_CUTOFF):
        self.dt, self.gain = _dt(dt), check_gain(gain)
        self.velocity_cutoff = check_velocity_cutoff(velocity_cutoff, self.dt)
        self.n = int(arm.n)
        eng = arm.engine("pinocchio")
        self._id = eng.unchecked.inverse_dynamics      # the engine's friction and rotors, no validation
        self._alpha = 1.0 - math.exp(-self.gain * self.dt)
        self._inv_dt = 1.0 / self.dt
        self._r = np.zeros(self.n)
        self._prev = np.zeros(self.n)         # qd_(k-1) / dt
        self._cur = np.zeros(self.n)
        self._acc = np.zeros(self.n)
        self._beta = _velocity_alpha(self.velocity_cutoff, self.dt)
        # with the low-pass, scaled states save an operation per call: u = r / alpha, v = r_f / (alpha beta),
        # u_k = (1 - alpha) u_(k-1) + y_k and v_k = (1 - beta) v_(k-1) + u_k, r_f = alpha beta v
        self._keep_u, self._keep_v = 1.0 - self._alpha, 1.0 - self._beta
        self._ab = self._alpha * self._beta
        self._u, self._v = np.zeros(self.n), np.zeros(self.n)
        self._rf = np.zeros(self.n)           # r through the output low-pass
        self._out = self._rf if self.velocity_cutoff > 0 else self._r
        self._started = False

    def reset(self) -> None:
        """Forget the past: the next :meth:`update` starts the observer again."""
        for x in (self._r, self._rf, self._u, self._v):
            x[:] = 0.0
        self._started = False

    @property
    def residual(self) -> np.ndarray:
        """The last residual (n,), N m (the buffer :meth:`update` returns)."""
        return self._out

    def update(self, q, qd, tau) -> np.ndarray:
        """One sample: the residual (n,), N m (the observer's buffer; class docstring)."""
        cur = self._cur
        _mul(qd, self._inv_dt, cur)           # qd_k / dt
        if not self._started:
            self._started = True
            self._prev, self._cur = cur, self._prev
            return self._out
        acc = self._acc
        _sub(cur, self._prev, acc)            # (qd_k - qd_(k-1)) / dt
        self._prev, self._cur = cur, self._prev
        y = self._id(q, qd, acc)              # tau_model(q, qd, dqd/dt): a new array of Pinocchio's
        y -= tau
        if self.velocity_cutoff > 0:          # the scaled states (__init__)
            u, v = self._u, self._v
            u *= self._keep_u
            u += y
            v *= self._keep_v
            v += u
            return _mul(v, self._ab, self._rf)
        r = self._r
        y -= r
        y *= self._alpha
        r += y
        return r

    def __repr__(self) -> str:
        vel = f" velocity_cutoff={self.velocity_cutoff:g} Hz"
        return f"<MomentumObserver n={self.n} dt={self.dt:g} s gain={self.gain:g} 1/s{vel}>"
