"""Split-conformal quantiles of held-out scores: the band's half-width, its leverage gain, its speed class.

Layer 5 (identification), room ``uncertainty``.  Used by :mod:`.bands` (module docstring there: what the
held-out residuals are, and why their conformal quantile is the band).

The speed class (:func:`slow_class`)
------------------------------------
Conformal coverage holds for new samples exchangeable with the held-out ones.  A run that stops and starts
is not: it spends two to three times as long at the slowest speeds as an excitation, which crosses zero speed
only at its reversals, and there the error of a friction law differs most from its error elsewhere (the
breakaway above Coulomb, the Stribeck decay: a law without them under-predicts the friction of every start and
stop).  A single quantile over all held-out samples is set by the fast ones, and a point-to-point run's slow
samples then miss: a synthetic UR5 with static friction 1.5x Coulomb, fitted with viscous and Coulomb friction
on Fourier runs, held 34 to 60 % of a point-to-point run's slow moving samples (under 0.1 rad/s), unflagged.
So the scores are also split by speed (a Mondrian conformal class): per joint, the held-out samples moving
slower than ``slow_speed_j``, the :data:`SLOW_QUANTILE` quantile of the joint's moving fit speeds (its slowest
5 %), give their own quantile, ``slow_half_width_j``, never narrower than the whole band.  A new sample slower
than ``slow_speed_j`` gets it; so does a joint at rest where the fit never rested, whose static level is the
law's breakaway only (a lower bound): what the fit data showed at their slowest, the held-out error there,
holds the breakaway the law left out (:meth:`.bands.PredictionBand.sample_widths`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["conformal_half_width", "leverage_gain", "slow_class", "slow_fields", "GAINS", "GAIN_BENEFIT", "SLOW_QUANTILE",
           "MIN_SLOW_SAMPLES"]

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


def slow_class(residual_sets, qd, still, level: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """``(slow_speed, slow_half_width)``, (n,) each (module docstring): ``residual_sets``, held-out residuals
    (N, n) each (NaN: no score, e.g. a joint at rest), of the samples with velocities ``qd`` (N, n), rad/s;
    ``still`` (N, n) bool, the joints at rest (not moving: outside the class's speeds).  Per joint the speed
    under which the slowest :data:`SLOW_QUANTILE` of its moving samples ran, and the largest conformal
    half-width of the residual sets over the samples slower than that (0 where fewer than
    :data:`MIN_SLOW_SAMPLES` scores: no class of its own)."""
    qd = np.abs(np.asarray(qd, dtype=np.float64))
    n = qd.shape[1]
    speed, width = np.zeros(n), np.zeros(n)
    for j in range(n):
        moving = ~still[:, j]
        if np.sum(moving) < MIN_SLOW_SAMPLES:
            continue
        v = float(np.quantile(qd[moving, j], SLOW_QUANTILE))
        slow = moving & (qd[:, j] < v)
        scores = [r[slow, j] for r in residual_sets]
        scores = [s[~np.isnan(s)] for s in scores]
        if min(len(s) for s in scores) < MIN_SLOW_SAMPLES:
            continue
        speed[j] = v
        width[j] = max(float(conformal_half_width(s[:, None], level)[0]) for s in scores)
    return speed, width


def slow_fields(rest, residual_sets, qd, still, level, width) -> dict:
    """The speed class of a fit with a ``rest`` threshold (:func:`slow_class`), never narrower than the band's
    ``width`` (n,), as :class:`.bands.PredictionBand`'s ``slow_speed`` and ``slow_half_width``; none (an empty
    dict) without a rest threshold."""
    if rest is None:
        return {}
    speed, slow = slow_class(residual_sets, qd, still, level)
    return {"slow_speed": speed, "slow_half_width": np.maximum(slow, width)}
