"""Samples at rest: the rest threshold a log decides, and the static friction its rests show.

Layer 5 (identification), room ``inputs``.

A joint at rest holds any torque within its static band ``[-Fs, Fs]``
(:mod:`manipdyn.model.friction_rest`), so identification treats its rest samples as what they
are, not as ``sign(noise)``:

* **the rest threshold** (:func:`rest_threshold`): joint j is at rest where ``|qd_j|`` is within
  :data:`REST_NOISE` times its velocity noise, measured on the log as the Coulomb smoothing's is
  (:mod:`.choices`: ``Measurements.qd_noise``, the RMS of what the low-pass filter removed from
  qd, or ``2 pi cutoff`` times what it removed from q).  Three times the raw noise: the filtered
  velocity of a still joint stays within it (the filter only narrows the noise), while a joint
  that moves leaves it within a few samples.  Where the noise is not known (qd measured and
  nothing filtered) the threshold is the law's smoothing ``v_s`` (the speed below which the
  smoothed sign is a guess already), or :data:`manipdyn.model.friction_law.DEFAULT_SMOOTHING`;
* **the fit** (:func:`manipdyn.identification.fit` with ``rest=``): the velocity of a joint at rest
  is 0 (no Coulomb or Stribeck torque there), and its rest rows are left out of that joint's
  least squares: the torque there is the rigid part plus an unknown static friction;
* **the static level** (:func:`static_record`): per joint, the :data:`STATIC_QUANTILE` quantile
  of ``|tau - prediction|`` over the fit's rest samples of that joint, when the fit data rested
  there for at least :data:`MIN_REST_SAMPLES` samples; else the fitted law's breakaway level
  (Coulomb plus Stribeck, read off the fitted model just out of rest) stands in, a lower bound, and
  validate flags rest samples there.
  A joint slower than all but :data:`SLOW_FRACTION` (0.1 %) of the fit samples ran, slower than anything
  the fit saw (an excitation crosses zero speed only briefly; a point-to-point run breaks away from every
  rest), gets the static band too, and a flag where the fit never rested: the law's break-away there was
  never checked.
  The record (:class:`~manipdyn.model.friction_rest.StaticFriction`) travels in the trust
  record as ``rest``: ``validate`` predicts the rigid part at rest and widens the band there by
  ``Fs_j`` (the static band); collision thresholds read the same record.
"""

from __future__ import annotations

import numpy as np

from ...model.friction_law import DEFAULT_SMOOTHING
from ...model.friction_rest import StaticFriction, rest_mask

__all__ = ["rest_threshold", "static_record", "breakaway_of", "rest_option", "rest_trust", "measured_rest",
           "REST_NOISE", "STATIC_QUANTILE", "MIN_REST_SAMPLES", "SLOW_FRACTION"]

#: a joint is at rest within this many times its velocity noise (module docstring)
REST_NOISE = 3.0
#: the static level: this quantile of ``|tau - prediction|`` over a joint's rest samples
STATIC_QUANTILE = 0.95
#: the fit data rested on a joint when at least this many of its samples were at rest
MIN_REST_SAMPLES = 50
#: "slower than anything the fit saw": under the speed that only this fraction of the fit samples were under
#: (a stray sample aside).  At 1 %, the zero crossings of one Fourier run flagged those of another (the LWR4's
#: run 1 against run 3: flags 3.3 times the misses, over the issue's 3)
SLOW_FRACTION = 0.001
#: the slowest speed, rad/s, at which a model's breakaway level is read (a threshold of 0: exact rest)
MIN_SPEED = 1e-3


def rest_threshold(data, smoothing: float | None = None) -> tuple[np.ndarray, str]:
    """``(threshold, note)``: the rest speed per joint (n,), rad/s (m/s), of the log ``data``
    (:class:`~manipdyn.identification.Measurements`: ``qd_noise`` (n,) or None), and a sentence saying
    how it was chosen.  ``smoothing``: the law's Coulomb smoothing v_s, the fallback (module docstring)."""
    n = data.q.shape[1]
    noise = getattr(data, "qd_noise", None)
    fallback = float(smoothing) if smoothing else DEFAULT_SMOOTHING
    if noise is not None:
        noise = np.asarray(noise, dtype=np.float64)
        known = np.isfinite(noise) & (noise > 0)
        t = np.where(known, REST_NOISE * np.where(known, noise, 0.0), fallback)
        how = f"{REST_NOISE:g} x the velocity's noise on the log" + (
            "" if np.all(known) else f"; {fallback:g} where the log shows no noise (joint(s) "
            + ", ".join(str(j + 1) for j in np.flatnonzero(~known)) + ")")
    else:
        t = np.full(n, fallback)
        how = ("the Coulomb smoothing" if smoothing else "the default smoothing") + \
            " (the velocity's noise is not known: qd measured and not filtered)"
    rest = rest_mask(data.qd, t)
    still = np.sum(~rest, axis=0) < MIN_REST_SAMPLES      # a joint that barely moves: no rest told apart
    t, rest = np.where(still, 0.0, t), rest & ~still
    how += "".join(f"; joint {j + 1} moves in under {MIN_REST_SAMPLES} samples: its rests are not told apart"
                   for j in np.flatnonzero(still))
    note = (f"rest: a joint whose |qd| is within {' '.join(f'{x:.2g}' for x in t)} rad/s ({how}) is at rest, "
            f"its torque the rigid part plus a static friction, left out of its friction fit; at rest "
            + ", ".join(f"j{j + 1} {100 * f:.0f} %" for j, f in enumerate(np.mean(rest, axis=0)))
            + " of the fit samples")
    return t, note


