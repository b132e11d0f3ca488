"""Zero-phase filtering, derivatives and decimation of uniform joint samples.

Layer 2 (formats: logs).

The cut-off of the low-pass filter is chosen from the data
(:func:`choose_cutoff`) unless it is given:

* the power spectrum of q (each joint's record linearly detrended, Hann
  windowed, summed over the joints: the joints that move most weigh most,
  a joint at rest adds only its noise) has its white-noise floor (the median
  power over the top half of the band) removed;
* ``f99.99`` is the frequency below which 99.99 % of the remaining power,
  weighted by ``f^2``, lies: the band of the **velocity** (the spectrum of qd
  is ``(2 pi f)^2`` times q's), counted up to ``MAX_CUTOFF / CUTOFF_MARGIN``
  (no higher cut-off is ever used).  q's own power is not enough: a motion
  that stops and starts again has almost none of its power in the ramps,
  but its velocity and acceleration do, and a cut-off set by q alone
  (0.3 Hz x 3 for the hard log's standstills, clipped to 2 Hz) smooths the
  ramps away while the torques keep them.  The acceleration's ``f^4`` would
  be the stricter weight, but it lifts what is left of the noise after the
  floor is removed above the motion on real logs (the Panda log's reaches
  the top of the range), so the velocity is the weight the data can carry;
* 99.99 %, not 99.9 %: the last 0.1 % of the velocity's power is where a
  motion turns through v = 0, and friction (a smoothed sign, a Stribeck
  dip) changes fastest there.  Measured on the hard log
  (:mod:`~manipdyn.identification.experiments.hardlog`, seed 0): at 99.9 % (5.85 Hz) a
  motor's Stribeck level came out 8.8 % low, 23 of its standard deviations;
  at 99.99 % (8.85 Hz) every rotor and friction parameter is within 5 %.
  On the Panda log and on smooth motions the two agree (the 2 Hz floor);
  at 99.999 % the Panda's noise takes over (14.8 Hz);
* the cut-off is ``CUTOFF_MARGIN`` (3) times ``f99.99``: the filter (4th order
  Butterworth run twice, power gain ``1 / (1 + (f / fc)^8)``) then passes
  the motion's top frequency with 1.5e-4 relative error, so the filtering
  bias on qdd is far below the noise it removes;
* clipped to ``[MIN_CUTOFF, min(MAX_CUTOFF, rate / 5)]`` = [2, 50] Hz: below
  2 Hz the band is resolved by only a few spectral bins of a short
  record and the trimmed ends (``EDGE_TRIM / cutoff`` s each) grow past
  0.375 s;
  above 50 Hz, q holds structural vibration and noise that a rigid-body
  model cannot explain, and a cut-off near Nyquist filters nothing.

:func:`zero_phase` filters q (and a measured qd, when there is one) with
``scipy.signal.sosfiltfilt`` (second-order sections: stable at any ratio of
cut-off to rate, where the transfer-function form loses digits at 2 Hz of a
5 kHz log), differentiates at the full rate with second-order central
differences, drops ``EDGE_TRIM / cutoff`` s at each end (the edges, below)
and then **decimates** by ``D``
when the rate is far above what the motion needs: ``D = floor(rate /
max(10 cutoff, DECIMATED_MIN_RATE))``, so the kept rate is 10 to 20 times
the cut-off and never below 200 Hz.  After the filter there is nothing left
above the new Nyquist frequency to alias (the gain at 5 cut-offs is 1e-6),
and the derivatives were taken before decimating, so they keep the full
rate's accuracy.  The torques are not filtered (data.py says why), so their
decimation just keeps every D-th sample; their white noise averages out in
the least squares over the samples kept, which is why the kept rate has a
floor (200 Hz).  A 5 kHz log then costs the fit no more than a 500 Hz one.

Edges
-----
A zero-phase filter needs the signal beyond both ends, and whatever it is
given there leaks into the first and last samples through the tail of its
impulse response.  ``sosfiltfilt``'s own odd extension (``2 x0 - x(s)``,
the reflection about the end sample) continues the value, the slope and
every odd term about the end, but flips the curvature: qdd is pulled
towards zero near the ends.  Measured on band-limited motions (six sines
up to ``cutoff / 3``, the band the cut-off rule passes, 20 seeds, 1 kHz,
2 Hz cut-off), the worst qdd error, relative to qdd's RMS, is 32 % at
``0.5 / cutoff`` from the end, 9 % at ``1 / cutoff``, 0.5 % at
``2 / cutoff`` and 0.1 % at ``3 / cutoff``: the ``3 / cutoff`` s (1.5 s
at 2 Hz) that used to be dropped at each end.

So the continuation here (:func:`_extended`, ``EDGE_PAD / cutoff`` s of it)
is that odd reflection plus twice the even part of a degree-5 polynomial
fitted to the first (last) ``EDGE_FIT / cutoff`` s: it continues the value,
slope, curvature and the next two terms, so what is left to leak is the
motion's 6th-order behaviour.  On the same motions the worst qdd error is
then 0.3 % at ``0.75 / cutoff`` and 0.07 % at ``1 / cutoff`` with q noise
of 1e-5 rad (0.4 % and 0.15 % at 1e-4 rad; at 1e-3 rad, 1.2 % and 1.1 %,
against 0.45 % in the middle of the record from the noise itself).
``EDGE_TRIM / cutoff`` = 0.75 / cutoff s is dropped at each end (0.375 s
at 2 Hz: a 10 s log keeps 9.25 s).  A tapered correction and degrees 3, 4
and 6 were measured too, and were worse (the s^6 term amplifies the noise).
"""

