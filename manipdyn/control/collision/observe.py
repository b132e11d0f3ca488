"""``md.observe``: a log's residuals against thresholds with a stated false-alarm rate, and its events.

Layer 6 (control: collision).

Where the thresholds come from, in this order (none: a :class:`ModelError`, never a silent default):

* ``threshold=`` given: per joint, N m (one number: every joint);
* ``calibrate=`` given: collision-free logs (or arrays) **the model was not fitted on**; the observer
  runs on them and :func:`~manipdyn.identification.uncertainty.thresholds.fit_thresholds` reads the
  thresholds off its residual for ``false_alarms`` per hour;
* ``fit_data=`` given: the log(s) the model was identified from, all of them; identify replayed from the
  trust record, its band's hold-outs (held-out trajectories, else blocks) each watched by the observer of
  the refit on the others (:mod:`manipdyn.control.collision.holdouts`);
* the model's trust record, key ``collision``, at the same gain (another rate is read off the stored
  tail, no data needed): ``manipdyn identify`` writes it by default, from the same hold-outs, and so do
  :func:`with_thresholds`, ``manipdyn observe --calibrate ... --save-model`` and ``--fit-data ... --save-model``.

A log is read nearly as logged, every sample kept (:mod:`manipdyn.control.collision.reading`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..._support.errors import ModelError
from ...identification.inputs.options import OptionError, brace_safe
from ...identification.uncertainty.thresholds import (DEFAULT_GAIN, DEFAULT_HYSTERESIS, DEFAULT_MIN_DURATION,
                                                      DEFAULT_RATE, CollisionThresholds, fit_thresholds)
from .events import detect_events
from .extrapolation import threshold_levels
from .gain import choose_gain
from .observer import (check_gain, check_velocity_cutoff, direct_residual, momentum_input, momentum_residual,
                       observer_output)
from .reading import Observed, read_observed

__all__ = ["observe", "calibrate_thresholds", "with_thresholds", "carried_thresholds", "resolve_thresholds",
           "TRUST_KEY"]

#: the trust record's key of the collision thresholds
TRUST_KEY = "collision"



def _residual(arm, obs: Observed, gain, velocity_cutoff) -> np.ndarray:
    return momentum_residual(arm, obs.q, obs.qd, obs.tau, obs.dt, gain, velocity_cutoff)


def calibrate_thresholds(arm, logs, gain: float | None = None, false_alarms: float = DEFAULT_RATE, *,
                         min_duration: float = DEFAULT_MIN_DURATION, hysteresis: float = DEFAULT_HYSTERESIS,
                         velocity_cutoff: float | None = None, **log_options) -> CollisionThresholds:
    """Thresholds from collision-free ``logs`` the model was not fitted on (paths or arrays, as
    :func:`observe` takes them), for ``false_alarms`` events per hour (the detector's, all joints), of the
    observer at ``gain`` 1/s (None: chosen on these logs for the smallest torque detected within 20 ms,
    :mod:`manipdyn.control.collision.gain`) with its output low-pass at ``velocity_cutoff`` Hz (None: the
    default, :data:`~manipdyn.control.collision.observer.DEFAULT_VELOCITY_CUTOFF`; 0: none), which the record
    keeps.  A log given twice is refused (it would count twice)."""
    K = None if gain is None else check_gain(gain)
    fc = check_velocity_cutoff(velocity_cutoff)
    _refuse_repeats(logs)
    parts = read_observed(arm, logs, **log_options)
    dts = [p.dt for p in parts]
    if max(dts) > 1.01 * min(dts):
        raise OptionError("{}: " + f"the logs' sample periods differ ({min(dts):.4g} to {max(dts):.4g} s); "
                          "resample them to one rate ({})", "calibrate", "resample")
    xs = [momentum_input(arm, p.q, p.qd, p.tau, p.dt) for p in parts]

    def at(k):
        res = [observer_output(x, p.dt, k, fc) for x, p in zip(xs, parts)]
        return fit_thresholds(np.vstack(res), dts[0], false_alarms, gain=k, min_duration=min_duration,
                              hysteresis=hysteresis, source="calibration logs " + ", ".join(p.label for p in parts),
                              velocity_cutoff=fc)

    return at(K) if K is not None else choose_gain(at)


def _refuse_repeats(logs) -> None:
    """Refuse a calibration log given twice (by its content's sha256, under any name): its residual would count
    twice, and the thresholds' stated rate of false events be off by the copies (identify refuses the same)."""
    import os

    from ...identification.results.provenance import file_sha256

    items = list(logs) if isinstance(logs, (list, tuple)) else [logs]
    seen = {}
    for item in items:
        if not isinstance(item, (str, os.PathLike)) or not os.path.isfile(item):
            continue                      # arrays, or a file the reader will name as missing
        sha = file_sha256(item)
        if sha in seen:
            raise OptionError("{}: " + brace_safe(f"{os.fspath(item)} holds the same data as {os.fspath(seen[sha])} "
                                                  "(sha256): a log counted twice makes the false-alarm rate "
                                                  "wrong; give each once"), "calibrate")
        seen[sha] = item


def carried_thresholds(arm) -> CollisionThresholds | None:
    """The thresholds in ``arm.trust`` (key ``collision``), or None."""
    rec = getattr(arm, "trust", None)
    if not isinstance(rec, dict) or rec.get(TRUST_KEY) is None:
        return None
    return CollisionThresholds.from_dict(rec[TRUST_KEY], arm.n, f"the model's trust record: key {TRUST_KEY!r}")


def with_thresholds(arm, thresholds: CollisionThresholds):
    """A shallow copy of ``arm`` whose trust record holds ``thresholds`` (``md.save`` writes it)."""
    import copy

    from ...formats.trust import TRUST_FORMAT

    out = copy.copy(arm)
    # the trust record does not touch the dynamics: the engines built so far serve the copy too (an empty
    # cache would leave the arm's bound fast-path calls, Arm.set_engine, on the old engine beside a new one)
    out._engines = dict(arm._engines)
    rec = dict(getattr(arm, "trust", None) or {"format": TRUST_FORMAT})
    rec[TRUST_KEY] = thresholds.to_dict()
    out.trust = rec
    return out


def _explicit(threshold, n, gain, rate, min_duration, hysteresis, velocity_cutoff) -> CollisionThresholds:
    T = np.atleast_1d(np.asarray(threshold, dtype=np.float64)).reshape(-1)
    if len(T) == 1:
        T = np.full(n, T[0])
    if len(T) != n or not np.all(np.isfinite(T)) or np.any(T <= 0):
        got = ", ".join(f"{x:g}" for x in T[:12]) + (", ..." if len(T) > 12 else "")
        raise OptionError("{}: " + brace_safe(f"expected 1 or {n} numbers > 0 (N m per joint), got [{got}]"),
                          "threshold")
    return CollisionThresholds(T, rate, gain, min_duration, hysteresis, 1.0, np.zeros(n), np.zeros(n), T,
                               "given (threshold=)", velocity_cutoff)


def resolve_thresholds(arm, gain, false_alarms, calibrate, threshold, min_duration, hysteresis, log_options,
                       fit_data=None, velocity_cutoff=None):
    """The :class:`CollisionThresholds` of :func:`observe` (module docstring), or a refusal; ``log_options``
    are the calibration logs' reading options.  ``velocity_cutoff`` (Hz; None: the carried thresholds' own,
    else the default) is the cut-off of the observer's output low-pass the thresholds are for; the returned record's
    ``velocity_cutoff`` and ``gain`` are the ones to watch with.  ``gain`` None: the carried thresholds' own,
    else chosen on the calibration data or hold-outs (:mod:`manipdyn.control.collision.gain`), else (numbers
    given) :data:`DEFAULT_GAIN`."""
    gain = None if gain is None else check_gain(gain)
    for name, v, ok in (("min_duration", min_duration, lambda x: x >= 0), ("hysteresis", hysteresis,
                                                                          lambda x: 0 <= x < 1)):
        try:
            good = np.isfinite(float(v)) and ok(float(v))
        except (TypeError, ValueError):
            good = False
        if not good:
            raise OptionError("{}: expected " + ("seconds >= 0" if name == "min_duration" else
                                                 "a fraction in [0, 1) of the threshold") + brace_safe(f", got {v!r:.40}"),
                              name)
    if isinstance(threshold, CollisionThresholds):        # a record resolved already (the CLI's)
        return replace(threshold, min_duration=min_duration, hysteresis=hysteresis)
    if threshold is not None:
        return _explicit(threshold, arm.n, DEFAULT_GAIN if gain is None else gain, false_alarms, min_duration,
                         hysteresis,
                         check_velocity_cutoff(velocity_cutoff))
    if calibrate is not None:
        return calibrate_thresholds(arm, calibrate, gain, false_alarms, min_duration=min_duration,
                                    hysteresis=hysteresis, velocity_cutoff=velocity_cutoff, **log_options)
    if fit_data is not None:
        from .holdouts import held_out_thresholds

        return held_out_thresholds(arm, fit_data, gain, false_alarms, min_duration=min_duration,
                                   hysteresis=hysteresis, velocity_cutoff=velocity_cutoff)
    carried = carried_thresholds(arm)
    if carried is None:
        raise OptionError("thresholds: the model carries no collision thresholds (its trust record has no "
                          f"{TRUST_KEY!r} key); give {{}} (collision-free logs the model was not fitted on), {{}} (the "
                          "logs it was identified from, for the band's hold-outs; manipdyn identify writes these by "
                          "default) or {} (N m per joint)", "calibrate", "fit_data", "threshold")
    if gain is not None and abs(carried.gain - gain) > 1e-9 * gain:
        raise OptionError("{}: " + f"the model's thresholds are for gain {carried.gain:g} 1/s, not {gain:g}; use that "
                          "gain, or {} / {} for this one", "gain", "calibrate", "threshold")
    if velocity_cutoff is not None:
        fc = check_velocity_cutoff(velocity_cutoff)
        if abs(fc - carried.velocity_cutoff) > 1e-9 * (1.0 + carried.velocity_cutoff):
            def with_(x):
                return f"with its output low-pass at {x:g} Hz" if x > 0 else "with no output low-pass (0)"

            raise OptionError("{}: " + brace_safe(f"the model's thresholds are for the observer "
                                                  f"{with_(carried.velocity_cutoff)}, not {with_(fc)} (a residual "
                                                  "filtered otherwise has other noise)") + "; use that cut-off, or "
                              "{} / {} for this one", "velocity_cutoff", "calibrate", "fit_data")
    out = carried.for_rate(false_alarms)
    return replace(out, min_duration=min_duration, hysteresis=hysteresis,
                   source=out.source or "the model's trust record")


def observe(arm, log_or_arrays, gain: float | None = None, *, false_alarms: float = DEFAULT_RATE, calibrate=None,
            threshold=None, min_duration: float = DEFAULT_MIN_DURATION, hysteresis: float = DEFAULT_HYSTERESIS,
            direct: bool = True, wrench: bool = True, calibrate_t_range=None, fit_data=None,
            velocity_cutoff: float | None = None, **log_options) -> "ObserveResult":
    """Watch a log for collisions: residuals, thresholds and events (module docstring).

    ``log_or_arrays``: a log path (CSV, bag), a list of them, or arrays (a dict or an object with ``t``
    (N,) s, uniform; ``q``, ``qd``, ``tau`` (N, n); optionally ``qdd``).  ``gain``: the momentum observer's
    K, 1/s (None: the carried thresholds' own, else chosen on the calibration data or hold-outs for the
    smallest torque detected within 20 ms, :mod:`manipdyn.control.collision.gain`, else 100).  ``false_alarms``: false events per hour the thresholds allow (all joints together).
    ``calibrate``: collision-free logs or arrays for the thresholds; ``threshold``: N m per joint (or a
    :class:`CollisionThresholds` record, used as it is).
    ``fit_data``: the log, or list of logs, the model was identified from (its trust record checks the
    sha256): thresholds from the band's hold-outs of them (:mod:`manipdyn.control.collision.holdouts`).
    ``calibrate_t_range``: ``(t0, t1)`` s (or ``"T0:T1"``) of the calibration logs, in place of ``t_range``
    (one file cut into a calibration window and a watched window).  ``velocity_cutoff``: Hz of the
    observer's causal low-pass against the measured velocity's noise (:mod:`manipdyn.control.collision.observer`; 0:
    none; None: the carried thresholds' own, else
    :data:`~manipdyn.control.collision.observer.DEFAULT_VELOCITY_CUTOFF`); thresholds carried for another
    cut-off are refused, as for another gain.
    ``min_duration`` s and ``hysteresis`` define an event (:mod:`manipdyn.control.collision.events`).  ``direct``: also the
    direct residual (needs ``qdd``).  ``log_options``: :func:`~manipdyn.identification.read_log`'s.
    Returns :class:`ObserveResult`; raises :class:`ModelError` when no thresholds can be had.
    """
    from .report import ObserveResult

    cal_options = dict(log_options, t_range=calibrate_t_range) if calibrate_t_range is not None else log_options
    thr = resolve_thresholds(arm, gain, false_alarms, calibrate, threshold, min_duration, hysteresis, cal_options,
                             fit_data, velocity_cutoff)
    K = thr.gain
    runs, levels = [], []
    for obs in read_observed(arm, log_or_arrays, **log_options):
        r = _residual(arm, obs, K, thr.velocity_cutoff)
        d = direct_residual(arm, obs.q, obs.qd, obs.qdd, obs.tau) if direct and obs.qdd is not None else None
        lag = 1.0 / K + (1.0 / (2.0 * np.pi * thr.velocity_cutoff) if thr.velocity_cutoff > 0 else 0.0)
        T, _ = threshold_levels(thr, arm, obs.q, obs.qd, obs.dt)      # (n,), or (N, n) where they scale
        ev = detect_events(arm, obs.t, obs.q, r, T, thr.min_duration, thr.hysteresis, wrench=wrench, lag=lag)
        runs.append((obs, r, d, ev))
        levels.append(T)
    return ObserveResult(arm=arm, thresholds=thr, runs=runs, levels=levels)
