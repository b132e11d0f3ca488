"""Time stamps of a log: repeated rows, gaps, and a uniform grid.

Layer 2 (formats: logs).

Real logs are stamped by the host that records them, not by the robot's
clock: the steps jitter, samples are dropped (gaps) and a sample is logged
twice when the host polls faster than the robot publishes.  The zero-phase
filter and the differences of :mod:`~manipdyn.formats.logs.filtering`
need uniform samples, so :func:`uniform_samples`

1. refuses time that goes back, naming the file row;
2. drops *repeated rows*: a row whose values (every column but ``t``) equal
   the previous row's exactly is the same sample logged again (a real
   sensor's noise never repeats all its digits), and keeps the first time
   stamp, the one closest to when the sample was taken.  Noiseless
   synthetic data at rest repeats rows too.  A repeated row whose *measured
   velocities* are all exactly zero is kept: it is a sample of an arm at rest
   (the same sample logged again while the arm moves repeats a velocity that
   is not zero; the real Panda log's 1131 repeated rows all do), and dropping
   the rows of poses held still would leave one sample per pose, the jumps
   between them read as motion;
3. finds *gaps*: steps over 1.5 times the median step (the median of the
   steps that are not gaps is the step of the grid);
4. checks that the median rate is plausible for a joint log (2 Hz to
   100 kHz), which catches ``t`` in milliseconds or nanoseconds;
5. resamples onto a uniform grid at the median rate (or at ``resample`` Hz)
   unless the steps are already uniform (within 0.1 %) and no other rate
   is asked for, in which case the samples are kept exactly as they are.

Interpolation is **linear**, for q, qd, qdd and tau alike, before any
filtering.  Linear interpolation never overshoots (a 9 ms gap inside a
motion is bridged by a chord, not by a spline's swing), stays local (one
bad sample cannot ring across the record) and keeps the Coulomb-friction
step of tau as sharp as the samples have it.  Its error, ``h^2 |q''| / 8``
for a step ``h``, is 1.3e-6 rad at 1 kHz with q'' = 10 rad/s^2, below
encoder resolution, and its kinks carry energy only at high frequencies,
which the low-pass filter removes before q is differentiated.  A cubic
spline is more accurate between samples of smooth data, but the gain is far
below the noise and it rings across gaps and at torque steps.

One side effect to know when scoring: a resampled point between two logged
samples is a weighted mean of them, so white noise on tau shrinks, to
``sqrt(2/3) = 0.816`` of its level for stamps jittered uniformly (the mean
of ``(1 - a)^2 + a^2``).  ``validate`` on a resampled log therefore reports
residuals below the sensor's noise level by up to that factor (measured on
the hard log: 0.81 to 0.84 of the known noise); the note says when the log
was resampled.
"""

from __future__ import annotations

import math

import numpy as np

from ..._support.errors import ModelError

__all__ = ["MIN_RATE", "MAX_RATE", "GAP_FACTOR", "uniform_samples", "interpolate"]

#: plausible sample rates of a joint log, Hz: below, ``t`` is probably in ms;
#: above, in us or ns (or the rate is given in the wrong unit)
MIN_RATE, MAX_RATE = 2.0, 1e5
#: a step over this many median steps is a gap (dropped samples)
GAP_FACTOR = 1.5
_UNIFORM = 1e-3


def interpolate(t, values, grid) -> np.ndarray:
    """Linear interpolation of ``values`` (N, m) sampled at increasing ``t`` (N,) onto ``grid`` (M,)
    inside ``[t[0], t[-1]]``; all columns at once."""
    k = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, len(t) - 2)
    w = ((grid - t[k]) / (t[k + 1] - t[k]))[:, None]
    return values[k] * (1.0 - w) + values[k + 1] * w