def measured_rest(data, threshold):
    """``threshold`` (n,) where the log ``data`` measured the joint's velocity noise, 0 (only an exact zero is
    rest) where it did not, or None without a ``threshold``: the rests the friction shapes' search leaves out.
    A threshold from the noise tells a rest apart; the fallback (the smoothing, on a log whose qd is exact or
    unfiltered) is a guess, and on a noise-free log it hid a sigmoid's steep part (alpha 30 to 60 s/rad, the
    shift within 0.05 rad/s) from the search, which then missed alpha by 15 to 200 %."""
    if threshold is None:
        return None
    noise = getattr(data, "qd_noise", None)
    known = np.zeros(len(threshold), dtype=bool) if noise is None else np.isfinite(noise) & (np.asarray(noise) > 0)
    return np.where(known, threshold, 0.0)


def static_record(residuals, qd, threshold, predict=None, q0=None) -> tuple[StaticFriction, str]:
    """``(record, note)``: the static friction of each joint (module docstring) from the fit's ``residuals``
    (N, n) (measured minus predicted, the prediction taking the velocity of a joint at rest as 0) at the
    velocities ``qd`` (N, n); ``threshold`` (n,) the rest speed.  Where the fit never rested, the fitted
    model's breakaway level stands in (:func:`breakaway_of`, from ``predict(q, qd, qdd)`` at the posture
    ``q0`` (n,)), or 0 without a ``predict``."""
    r, qd = np.asarray(residuals, dtype=np.float64), np.asarray(qd, dtype=np.float64)
    n = r.shape[1]
    rest = rest_mask(qd, threshold)
    count = np.sum(rest, axis=0)
    measured = count >= MIN_REST_SAMPLES
    stand_in = np.zeros(n) if predict is None or np.all(measured) else breakaway_of(predict, q0, threshold)
    level = np.array([float(np.quantile(np.abs(r[rest[:, j], j]), STATIC_QUANTILE)) if measured[j] else stand_in[j]
                      for j in range(n)])
    slow = np.quantile(np.abs(qd), SLOW_FRACTION, axis=0)
    record = StaticFriction(threshold=np.asarray(threshold, dtype=np.float64), level=level, measured=measured,
                            rest_fraction=np.mean(rest, axis=0), slow=slow)
    return record, record.describe()


def breakaway_of(predict, q0, threshold) -> np.ndarray:
    """(n,) N m: half the jump of each joint's predicted torque from ``-v`` to ``+v`` (that joint alone moving,
    ``v = 2 threshold``, at least :data:`MIN_SPEED`), at the posture ``q0``: the model's friction just out of
    rest, its Coulomb plus Stribeck level on any law and side (the rigid terms cancel: gravity is the same, the
    velocity terms even in v).  The model's own breakaway level, a lower bound of the static one."""
    q0 = np.asarray(q0, dtype=np.float64)
    n = len(q0)
    v = np.maximum(2.0 * np.asarray(threshold, dtype=np.float64), MIN_SPEED)
    qd = np.diag(v)
    q = np.repeat(q0[None], n, axis=0)
    up, down = predict(q, qd, np.zeros((n, n))), predict(q, -qd, np.zeros((n, n)))
    return np.maximum(0.5 * np.diag(np.asarray(up) - np.asarray(down)), 0.0)


def rest_option(data, smoothing, notes: list) -> np.ndarray:
    """The rest threshold (n,) :func:`~manipdyn.identification.pipeline.identify` fits with (:func:`rest_threshold`); its note appended to ``notes``."""
    threshold, note = rest_threshold(data, smoothing)
    notes.append(note)
    return threshold


def rest_trust(prov: dict, result, data, threshold) -> list:
    """Put the static friction (:func:`static_record`) of the fit ``result`` on ``data`` into the provenance
    ``prov`` as ``rest`` (nothing without a ``threshold``); returns the notes to add."""
    if threshold is None:
        return []
    record, note = static_record(result.residuals, data.qd, threshold, result.predict, data.q[0])
    prov["rest"] = record.to_dict()
    return [note]
