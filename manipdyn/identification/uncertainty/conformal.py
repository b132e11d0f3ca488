"""Split-conformal quantiles of held-out scores: the band's half-width, its leverage gain, its speed class.

Layer 5 (identification), room ``uncertainty``.  Used by :mod:`.bands` (module docstring there: what the
held-out residuals are, and why their conformal quantile is the band).

The speed class (:func:`slow_speeds`, :func:`slow_fields`)
-----------------------------------------------------------
Conformal coverage holds for new samples exchangeable with the held-out ones.  A run that stops and starts
is not: it spends two to three times as long at the slowest speeds as an excitation, which crosses zero speed
only at its reversals, and there the error of a friction law differs most from its error elsewhere (the
breakaway above Coulomb, the Stribeck decay: a law without them under-predicts the friction of every start and
stop).  A single quantile over all held-out samples is set by the fast ones, and a point-to-point run's slow
samples then miss: a synthetic UR5 with static friction 1.5x Coulomb, fitted with viscous and Coulomb friction
on Fourier runs, held 34 to 60 % of a point-to-point run's slow moving samples (under 0.1 rad/s), unflagged.
So the slowest speeds get a class of their own (a Mondrian conformal class): per joint, the held-out samples
moving slower than ``slow_speed_j``, the :data:`SLOW_QUANTILE` quantile of the joint's moving fit speeds (its
slowest 5 %), give their own quantile, and ``slow_half_width_j`` is the larger of it and the band's (the
quantile over every moving sample, as before: the class only widens, the band narrows nowhere).  Scoring the
other samples apart too (the textbook split) narrowed the band at speed: on the synthetic UR5 the
point-to-point run's fast samples, beyond the Fourier runs' postures, then missed on joint 1 (84.9 %; pooled
92.9 % against 96.3 %), and the LWR4's joint 1 lost 1.1 % on another run.  A new sample slower
than ``slow_speed_j`` gets it; so does a joint at rest where the fit never rested, whose static level is the
law's breakaway only (a lower bound): what the fit data showed at their slowest, the held-out error there,
holds the breakaway the law left out (:meth:`.bands.PredictionBand.sample_widths`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["conformal_half_width", "leverage_gain", "slow_speeds", "slow_fields", "GAINS", "GAIN_BENEFIT",
           "SLOW_QUANTILE", "MIN_SLOW_SAMPLES"]

#: the leverage gains g tried per joint (0: a constant band)
GAINS = (0.0, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0)
#: a gain is taken only when its band is this much narrower on average than the constant one
GAIN_BENEFIT = 0.05
#: the slow class: the joint's moving fit samples under this quantile of their speeds (module docstring)
SLOW_QUANTILE = 0.05
#: the least held-out samples of a slow class for its own quantile (fewer: none, the whole band there)
MIN_SLOW_SAMPLES = 40


def conformal_half_width(residuals, level: float = 0.95) -> np.ndarray:
    """Per column, the ``ceil((m + 1) level)``-th smallest ``|r|`` of ``m`` residuals (the largest when
    that rank passes ``m``): the split-conformal half-width (module docstring)."""
    r = np.abs(np.asarray(residuals, dtype=np.float64))
    if np.isnan(r).any():           # NaN: no score (a joint at rest: the moving band's scores only); each column its own m
        return np.array([conformal_half_width(c[~np.isnan(c)][:, None], level)[0] if np.any(~np.isnan(c)) else 0.0
                         for c in r.T])
    m = len(r)
    rank = min(m, math.ceil((m + 1) * float(level)))
    return np.sort(r, axis=0)[rank - 1]


def leverage_gain(r, u, level) -> tuple[float, float]:
    """``(g, c)`` of one joint: the gain of :data:`GAINS` whose conformal band is narrowest on average over the
    held-out samples (``r`` residuals, ``u`` leverage ratios, (m,)), and its ``c``."""
    scored = []
    for g in GAINS:
        s = np.sqrt(1.0 + g * u)
        c = float(conformal_half_width((r / s)[:, None], level)[0])
        scored.append((c * float(np.mean(s)), g, c))
    width, g, c = min(scored)
    if width > (1.0 - GAIN_BENEFIT) * scored[0][0]:      # not clearly narrower: the constant band
        return GAINS[0], scored[0][2]
    return g, c


def slow_speeds(qd, still) -> tuple[np.ndarray, np.ndarray]:
    """``(slow_speed, slow)``: per joint (n,) the speed under which the slowest :data:`SLOW_QUANTILE` of its
    moving samples ran (0: fewer than :data:`MIN_SLOW_SAMPLES` moving samples, no class), and (N, n) bool the
    moving samples slower than that (module docstring).  ``qd`` (N, n) rad/s; ``still`` (N, n) bool, the joints
    at rest (outside the class's speeds)."""
    qd = np.abs(np.asarray(qd, dtype=np.float64))
    speed = np.zeros(qd.shape[1])
    for j in range(qd.shape[1]):
        moving = ~still[:, j]
        if np.sum(moving) >= MIN_SLOW_SAMPLES:
            speed[j] = float(np.quantile(qd[moving, j], SLOW_QUANTILE))
    return speed, (qd < speed) & ~still


def slow_fields(speed, slow, residual_sets, level, width) -> dict:
    """:class:`.bands.PredictionBand`'s ``slow_speed`` and ``slow_half_width`` (an empty dict when ``speed`` is
    None: a fit without a rest threshold): per joint the largest conformal half-width over the ``residual_sets``
    ((N, n) each, NaN: no score) of the ``slow`` samples (N, n) bool (:func:`slow_speeds`), never narrower than
    the band's ``width`` (n,), the other samples' (a joint with fewer than :data:`MIN_SLOW_SAMPLES` slow scores:
    ``width``)."""
    if speed is None:
        return {}
    out = np.array(width, dtype=np.float64)
    for j in range(len(out)):
        scores = [r[slow[:, j], j] for r in residual_sets]
        scores = [x[~np.isnan(x)] for x in scores]
        if min(len(x) for x in scores) >= MIN_SLOW_SAMPLES:
            out[j] = max(out[j], *(float(conformal_half_width(x[:, None], level)[0]) for x in scores))
    return {"slow_speed": speed, "slow_half_width": out}