def _grid_size(t, rate: float, m: int, where: str, option=None, rows=None) -> int:
    """Samples of the uniform grid at ``rate`` Hz over ``t`` (m values each), refused over
    :data:`manipdyn.limits.MAX_GRID_VALUES` before anything is allocated; the message names
    the rate when ``option`` (the argument) set it, else the largest gap (a bad time stamp)."""
    from ..._support import limits

    span = float(t[-1]) - float(t[0])
    count = math.floor(span * rate + 1e-9) + 1 if math.isfinite(span * rate) else math.inf
    if count < 2:
        raise ModelError(f"{where}: {option or 'the rate'}={rate:g} Hz over the log's {span:.6g} s gives "
                         f"{int(count)} sample; a log needs at least 2 (a rate in Hz, not a step in s?)")
    if count * m <= limits.MAX_GRID_VALUES:
        return int(count)
    shown = f"{count:.3g}" if math.isfinite(count) else "infinitely many"
    if option is not None:
        why = (f"{option}={rate:g} Hz over the log's {span:.6g} s gives {shown} samples of {m} values"
               f"; resample at a lower rate")
    else:
        step = np.diff(np.asarray(t, dtype=np.float64))
        k = int(np.argmax(step))
        row = f"row {rows[k + 1]}" if rows is not None else f"sample {k + 1}"
        why = (f"the time stamps span {span:.6g} s, {shown} samples of {m} values at {rate:.6g} Hz; the "
               f"largest gap is {float(step[k]):.6g} s before {row} (t = {float(t[k + 1])!r}): a bad time "
               f"stamp? cut it off with t_range (--t-range)")
    raise ModelError(f"{where}: the uniform time grid would be too large: {why} "
                     f"(limit {limits.MAX_GRID_VALUES:g} values, manipdyn.limits.MAX_GRID_VALUES)")


def _check_given_rate(rate, where, name, what):
    if not (MIN_RATE <= rate <= MAX_RATE):
        raise ModelError(f"{where}: {name}= (--{name}) {rate:.6g} Hz as {what} is implausible for a joint log "
                         f"(expected {MIN_RATE:g} Hz to {MAX_RATE:g} Hz; a rate in Hz, not a step in s?)")


def _check_rate(rate, where, what):
    if not (MIN_RATE <= rate <= MAX_RATE):
        raise ModelError(
            f"{where}: {what} gives a sample rate of {rate:.6g} Hz, implausible for a joint log "
            f"(expected {MIN_RATE:g} Hz to {MAX_RATE:g} Hz): if 't' is in milliseconds (or us, ns), scale it "
            "to seconds with time_scale=1e-3 (1e-6, 1e-9; --time-scale), or ignore 't' and give the rate "
            "with rate=HZ (--rate HZ)")


