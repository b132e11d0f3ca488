"""Collision thresholds with a stated false-alarm rate, from residuals of collision-free held-out data.

Layer 5 (identification).

A collision detector compares a residual ``r`` (N, n) (the momentum observer's or the direct
one, N m; :mod:`manipdyn.control.collision`) with a threshold per joint.  On data the model
was not fitted on and where nothing was touched, every crossing is a false alarm, so the
thresholds are read off such data (the band's blocked hold-outs, :mod:`.bands`, or the
user's calibration logs) for a stated rate of false events per hour.

What an event is
----------------
Joint j *crosses* while ``|r_j| > T_j``.  An event starts when some joint has crossed for at
least ``min_duration`` seconds without a break, and ends when every joint is back below
``hysteresis * T_j`` (hysteresis: a residual hovering about the threshold is one event, not
many).  :func:`sustained` gives the signal whose plain crossings are these events:
``s_j(t) = min |r_j|`` over the last ``min_duration``.

From a few minutes of data to a rate per hour
---------------------------------------------
``N_j(u)``, the number of events of joint j alone at a level ``u`` in ``H`` hours of data, falls
as ``u`` grows.  A rate of ``rho`` per hour asked for, shared equally between the ``n`` joints
(any joint's event is the detector's event), needs ``N_j(T_j) / H <= rho / n``.  When the data
are shorter than ``n / rho`` hours no level is seen that rarely, and the tail is extrapolated:
``ln N_j(u) = a_j - b_j u`` (peaks over a threshold): from the lowest level ``u0`` crossed at most 30
times, the events above ``u0`` and their peaks' mean excess ``beta`` (the maximum-likelihood scale of
an exponential tail), ``N_j(u) = N_j(u0) exp(-(u - u0) / beta)``.  An exponential tail is the
generalized Pareto tail with zero shape; a Gaussian residual's tail falls faster (``ln N ~ -u^2``),
so on noise the extrapolation errs on the high side.  The threshold is the larger of the extrapolated level and the highest level
the data crossed (at least one level above every event seen).  The record keeps ``a``, ``b``,
``H`` and the highest level, so another rate needs no data (:meth:`CollisionThresholds.for_rate`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..._support.errors import ModelError

__all__ = ["CollisionThresholds", "sustained", "count_events", "event_peaks", "fit_thresholds", "DEFAULT_MIN_DURATION",
           "DEFAULT_HYSTERESIS", "DEFAULT_RATE", "DEFAULT_GAIN", "low_pass", "leverage_factor"]

#: seconds a crossing must last to be an event
DEFAULT_MIN_DURATION = 0.005
#: an event ends when every joint is below this fraction of its threshold
DEFAULT_HYSTERESIS = 0.5
#: false events per hour asked for by default
DEFAULT_RATE = 1.0
#: the momentum observer's gain K, 1/s: ``r`` follows the external torque with time constant 1/K
DEFAULT_GAIN = 100.0
#: the upper tail fitted: levels crossed between 1 and this many times
TAIL_COUNTS = 30


def low_pass(x, dt: float, gain: float) -> np.ndarray:
    """``x`` (N, n) through ``r' = K (x - r)``, ``r(0) = 0``, discretized exactly for a held input
    (``r_k = r_(k-1) + (1 - exp(-K dt)) (x_k - r_(k-1))``): what the momentum observer makes of an
    external torque ``x`` (:mod:`manipdyn.control.collision.observer`)."""
    from scipy.signal import lfilter

    a = 1.0 - math.exp(-float(gain) * float(dt))
    return lfilter([a], [1.0, a - 1.0], np.asarray(x, dtype=np.float64), axis=0)


def sustained(residual, dt: float, min_duration: float = DEFAULT_MIN_DURATION) -> np.ndarray:
    """``s`` (N, n): ``min |r_j|`` over the last ``ceil(min_duration / dt)`` samples (the first ones: over
    what there is), so ``s_j > T`` exactly where ``|r_j| > T`` has lasted ``min_duration``."""
    from numpy.lib.stride_tricks import sliding_window_view

    r = np.abs(np.asarray(residual, dtype=np.float64))
    # a window longer than the data: the same as the data's length (every sample sees back to the first)
    m = max(1, int(min(math.ceil(min(float(min_duration) / float(dt), 1e15) - 1e-9), max(len(r), 1))))
    if m == 1:
        return r
    padded = np.concatenate([np.repeat(r[:1], m - 1, axis=0), r])
    return sliding_window_view(padded, m, axis=0).min(axis=-1)      # sample k sees k-m+1..k


def event_peaks(s, level, hysteresis: float = DEFAULT_HYSTERESIS) -> np.ndarray:
    """The peak of ``s`` (N,) in each event at ``level`` (a rise above ``level`` that starts after ``s``
    fell below ``hysteresis * level``; an event lasts until the next such fall)."""
    s = np.asarray(s, dtype=np.float64)
    above, low = s > level, s < hysteresis * level
    peaks, inside, peak = [], False, 0.0
    idx = np.flatnonzero(above | low)
    for k in idx:                               # only the marked samples: few where the level is high
        if above[k]:
            if not inside:
                inside, peak = True, s[k]
            else:
                peak = max(peak, s[k])
        elif inside:
            peaks.append(peak)
            inside = False
    if inside:
        peaks.append(peak)
    return np.asarray(peaks)


def count_events(s, level, hysteresis: float = DEFAULT_HYSTERESIS) -> int:
    """Events of one joint's sustained signal ``s`` (N,) at ``level``: rises above ``level`` that start
    after ``s`` fell below ``hysteresis * level``."""
    s = np.asarray(s, dtype=np.float64)
    above = s > level
    if not np.any(above):
        return 0
    low = s < hysteresis * level
    mark = np.where(above, 1, np.where(low, -1, 0))
    states = mark[np.flatnonzero(mark)]
    return int(np.sum((states[1:] == 1) & (states[:-1] == -1)) + (states[0] == 1))


def leverage_factor(gain, u) -> np.ndarray:
    """``sqrt((1 + g u) / (1 + g))`` (N, n): a threshold's factor at leverage ratios ``u`` (N, n, negative read as
    0) for gains ``g`` (n,); 1 at ``u = 1``, the typical fitted sample."""
    g = np.asarray(gain, dtype=np.float64)
    return np.sqrt((1.0 + g * np.maximum(np.asarray(u, dtype=np.float64), 0.0)) / (1.0 + g))


@dataclass(frozen=True)
class CollisionThresholds:
    """Per-joint thresholds ``threshold`` (n,), N m (N), for ``false_alarms_per_hour`` (the detector's, all
    joints together), with what they came from: ``gain`` (1/s, the observer's K; 0 for the direct
    residual), ``min_duration`` (s), ``hysteresis``, ``hours`` of calibration data, the tail
    ``ln N(u) = a - b u`` per joint (``tail_a``, ``tail_b``), ``observed_max`` (n,) the highest
    sustained level seen, ``source`` (text) and ``velocity_cutoff`` (Hz, the observer's output low-pass,
    :mod:`manipdyn.control.collision.observer`; 0: none): a residual is compared with them only when it
    comes from the same observer (the same gain and low-pass).

    ``leverage_gain`` (n,) or None: with it, joint j's threshold on a sample is
    ``threshold_j sqrt((1 + g_j u_j) / (1 + g_j))`` (:meth:`levels`, ``g`` the ``leverage_gain``), ``u_j`` the
    sample's leverage ratio against the fit data (:mod:`.leverage`; 1 on a typical fitted sample): the thresholds
    are lower where the state stays within what the fit saw and higher where it leaves it
    (:mod:`manipdyn.control.collision.extrapolation`).  ``threshold`` is always the level at a typical fitted
    sample (``u = 1``, as a prediction band's ``half_width``), so a loop that reads ``threshold`` alone reads the
    typical level; the tail and ``observed_max`` are those of the residual divided by the same factor."""

    threshold: np.ndarray
    false_alarms_per_hour: float
    gain: float
    min_duration: float
    hysteresis: float
    hours: float
    tail_a: np.ndarray
    tail_b: np.ndarray
    observed_max: np.ndarray
    source: str = ""
    velocity_cutoff: float = 0.0
    leverage_gain: np.ndarray | None = None

    def __post_init__(self):
        for k in ("threshold", "tail_a", "tail_b", "observed_max", "leverage_gain"):
            if getattr(self, k) is None:
                continue
            a = np.asarray(getattr(self, k), dtype=np.float64).reshape(-1)
            if not np.all(np.isfinite(a)) or (k == "leverage_gain" and (a.shape != self.threshold.shape
                                                                          or np.any(a < 0))):
                raise ModelError(f"collision thresholds: {k}: expected finite numbers"
                                 + (" >= 0, one per joint" if k == "leverage_gain" else "") + f", got {a.tolist()}")
            a.setflags(write=False)
            object.__setattr__(self, k, a)
        if self.leverage_gain is not None and not np.any(self.leverage_gain > 0):
            object.__setattr__(self, "leverage_gain", None)      # all zero: the constant thresholds
        if np.any(self.threshold <= 0):
            raise ModelError(f"collision thresholds: threshold: expected numbers > 0, got {self.threshold.tolist()}")
        for name, ok in (("false_alarms_per_hour", self.false_alarms_per_hour > 0), ("hours", self.hours > 0),
                         ("hysteresis", 0 <= self.hysteresis < 1), ("min_duration", self.min_duration >= 0),
                         ("gain", self.gain >= 0), ("velocity_cutoff", self.velocity_cutoff >= 0)):
            if not ok:
                raise ModelError(f"collision thresholds: {name}: expected " + {
                    "hysteresis": "a fraction in [0, 1)", "min_duration": "seconds >= 0", "gain": "1/s >= 0",
                    "velocity_cutoff": "Hz >= 0 (0: no filter)"}.get(
                        name, "a number > 0") + f", got {getattr(self, name)!r}")

    @property
    def n(self) -> int:
        return len(self.threshold)

    @property
    def scales_with_leverage(self) -> bool:
        """Whether some joint's threshold grows with the leverage ratio (``leverage_gain`` > 0 there)."""
        return self.leverage_gain is not None

    def levels(self, u=None) -> np.ndarray:
        """The thresholds in effect, N m: ``threshold_j sqrt((1 + g_j u_j) / (1 + g_j))`` (N, n) at the leverage
        ratios ``u`` (N, n) of :mod:`.leverage` (``threshold`` itself, (n,), with ``u`` None or no gain)."""
        if u is None or self.leverage_gain is None:
            return np.asarray(self.threshold)
        return self.threshold * leverage_factor(self.leverage_gain, u)

    @property
    def given(self) -> bool:
        """Thresholds given as numbers (no tail: every ``tail_b`` is 0): the same at every rate."""
        return bool(np.all(self.tail_b == 0))

    def for_rate(self, rate: float) -> "CollisionThresholds":
        """The same record at another rate of false events per hour (the stored tail; no data needed); at
        the record's own rate, the stored thresholds themselves."""
        rate = _rate(rate)
        if self.given or rate == self.false_alarms_per_hour:
            return replace(self, false_alarms_per_hour=rate)
        T = _levels(self.tail_a, self.tail_b, self.observed_max, self.hours, rate, self.n)
        return replace(self, threshold=T, false_alarms_per_hour=rate)

    def to_dict(self) -> dict:
        """The record as the trust record's ``collision`` key holds it (JSON-ready)."""
        return {"threshold": [float(x) for x in self.threshold],
                "false_alarms_per_hour": float(self.false_alarms_per_hour), "gain": float(self.gain),
                "min_duration": float(self.min_duration), "hysteresis": float(self.hysteresis),
                "hours": float(self.hours), "tail_a": [float(x) for x in self.tail_a],
                "tail_b": [float(x) for x in self.tail_b],
                "observed_max": [float(x) for x in self.observed_max], "source": str(self.source),
                "velocity_cutoff": float(self.velocity_cutoff),
                **({} if self.leverage_gain is None else {"leverage_gain": [float(x) for x in self.leverage_gain]})}

    @classmethod
    def from_dict(cls, value, n: int, where: str) -> "CollisionThresholds":
        """The record of a trust record's ``collision`` key, checked: every per-joint field ``n`` numbers,
        every scalar a number (not a boolean or a string), and ``threshold`` the stored tail's own level at
        the stored rate (an edited threshold with the tail left alone is refused, never silently
        recomputed); ``where`` names the record in the errors."""
        if not isinstance(value, dict):
            raise ModelError(f"{where}: expected an object with threshold, false_alarms_per_hour, gain, ...")
        missing = [k for k in _FIELDS if k not in value]
        if missing:
            raise ModelError(f"{where}: malformed collision thresholds (missing {', '.join(missing)})")
        arrays = {k: _numbers(value[k], n, f"{where}: {k}") for k in ("threshold", "tail_a", "tail_b", "observed_max")}
        scalars = {k: _number(value.get(k, 0.0), f"{where}: {k}")       # no velocity_cutoff: records before it
                   for k in ("false_alarms_per_hour", "gain", "min_duration", "hysteresis", "hours", "velocity_cutoff")}
        try:
            out = cls(arrays["threshold"], scalars["false_alarms_per_hour"], scalars["gain"], scalars["min_duration"],
                      scalars["hysteresis"], scalars["hours"], arrays["tail_a"], arrays["tail_b"],
                      arrays["observed_max"], str(value.get("source", "")), scalars["velocity_cutoff"],
                      None if value.get("leverage_gain") is None else _numbers(value["leverage_gain"], n,
                                                                                f"{where}: leverage_gain"))
        except ModelError as exc:
            raise ModelError(f"{where}: {exc}") from None
        if not out.given:
            T = _levels(out.tail_a, out.tail_b, out.observed_max, out.hours, out.false_alarms_per_hour, n)
            if not np.allclose(out.threshold, T, rtol=1e-6, atol=0.0):
                raise ModelError(f"{where}: threshold {_short(out.threshold)} is not the level of the record's own "
                                 f"tail (tail_a, tail_b, observed_max, hours) at {out.false_alarms_per_hour:g} false "
                                 f"events per hour, {_short(T)}: the record's parts disagree (edited?); "
                                 "recalibrate (observe --calibrate/--fit-data --save-model) or give --threshold")
        return out


#: the fields a stored record must have
_FIELDS = ("threshold", "false_alarms_per_hour", "gain", "min_duration", "hysteresis", "hours", "tail_a", "tail_b",
           "observed_max")


def _short(x) -> str:
    return "[" + ", ".join(f"{v:.4g}" for v in np.asarray(x).reshape(-1)) + "]"


def _number(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ModelError(f"{where}: expected a number, got {value!r:.60}")
    try:
        return float(value)
    except (OverflowError, ValueError):
        raise ModelError(f"{where}: expected a number within float range") from None


def _numbers(value, n: int, where: str) -> np.ndarray:
    if not isinstance(value, (list, tuple, np.ndarray)) or len(value) != n:
        raise ModelError(f"{where}: expected a list of {n} numbers (one per joint), got {value!r:.80}")
    return np.array([_number(v, f"{where}[{k}]") for k, v in enumerate(value)], dtype=np.float64)


def positive(value, name: str, what: str) -> float:
    """``value`` as a finite float > 0, else a :class:`ModelError` "``name``: expected ``what``, got ..."."""
    from ..inputs.options import OptionError, brace_safe

    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        x = math.nan
    if not (math.isfinite(x) and x > 0):          # str(): the keyword; cli_message(): --the-flag
        raise OptionError("{}: " + brace_safe(f"expected {what}, got {value!r:.60}"), name)
    return x


def _rate(rate) -> float:
    return positive(rate, "false_alarms", "a rate of false events per hour > 0")


def _levels(a, b, top, hours, rate, n) -> np.ndarray:
    """The threshold per joint: the extrapolated tail's level for ``rate / n`` events per hour and joint in
    ``hours`` and never below the highest level seen (module docstring).  In logarithms, so a rate or
    ``hours`` as small as 5e-324 gives a (high) level, not ``log(0)``."""
    target = math.log(rate) - math.log(n) + math.log(hours)      # ln N at the threshold
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        T = np.where(np.asarray(b) > 0, (np.asarray(a) - target) / np.maximum(b, 1e-300), np.inf)
    T = np.where(np.isfinite(T), T, 2.0 * np.asarray(top))
    return np.maximum(T, np.asarray(top) * (1.0 + 1e-9)) if target < 0 else np.maximum(T, 1e-12)


def _period(dt) -> float:
    """``dt`` (s) as a float, or a ModelError: a sample period is a finite number > 0 (0 divided)."""
    try:
        out = float(dt)
    except (TypeError, ValueError, OverflowError):
        out = float("nan")
    if isinstance(dt, bool) or not (np.isfinite(out) and out > 0):
        raise ModelError(f"dt: expected the sample period in s, a finite number > 0, got {dt!r:.40}")
    return out


def fit_thresholds(residual, dt: float, rate: float = DEFAULT_RATE, *, gain: float = DEFAULT_GAIN,
                   min_duration: float = DEFAULT_MIN_DURATION, hysteresis: float = DEFAULT_HYSTERESIS,
                   source: str = "", velocity_cutoff: float = 0.0) -> CollisionThresholds:
    """:class:`CollisionThresholds` from the residual ``residual`` (N, n), N m, of collision-free data the
    model was not fitted on, sampled every ``dt`` seconds (module docstring).  ``gain`` and ``velocity_cutoff``
    (Hz) are recorded (the residual must already be the observer's at that gain and low-pass).  Raises :class:`ModelError` for fewer than
    100 samples or a non-finite residual."""
    r = np.asarray(residual, dtype=np.float64)
    if r.ndim != 2 or len(r) < 100:
        raise ModelError(f"calibration data: expected at least 100 samples (N, n) of collision-free residuals, "
                         f"got shape {r.shape}")
    if not np.all(np.isfinite(r)):
        raise ModelError("calibration data: the residual is not finite")
    rate = _rate(rate)
    dt = _period(dt)
    s = sustained(r, dt, min_duration)
    hours = len(r) * float(dt) / 3600.0
    n = r.shape[1]
    a, b, top = np.zeros(n), np.zeros(n), s.max(axis=0)
    for j in range(n):
        sj = s[:, j]
        levels = np.quantile(sj, np.linspace(0.5, 1.0, 80, endpoint=False)[1:])
        levels = np.unique(np.concatenate([levels, np.linspace(levels[0], top[j], 40, endpoint=False)]))
        counts = np.array([count_events(sj, u, hysteresis) for u in levels])
        tail = np.flatnonzero((counts >= 1) & (counts <= TAIL_COUNTS))
        u0 = float(levels[tail[0]]) if len(tail) else float(top[j])
        excess = event_peaks(sj, u0, hysteresis) - u0
        n0 = max(len(excess), 1)
        beta = float(np.mean(excess)) if len(excess) and np.mean(excess) > 0 else 0.0
        if not beta > 0:           # no tail seen: one e-fold per RMS of s above the top
            beta = float(np.sqrt(np.mean(sj ** 2))) or 1e-12
        # peaks over the threshold u0: exceedances of an exponential tail, scale = their mean excess (MLE)
        b[j] = 1.0 / beta
        a[j] = math.log(n0) + u0 * b[j]
    T = _levels(a, b, top, hours, rate, n)
    return CollisionThresholds(T, rate, float(gain), float(min_duration), float(hysteresis), hours, a, b, top,
                               source, float(velocity_cutoff or 0.0))