from __future__ import annotations

import math

import numpy as np

from ..._support.errors import ModelError

__all__ = ["SPECTRUM_FRACTION", "CUTOFF_MARGIN", "MIN_CUTOFF", "MAX_CUTOFF", "DECIMATED_MIN_RATE",
           "EDGE_TRIM", "choose_cutoff", "zero_phase", "decimation_factor", "edge_samples", "velocity_noise"]

SPECTRUM_FRACTION = 0.9999
CUTOFF_MARGIN = 3.0
MIN_CUTOFF, MAX_CUTOFF = 2.0, 50.0
#: the decimated rate is at least 10 cut-offs and at least this, Hz
DECIMATED_MIN_RATE = 200.0
#: the edges (module docstring): dropped at each end, the fitted edge window and the continuation, in
#: periods of the cut-off (1 / cutoff s); the degree of the edge polynomial
EDGE_TRIM, EDGE_FIT, EDGE_PAD = 0.75, 1.0, 6.0
EDGE_DEGREE = 5


def choose_cutoff(q, rate: float):
    """``(cutoff, reason)``: the cut-off in Hz chosen from samples ``q`` (N, n) at ``rate`` Hz
    (module docstring), and one sentence saying how."""
    from ..._support.deps import require

    signal = require("scipy.signal", "choosing the filter's cut-off")
    q = np.asarray(q, dtype=np.float64)
    hi = min(MAX_CUTOFF, rate / 5.0)
    x = signal.detrend(q, axis=0) * np.hanning(len(q))[:, None]
    power = (np.abs(np.fft.rfft(x, axis=0)) ** 2).sum(axis=1)
    f = np.fft.rfftfreq(len(q), 1.0 / rate)
    top = f > rate / 4
    floor = float(np.median(power[top])) if top.any() else 0.0
    power = np.maximum(power - floor, 0.0)
    band = f <= MAX_CUTOFF / CUTOFF_MARGIN
    f, power = f[band], power[band] * f[band] ** 2          # the velocity's spectrum
    total = float(power.sum())
    if not total > 0:
        return hi, f"q does not move (no power above its noise floor): cut-off at the upper bound {hi:g} Hz"
    k = int(np.searchsorted(np.cumsum(power), SPECTRUM_FRACTION * total))
    f999 = float(f[min(k, len(f) - 1)])
    raw = CUTOFF_MARGIN * f999
    fc = min(max(raw, MIN_CUTOFF), hi)
    clip = "" if fc == raw else f", clipped to [{MIN_CUTOFF:g}, {hi:g}] Hz"
    return fc, (f"{SPECTRUM_FRACTION * 100:g} % of qd's power (q's, detrended, noise floor removed, times f^2) lies below "
                f"{f999:.3g} Hz; cut-off {CUTOFF_MARGIN:g} x that = {raw:.3g} Hz{clip}")


def decimation_factor(rate: float, cutoff: float) -> int:
    """``D = floor(rate / max(10 cutoff, DECIMATED_MIN_RATE))``, at least 1."""
    return max(1, int(math.floor(rate / max(10.0 * cutoff, DECIMATED_MIN_RATE))))