def uniform_samples(t, values, rows, where: str, *, rate=None, resample=None, velocity_columns=()):
    """Uniform samples of a log (module docstring).

    ``t`` (N,) time stamps in s, or None (then ``rate`` Hz is required and the
    rows are taken as uniform samples from t = 0); given with ``t``, ``rate``
    replaces the stamps (for a ``t`` column in an unknown unit).  ``values``
    (N, m) every other signal; ``rows`` (N,) the file row of each sample, for
    messages; ``resample`` Hz, the rate of the grid (default: the median rate);
    ``velocity_columns`` the indices of ``values``' measured velocities (and
    accelerations): a repeated row with all of them exactly zero is kept.

    Returns ``(t, values, rate, notes)``: the uniform times (M,), the values
    on them (M, m), the rate in Hz and a list of one-line notes saying what
    was done.
    """
    notes = []
    values = np.asarray(values, dtype=np.float64)
    if len(values) < 2:
        raise ModelError(f"{where}: {len(values)} data row(s); a log needs at least 2 samples")
    if resample is not None and not (np.isfinite(resample) and resample > 0):
        raise ModelError(f"{where}: resample: expected a rate in Hz > 0, got {resample!r}")
    if resample is not None:
        _check_given_rate(float(resample), where, "resample", "the uniform grid's rate")
    if rate is not None:
        if not (np.isfinite(rate) and rate > 0):
            raise ModelError(f"{where}: rate: expected a sample rate in Hz > 0, got {rate!r}")
        rate = float(rate)
        _check_given_rate(rate, where, "rate", "the log's sample rate")
        why = "the log has no 't' column" if t is None else "given rate= replaces the 't' column"
        t = np.arange(len(values)) / rate
        notes.append(f"time: {why}; {len(values)} rows taken as uniform samples at {rate:g} Hz")
        same = np.all(values[1:] == values[:-1], axis=1)
        if same.any():
            notes.append(f"time: {int(same.sum())} rows repeat the previous row exactly; without time "
                         "stamps they are kept as samples (if they are the same sample logged twice, "
                         "the time axis is stretched: log t)")
        if resample is None or abs(resample - rate) <= 1e-9 * rate:
            return t, values, rate, notes
        grid = np.arange(_grid_size(t, resample, values.shape[1], where, "resample")) / float(resample)
        notes.append(f"time: resampled from {rate:g} Hz to {resample:g} Hz by linear interpolation "
                     f"({len(t)} -> {len(grid)} samples)")
        return grid, interpolate(t, values, grid), float(resample), notes
    if t is None:
        raise ModelError(f"{where}: no time column 't'; give the sample rate with rate=HZ (--rate HZ), "
                         "or map the time column with columns='t=NAME'")
    t = np.asarray(t, dtype=np.float64)
    rows = np.asarray(rows)
    step = np.diff(t)
    back = np.flatnonzero(step < 0)
    if back.size:
        k = int(back[0]) + 1
        raise ModelError(f"{where}: column 't' must increase: row {rows[k]} (t = {float(t[k])!r}) goes back from "
                         f"row {rows[k - 1]} (t = {float(t[k - 1])!r})")
    same = np.all(values[1:] == values[:-1], axis=1)
    clash = np.flatnonzero((step == 0) & ~same)
    cols = list(velocity_columns)
    if cols:
        rest = same & (step > 0) & np.all(values[1:, cols] == 0.0, axis=1)
        if rest.any():
            notes.append(f"time: kept {int(rest.sum())} rows that repeat the previous row with every measured "
                         "velocity exactly zero (an arm at rest, not a sample logged twice)")
            same = same & ~rest
    if clash.size:
        k = int(clash[0]) + 1
        raise ModelError(f"{where}: column 't' must increase: row {rows[k]} repeats the time {float(t[k])!r} of row "
                         f"{rows[k - 1]} with different values")
    if same.any():
        keep = np.concatenate([[True], ~same])
        notes.append(f"time: dropped {int(same.sum())} duplicate rows (all values equal to the previous row's: "
                     "the same sample logged again), keeping the first time stamp")
        t, values = t[keep], values[keep]
    if len(t) < 2:
        raise ModelError(f"{where}: column 't' must increase over at least 2 distinct samples; found "
                         f"{len(t)} after dropping {int(same.sum())} duplicate row(s)")
    step = np.diff(t)
    h = float(np.median(step))
    if h <= 0:
        raise ModelError(f"{where}: column 't' must increase: more than half of its steps are 0")
    regular = step[(step > 0.5 * h) & (step < GAP_FACTOR * h)]
    h = float(np.median(regular))        # without the gaps, which would bias the median up
    native = 1.0 / h
    _check_rate(native, where, f"column 't' has a median step of {h:.6g} s, which")
    gaps = step > GAP_FACTOR * h
    if gaps.any():
        big = int(np.argmax(step))
        notes.append(f"time: {int(gaps.sum())} gaps (steps over {GAP_FACTOR:g} x the median {h * 1e3:.4g} ms), "
                     f"largest {step[big] * 1e3:.4g} ms at t = {t[big]:.6g} s (~{step[big] / h - 1:.0f} samples "
                     "dropped there)")
    uniform = float(np.max(np.abs(step - h))) <= _UNIFORM * h
    if uniform and (resample is None or abs(resample - native) <= 1e-6 * native):
        notes.append(f"time: uniform steps at {native:.6g} Hz; samples kept as they are")
        return t, values, native, notes
    target = native if resample is None else float(resample)
    why = "the median rate" if resample is None else "as asked"
    grid = t[0] + np.arange(_grid_size(t, target, values.shape[1], where, "resample" if resample else None,
                                       rows)) / target
    if not uniform:
        notes.append(f"time: steps not uniform ({step.min() * 1e3:.4g} to {step.max() * 1e3:.4g} ms, median "
                     f"{h * 1e3:.4g} ms)")
    notes.append(f"time: resampled onto a uniform grid at {target:.6g} Hz ({why}) by linear interpolation: "
                 f"{len(t)} -> {len(grid)} samples (interpolating averages neighbouring samples: white "
                 "noise on tau shrinks, down to 0.82 of its level)")
    return grid, interpolate(t, values, grid), target, notes
