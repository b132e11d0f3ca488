"""Collision thresholds that widen where the watched state leaves what the fit saw: the leverage ratio.

Layer 6 (control: collision).

The thresholds are read off the band's hold-outs (:mod:`.holdouts`): each held-out part watched by the observer
of a refit on the other data.  Where a held-out trajectory goes where its refit never went (other postures,
speeds, accelerations), the refit extrapolates and its residual grows there, and a constant threshold per joint
sets every sample's level by those excursions: a new run that stays within the model's fit data is then
watched at a level set by another run's extrapolation.  On the UR5 (fit on No6 and No1, issue 45) the wrist's
largest held-out residuals came from starts and stops of No6 that the refit on No1, which never rests, had not
seen: joint 6's constant threshold 4.42 N m, where its residual in motion stays within 0.3 N m.

So, as the prediction band does on its blocks (:mod:`manipdyn.identification.uncertainty.bands`), joint j's
threshold on a sample grows with the sample's **leverage ratio** ``u_j``
(:mod:`manipdyn.identification.uncertainty.leverage`: joint j's regressor row against the rows of the fit
data, 1 on a typical fitted sample, large where the state leaves what the data excited, whichever joint took
it there, accelerations included)::

    T_j(x) = T_j sqrt((1 + g_j u_j(x)) / (1 + g_j))

(``T_j`` the threshold at a typical fitted sample, ``u = 1``, as a band's half-width is; what a loop reading
``threshold`` alone gets).

* **Only across runs.** The gain is chosen only when the hold-outs are held-out trajectories (two or more
  different runs): there a held-out run goes where its refit never went, and whether the residual grows with
  ``u`` is tested out of sample.  The blocks of one trajectory revisit each other's states, their ``u`` barely
  varies, and a gain chosen on them was chance: on the Panda's log (one trajectory, fit on 0-10 s) it lowered
  joint 3's threshold at gain 100 from 3.9 to 2.4 N m, and the next 11 s, collision-free, crossed it (1.09 of
  it).  With blocks the thresholds stay constant.
* **Calibration** (:func:`choose_leverage_gain`): each held-out sample's ``u`` is taken against the rows its
  own refit saw (:func:`refit_reference`: the same features, weights and ``v_s`` as the model's reference), so a
  held-out part is as far from its refit's data as it is; the residual divided by ``sqrt((1 + g u) / (1 + g))`` gives
  ``T_j`` through the same tail fit and false-alarm rate as the constant thresholds
  (:func:`~manipdyn.identification.uncertainty.thresholds.fit_thresholds`; with held-out trajectories, the
  blocks' at the same ``g`` a floor).  ``g_j`` is the one of the band's gains
  (:data:`~manipdyn.identification.uncertainty.conformal.GAINS`) whose threshold, averaged over the held-out samples,
  is lowest, taken only when that is :data:`~manipdyn.identification.uncertainty.conformal.GAIN_BENEFIT` (5 %) below
  the constant threshold's; else ``g_j = 0``, the constant threshold.  The observer's gain ``K`` is chosen first
  (:mod:`.gain`, on the constant thresholds), then ``g`` at that ``K``.
* **Watching a log** (:func:`threshold_levels`): ``u`` of each sample against the model's own reference (its
  trust record's ``leverage``), so the thresholds are lower where the log stays within the fit data and higher,
  said so, where it leaves them.  The acceleration of the features is the measured velocity's derivative,
  smoothed (:func:`acceleration`: a quadratic Savitzky-Golay fit over :data:`ACCEL_WINDOW` s, centred): the
  thresholds are for ``observe``'s offline reading of a log; :class:`~.observer.MomentumObserver` (a
  controller's loop) gives residuals only.

Measured on the UR5 (issue 45's command, gain 100 1/s, after the band's refits learnt the rests): ``g`` 0.03, 0,
0, 0.3, 3, 1 on joints 1 to 6; thresholds at a typical sample 32.7, 32.3, 22.0, 4.47, 2.80, 1.20 N m; on the
three runs without a push no event (the highest residual 0.78 of its threshold), on the four with one 6, 3, 3
and 3 events (docs/guide/work.md).  Before the leverage scaling the constant thresholds were 38.8, 35.9, 20.4,
6.8, 4.98, 4.42 N m.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..._support.errors import ModelError
from ...identification.uncertainty.thresholds import leverage_factor

__all__ = ["acceleration", "model_reference", "refit_reference", "leverage_ratios", "choose_leverage_gain",
           "threshold_levels", "ACCEL_WINDOW"]

#: s: the window of the smoothed derivative of the measured velocity that the leverage's features take
ACCEL_WINDOW = 0.1


def acceleration(qd, dt: float) -> np.ndarray:
    """``qdd`` (N, n), rad/s^2: the derivative of ``qd`` (N, n) sampled every ``dt`` s, a quadratic
    Savitzky-Golay fit over :data:`ACCEL_WINDOW` s (at least 5 samples; fewer samples than that: a plain
    gradient)."""
    qd = np.asarray(qd, dtype=np.float64)
    m = int(round(ACCEL_WINDOW / float(dt))) // 2 * 2 + 1
    m = max(m, 5)
    if len(qd) < m:
        return np.gradient(qd, float(dt), axis=0) if len(qd) > 1 else np.zeros_like(qd)
    from scipy.signal import savgol_filter

    return savgol_filter(qd, m, 2, deriv=1, delta=float(dt), axis=0, mode="interp")


def model_reference(arm):
    """The :class:`~manipdyn.identification.uncertainty.leverage.Leverage` of the model's trust record
    (``leverage``), or None when it has none or it does not read."""
    from ...identification.uncertainty.leverage import Leverage

    rec = getattr(arm, "trust", None)
    if not isinstance(rec, dict) or rec.get("leverage") is None:
        return None
    try:
        return Leverage.from_dict(rec["leverage"], arm.n, "the model's leverage")
    except ModelError:
        return None


def refit_reference(reference, arm, data, held):
    """The leverage reference of a refit: ``reference``'s weights and ``v_s`` over the rows of ``data`` (identify's
    Measurements) that the refit ``arm`` saw, those outside ``held`` (N,) bool."""
    from ...identification.uncertainty.leverage import Leverage

    seen = ~np.asarray(held, dtype=bool)
    return Leverage.of_fit(arm, data.q[seen], data.qd[seen], data.qdd[seen], reference.weights, reference.smoothing)


def leverage_ratios(reference, arm, q, qd, dt: float) -> np.ndarray:
    """``u`` (N, n): the leverage ratio of the states ``q``, ``qd`` (N, n), sampled every ``dt`` s (their
    acceleration :func:`acceleration`), against ``reference``."""
    u, _ = reference.ratio(arm, q, qd, acceleration(qd, dt))
    return u


def choose_leverage_gain(record_at, ratios, gains=None, benefit=None):
    """The thresholds with a leverage gain per joint (module docstring).

    ``record_at(g)``: the :class:`~manipdyn.identification.uncertainty.thresholds.CollisionThresholds` of the
    held-out residuals divided by ``sqrt((1 + g u) / (1 + g))`` (every joint at gain ``g``); ``ratios``: the held-out samples'
    ``u``, a list of (N_k, n).  Returns the record whose joint j is ``record_at(g_j)``'s, with ``leverage_gain``
    and its source saying the choice."""
    from ...identification.uncertainty.conformal import GAIN_BENEFIT, GAINS

    gains = tuple(GAINS if gains is None else gains)
    benefit = GAIN_BENEFIT if benefit is None else float(benefit)
    U = np.vstack(ratios)
    recs = {g: record_at(float(g)) for g in gains}
    mean_level = {g: recs[g].threshold * np.mean(leverage_factor(np.full(U.shape[1], float(g)), U), axis=0)
                  for g in gains}
    g0 = gains[0]
    n = recs[g0].n
    pick = []
    for j in range(n):
        best = min(gains, key=lambda g: mean_level[g][j])
        pick.append(best if mean_level[best][j] <= (1.0 - benefit) * mean_level[g0][j] else g0)
    g = np.array(pick, dtype=np.float64)
    base = recs[g0]
    if not np.any(g > 0):
        return base
    fields = {k: np.array([getattr(recs[pick[j]], k)[j] for j in range(n)]) for k in ("threshold", "tail_a",
                                                                                   "tail_b", "observed_max")}
    told = ", ".join(f"j{j + 1} {x:g}" for j, x in enumerate(g))
    means = ", ".join(f"{mean_level[pick[j]][j]:.3g}" for j in range(n))
    const = ", ".join(f"{x:.3g}" for x in mean_level[g0])
    return replace(base, **fields, leverage_gain=g,
                   source=f"{base.source}; each joint's threshold T_j sqrt((1 + g_j u) / (1 + g_j)) grows with "
                          f"the sample's leverage ratio u against the fit data (g {told}: the lowest held-out mean threshold, "
                          f"{means} N m, against the constant {const} N m)")


def threshold_levels(thresholds, arm, q, qd, dt: float):
    """``(T, u)``: the thresholds in effect on each sample (N, n), N m, and the leverage ratios (N, n) they
    were taken at (None, and ``T`` the constant (n,) thresholds, when they do not scale with the leverage).
    Raises :class:`ModelError` when they scale and the model carries no leverage reference."""
    if not getattr(thresholds, "scales_with_leverage", False):
        return np.asarray(thresholds.threshold), None
    ref = model_reference(arm)
    if ref is None:
        raise ModelError("thresholds: they grow with the leverage ratio against the fit data (leverage_gain), and "
                         "the model carries no leverage reference (its trust record's 'leverage'); use the model "
                         "identify wrote, or thresholds from calibrate= / threshold=")
    u = leverage_ratios(ref, arm, q, qd, dt)
    return thresholds.levels(u), u