def _extended(x, pad: int, fit: int):
    """``x`` (N, ...) with ``pad`` samples of continuation prepended and appended (module docstring,
    "Edges"): the odd reflection about each end sample, plus twice the even part (the ``s^2`` and
    ``s^4`` terms) of a degree-``EDGE_DEGREE`` polynomial fitted to the ``fit`` samples at that end."""
    def left(y):
        s = np.arange(fit) / fit
        c = np.polynomial.polynomial.polyfit(s, y[:fit].reshape(fit, -1), EDGE_DEGREE)
        sp = (np.arange(1, pad + 1) / fit)[:, None]
        even = sum(2.0 * c[k] * sp ** k for k in range(2, EDGE_DEGREE + 1, 2))
        return (2.0 * y[:1] - y[1:pad + 1] + even.reshape((pad,) + y.shape[1:]))[::-1]

    return np.concatenate([left(x), x, left(x[::-1])[::-1]], axis=0)


def edge_samples(rate: float, cutoff: float) -> int:
    """Samples dropped at each end by :func:`zero_phase`: ``ceil(EDGE_TRIM rate / cutoff)``."""
    return int(math.ceil(EDGE_TRIM * rate / cutoff))


def zero_phase(t, q, cutoff: float, *, qd=None, others=(), decimate: int = 1, order: int = 4,
               where: str = "data"):
    """Filtered, differentiated, trimmed and decimated samples (module docstring).

    ``t`` (N,) uniform, s; ``q`` (N, n); ``qd`` (N, n) measured velocities or
    None (then derived from q); ``others``: arrays (N, ...) trimmed and
    decimated alike but not filtered (the torques).  ``cutoff`` Hz below
    Nyquist; ``decimate`` the factor D >= 1.

    Returns ``(t, q, qd, qdd, others)`` with ``EDGE_TRIM / cutoff`` s
    (:func:`edge_samples`) dropped at each end.
    """
    from ..._support.deps import require

    signal = require("scipy.signal", "deriving qd and qdd from q")
    dt = float(np.median(np.diff(t)))
    rate = 1.0 / dt
    fc = float(cutoff)
    if not (math.isfinite(fc) and 0 < fc < rate / 2):
        raise ModelError(f"{where}: cutoff: expected 0 < cutoff < {rate / 2:g} Hz (the Nyquist frequency "
                         f"of the {rate:g} Hz samples), got {fc:g}")
    if len(t) <= EDGE_PAD * rate / fc:       # checked as a float: 1e-300 Hz would need a 300-digit count
        raise ModelError(f"{where}: {len(t)} samples are too few to filter at {fc:g} Hz; that needs more than "
                         f"{EDGE_PAD / fc:.4g} s of samples; these allow cutoffs above "
                         f"{EDGE_PAD * rate / len(t):.4g} Hz")
    trim = edge_samples(rate, fc)
    fit = max(EDGE_DEGREE + 2, int(math.ceil(EDGE_FIT * rate / fc)))
    pad = int(math.ceil(EDGE_PAD * rate / fc))
    sos = signal.butter(order, fc / (rate / 2), output="sos")

    def smooth(x):
        x = np.asarray(x, dtype=np.float64)
        return signal.sosfiltfilt(sos, _extended(x, pad, fit), axis=0, padlen=0)[pad:pad + len(x)]

    qf = smooth(q)
    v = np.gradient(qf, dt, axis=0) if qd is None else smooth(qd)
    a = np.gradient(v, dt, axis=0)
    keep = slice(trim, len(t) - trim, max(1, int(decimate)))
    return t[keep], qf[keep], v[keep], a[keep], [np.asarray(o)[keep] for o in others]


def velocity_noise(t, q, qd, cutoff: float, decimate: int, q_kept, qd_kept) -> np.ndarray:
    """The velocity's noise level per joint (n,), rad/s (m/s), from what :func:`zero_phase` removed.

    ``t`` (N,), ``q``, ``qd`` (N, n): the samples given to :func:`zero_phase` (``qd`` None when
    derived); ``q_kept``, ``qd_kept``: what it returned from them at ``cutoff`` Hz and ``decimate``.  A measured qd: the RMS of ``qd - filtered qd`` over the kept samples (the
    per-sample noise of the logged velocity, its resolution included).  A derived qd: ``2 pi
    cutoff`` times the RMS of ``q - filtered q`` (the speed of a sine at the cut-off whose
    amplitude is q's noise: the finest speed the filtered derivative resolves).
    """
    trim = edge_samples(1.0 / float(np.median(np.diff(t))), cutoff)      # as zero_phase reads the rate
    keep = slice(trim, len(q) - trim, max(1, int(decimate)))
    if qd is not None:
        return np.sqrt(np.mean((np.asarray(qd, dtype=np.float64)[keep] - qd_kept) ** 2, axis=0))
    removed = np.asarray(q, dtype=np.float64)[keep] - q_kept
    return 2.0 * math.pi * float(cutoff) * np.sqrt(np.mean(removed**2, axis=0))
