"""The observer's gain chosen from the data the thresholds are read off: the smallest torque detected in time.

Layer 6 (control: collision).

The gain ``K`` trades delay against noise: the residual follows a contact's torque with time constant
``1/K`` (and ``1/w`` of its output low-pass, ``w = 2 pi f_c``), while the measured velocity's noise reaches
it as ``K M qd_noise`` (:mod:`manipdyn.control.collision.observer`).  A fixed ``K`` lets the noise of one log
set its thresholds: on the Panda's log, gain 100 1/s gave joints 2 to 4 thresholds of 7.69, 3.92 and
3.82 N m, where gain 30 gives 2.66, 1.60, 1.89.

So by default the gain is chosen, among :data:`GAIN_CANDIDATES`, on the data the thresholds come from (the
band's hold-outs, or the calibration logs): for each candidate the thresholds ``T_j(K)`` at the rate asked,
and the **smallest torque detected within the delay budget** :data:`DELAY_BUDGET` (20 ms, the events'
``min_duration`` included), a step of the external torque ``F`` being detected when the residual's step
response ``F y_K(t)`` exceeds ``T_j`` by ``t = budget - min_duration``::

    F_j(K) = T_j(K) / y_K(budget - min_duration),
    y_K(t) = 1 - (K e^(-w t) - w e^(-K t)) / (K - w)      (two poles; 1 - e^(-K t) without the low-pass)

The gain kept is the one whose largest ``F_j(K)`` over the joints is smallest: the smallest torque that is
detected within the budget **on every joint**.  A higher gain answers faster, a lower one is quieter: the
choice weighs both on the log's own noise, not on a constant.  Measured on the Panda's log (identified on
0 to 10 s, the band's five blocks; ``F`` per gain 10, 20, 30, 50, 100 1/s: 17.1, 13.7, 13.6, 14.2, 15.4 N m,
joint 2's at 20 to 100) it keeps 30 1/s: thresholds 1.53, 2.85, 1.49, 1.96, 1.21, 0.47, 0.84 N m, 7.0 to 30
times below libfranka's hand-set 20, 20, 18, 18, 16, 14, 12 N m (gain 100: 2.6 to 20 times).  (The
geometric mean over the joints kept 100 there: the wrist's joints, which the velocity noise does not set,
outvoted joint 2, whose detectable torque is the arm's largest.)
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

__all__ = ["GAIN_CANDIDATES", "DELAY_BUDGET", "step_fraction", "detectable_torque", "choose_gain"]

#: the gains tried, 1/s
GAIN_CANDIDATES = (10.0, 20.0, 30.0, 50.0, 100.0)
#: a contact must be detected within this time, s (the events' min_duration included)
DELAY_BUDGET = 0.020


def step_fraction(gain: float, velocity_cutoff: float, t: float) -> float:
    """The residual's step response at ``t`` s: the fraction of a step of external torque it shows, through
    the observer's first order at ``gain`` 1/s and its output low-pass at ``velocity_cutoff`` Hz (0: none)."""
    K, t = float(gain), max(float(t), 0.0)
    w = 2.0 * math.pi * float(velocity_cutoff)
    if w <= 0:
        return 1.0 - math.exp(-K * t)
    if abs(K - w) < 1e-9 * K:                          # a double pole
        return 1.0 - (1.0 + K * t) * math.exp(-K * t)
    return 1.0 - (K * math.exp(-w * t) - w * math.exp(-K * t)) / (K - w)


def detectable_torque(thr, budget: float = DELAY_BUDGET) -> np.ndarray:
    """Per joint, N m: the smallest step of external torque that ``thr`` (a CollisionThresholds) detects within
    ``budget`` s (module docstring); ``inf`` where its ``min_duration`` uses up the budget.  Thresholds that grow
    with the leverage ratio are taken at a typical fitted sample (``u = 1``): ``threshold`` is that level."""
    y = step_fraction(thr.gain, thr.velocity_cutoff, float(budget) - thr.min_duration)
    return np.asarray(thr.threshold) / y if y > 0 else np.full(thr.n, np.inf)


def choose_gain(thresholds_at, candidates=GAIN_CANDIDATES, budget: float = DELAY_BUDGET):
    """The thresholds at the candidate gain with the smallest detectable torque (module docstring).

    ``thresholds_at(K)`` returns the CollisionThresholds at gain ``K``.  The chosen record's ``source`` says
    the choice, with each candidate's largest detectable torque over the joints.
    """
    scores, best = [], None
    for K in candidates:
        thr = thresholds_at(float(K))
        F = detectable_torque(thr, budget)
        score = float(np.max(F))
        scores.append((float(K), score))
        if best is None or score < best[1]:
            best = (thr, score)
    thr = best[0]
    told = ", ".join(f"{K:g}: {s:.3g}" for K, s in scores)
    return replace(thr, source=f"{thr.source}; gain {thr.gain:g} 1/s chosen from these data for the smallest torque "
                               f"detected within {1e3 * budget:g} ms on every joint (N m, per gain {told})")
