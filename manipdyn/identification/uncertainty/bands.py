"""Prediction bands that hold on the next trajectory: blocked hold-outs of the fit data.

Layer 5 (identification).

What a band must cover
----------------------
On a new sample the error is ``tau - f_hat(x) = [f(x) - f_hat(x)] + e``.  The first term is
parameter error (what the base parameters' covariance describes) **plus model error**: a
friction law that is not the arm's, elasticity, cables, thermal drift.  Model error does not
shrink with more data and is not a parameter uncertainty.  ``e`` is the measurement noise,
**coloured** by the drive's controller, by resampling and by the zero-phase filter.

The covariance band ``1.96 sqrt(y_b C y_b^T + sigma_j^2)`` counts only parameter error and
white noise: ``C`` scales with ``sigma^2 (Y^T Y)^-1`` as if every sample were independent,
so correlated residuals make it too narrow, and model error is in it only as far as it
inflates ``sigma`` on the fit data.  On real arms it held 13 to 57 % of the samples.

What is done instead (:func:`calibrate_band`)
---------------------------------------------
The fit data itself is cut into ``folds`` contiguous blocks in time (5 by default).  Each
block is predicted by a fit, with the same method and options, on the other blocks, and
the held-out residuals ``r = tau - f_hat_(-k)(x)`` are collected (:func:`held_out_residuals`).
They contain

* parameter error of a fit on (K-1)/K of the data: a little more than the full fit's, so
  the band errs on the wide side;
* model error where it shows between blocks: each held-out block holds states the
  others reach less well, a small dose of the extrapolation the next trajectory brings;
* the noise as it is, correlations included: contiguous blocks are long against the
  correlation time, so a refit cannot follow the noise of the block it predicts (random
  folds would leave every held-out sample's neighbours in the fit and make the band narrow).

The band's half-width per joint is a split-conformal quantile of these scores,
``c_j = the ceil((m + 1) level)-th smallest |r_j|`` among the ``m`` held-out residuals
(for exchangeable scores this covers at least ``level`` of new samples).  Samples of a time
series are not exchangeable, but the correction is tiny for the thousands of samples of a
log; the risk that remains is new data farther from the fit data than the blocks are from
each other, which :mod:`.coverage` reports.  The band is ``[pred - c_j, pred + c_j]``:

* constant per joint, not scaled by the covariance's ``std(x)``: on real arms the
  model error dominates and does not follow the parameter uncertainty, and n numbers
  travel with any model (model file, URDF comment, base JSON), covariance or not;
* symmetric: a mean error of the fit window (a bias) need not carry to another
  trajectory with its sign, so ``|r|`` covers either.

A band that knows where it is
-----------------------------
A constant half-width is right where the next trajectory is like the blocks, and too
narrow where it leaves what the fit data excited: there the parameter error (and the model
error that the fit absorbed into the parameters) is carried out with nothing to check it.
On a 7-joint arm fitted on one run a joint held 28 % of another run's samples, inside its
own ranges, because two other joints went 30-50 % beyond theirs.  So the half-width may grow
with the leverage ratio ``u_j(x)`` of :mod:`.leverage` (joint j's regressor row against the
fit data's rows; 1 on a typical fitted sample):

    ``half_width_j(x) = c_j sqrt(1 + g_j u_j(x))``.

The form is the least-squares prediction variance ``sigma^2 (1 + h)``, with the gain
``g_j`` free because the error that grows away from the data is mostly model error, not
the white-noise parameter error that ``h`` alone would give.  ``c_j`` and ``g_j`` come from
the same blocked hold-outs, as **normalised conformal scores**: for each held-out sample,
its ``u`` against the Gram matrix of the blocks its refit saw (so a block is as far from its
refit's data as it is), the score ``|r| / sqrt(1 + g u)``, and ``c_j`` the conformal quantile of
those scores (coverage of exchangeable scores holds for any fixed ``g``).  ``g_j`` is chosen
among :data:`GAINS` as the one whose band is narrowest on average over the held-out samples,
and only when that is at least :data:`GAIN_BENEFIT` (5 %) narrower than the constant band: where the held-out errors do not grow with ``u`` (data from the
model's own class, interpolating) that is ``g = 0``, today's constant band, and the band
does not widen everywhere; where they do, it narrows in the middle and widens outside.
Choosing ``g`` among a few values on the same scores costs a little coverage optimism: on
synthetic logs of the right model class a gain picked for a 1-3 % narrower band lost 0.5-1.2 %
of coverage on the next trajectory, which is why a gain must buy 5 %.

Runs are the unit of trust: held-out trajectories
-------------------------------------------------
Blocks cut in time measure the error **within** a trajectory: with several runs stacked, every
refit still sees most of every run.  On a KUKA LWR4+ fitted on two different trajectories that
band held 86 % of a third run (joint 2: 74 %), while a band calibrated on held-out **runs** held
about 96 %.  So when the fit data hold two or more distinct trajectories (``labels``: the group
of each sample, runs that repeat one trajectory held out together, found from the positions by
:mod:`..inputs.trajectories`), each group is predicted by a fit, with the same method and
options, on the other groups, and the conformal quantile is taken over those residuals.

Combining them with the blocks (where trajectories are few).  Two or three trajectories give
two or three held-out experiments: a joint may happen to carry over well from one trajectory
to the other, and its held-out-trajectory quantile then falls below what the noise and the
within-run model error alone give on any run.  The blocks measure that floor on every sample.
So the half-width per joint is the **larger** of the two quantiles, the held-out trajectories'
and the blocks' (the blocks' constant band, at ``u = 1``), and it is constant per joint (the
trajectories' residuals already hold the extrapolation the leverage gain stands for; where a
new run leaves even them, the flags say so, below).  Each held-out trajectory is predicted by a
fit on fewer runs than the model's, so the band errs on the wide side, the safe one for a
collision threshold; with many trajectories the difference fades.

With a single trajectory (one run, or runs that only repeat it) there is no other run to hold
out, and blocks in time of a periodic excitation hold states every other block revisits: on the
LWR4 such a band held 83 and 77 % of the other trajectory.  So the held-out groups are then
**posture regions** (:func:`..inputs.trajectories.posture_regions`: four regions of the joint
space by k-means on the positions), each predicted by a fit on the others, combined with the
blocks exactly as held-out trajectories are (the larger quantile per joint, constant, the flags'
leverage calibrated on the regions): 92.5 and 96.9 % there, the Panda's unchanged at 96.5 %.  The
band is still labelled **within one trajectory** (``trajectories == 1``; ``regions``: the posture
regions held out, 0 where they could not be had and the blocks' band with its leverage gain
stands): ``validate`` says it has not seen how another trajectory differs.

Flags calibrated on the same hold-outs
--------------------------------------
``validate``'s per-sample flags (:mod:`.coverage`) include a leverage threshold per joint,
``flag_leverage``: the :data:`FLAG_LEVEL` conformal quantile of the held-out samples' leverage
ratios ``u`` (the held-out trajectories' when there are two or more, else the blocks'), each
against the Gram matrix of the data its refit saw.  A new sample beyond it is farther from the
fit data than 99 % of the samples the band was calibrated on: the band has not been checked
there.  (The older rule, "beyond every fitted sample", compared a new sample with the fit data
themselves, whose own leverage is small by construction, and flagged nearly everything on a
new trajectory.)

``PredictionBand.half_width`` stays the width at a typical fitted sample (``u = 1``);
:meth:`PredictionBand.interval` takes ``u`` per sample.

The numbers travel with the model in its trust record (:mod:`manipdyn.formats.trust`:
``prediction_band``, :meth:`.band_record.PredictionBand.to_dict`), and as a line of a model file's
``[sources]`` (:meth:`.band_record.PredictionBand.to_text`) for the reader.
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError
from .band_record import WITHIN_ONE_TRAJECTORY, PredictionBand
from .conformal import GAIN_BENEFIT, GAINS, conformal_half_width, leverage_gain, slow_fields, slow_speeds  # noqa: F401

__all__ = ["PredictionBand", "calibrate_band", "held_out_residuals", "held_out_leverage", "DEFAULT_FOLDS",
           "DEFAULT_LEVEL", "GAINS", "FLAG_LEVEL", "WITHIN_ONE_TRAJECTORY"]

DEFAULT_FOLDS = 5
DEFAULT_LEVEL = 0.95
#: a held-out block shorter than this many samples is too short to say anything
MIN_BLOCK = 20
#: the held-out leverage quantile past which a sample is flagged (module docstring)
FLAG_LEVEL = 0.99
def _blocks(N: int, folds: int) -> np.ndarray:
    if int(folds) != folds or folds < 2:
        raise ModelError(f"folds: expected an integer >= 2, got {folds!r}")
    edges = np.linspace(0, N, int(folds) + 1).astype(int)
    if np.min(np.diff(edges)) < MIN_BLOCK:
        raise ModelError(f"data: {N} samples are too few for {folds} blocks of at least {MIN_BLOCK}")
    return edges


def _kept_segments(segments, test) -> list | None:
    """The runs' sample counts (``segments``) left after removing the ``test`` samples (empty runs dropped)."""
    if segments is None:
        return None
    edges = np.concatenate([[0], np.cumsum([int(k) for k in segments])])
    if edges[-1] != len(test):
        raise ModelError(f"segments: expected sample counts adding up to the {len(test)} samples, "
                         f"got {list(segments)}")
    kept = [int(np.sum(~test[a:b])) for a, b in zip(edges[:-1], edges[1:])]
    return [k for k in kept if k > 0]


def _masks(N: int, folds: int, masks, segments=None) -> list:
    """The folds' test samples: ``masks`` as given, else ``folds`` blocks in time; with several runs
    (``segments``, their sample counts) block k is the k-th part of **every** run, so a run that repeats
    another's trajectory is held out with it at the same phase (a refit that kept the repeat's block would
    have seen the held-out states)."""
    if masks is not None:
        return list(masks)
    counts = [int(c) for c in segments] if segments is not None and len(segments) > 1 else [N]
    if sum(counts) != N:
        raise ModelError(f"segments: expected sample counts adding up to the {N} samples, got {counts}")
    out = [np.zeros(N, dtype=bool) for _ in range(int(folds))]
    start = 0
    for c in counts:
        edges = _blocks(c, folds) if len(counts) == 1 or c >= MIN_BLOCK * folds else np.linspace(0, c, int(folds) + 1).astype(int)
        for k in range(int(folds)):
            out[k][start + edges[k]:start + edges[k + 1]] = True
        start += c
    return out


def held_out_residuals(arm, q, qd, qdd, tau, folds: int = DEFAULT_FOLDS, segments=None, masks=None,
                       refits: list | None = None, **fit_kwargs) -> np.ndarray:
    """Measured minus predicted torque (N, n), each block predicted by a fit on the others.

    ``q, qd, qdd, tau`` (N, n) in time order (one log; several logs: stacked in order, a block
    then may span a boundary, which is harmless: every sample is still predicted by a fit that
    did not see it).  ``segments``: the stacked runs' sample counts, when the fit takes them
    (each refit gets the counts of what it keeps).  ``fit_kwargs`` go to
    :func:`manipdyn.identification.fit` (``method``, ``friction``, ``armature``, ``bounds``,
    ``prior_weight``, ``rest``): the refits are the fit the user asked for, on less data (with ``rest``, a
    joint at rest still and out of its rows, as in the fit, and predicted still).  ``masks``: the
    folds' test samples, (N,) bool each, partitioning the samples (the held-out trajectories),
    instead of ``folds`` blocks in time.  ``refits``: a list to which each fold's ``(test, arm)`` is
    appended, ``test`` its held-out samples (N,) bool and ``arm`` the refit's arm (None when its
    parameters are no physical arm), for the collision thresholds, which watch the same hold-outs
    through the observer of the same refits (:mod:`manipdyn.control.collision.holdouts`).
    """
    from ..estimation.fitting import fit, known_torque, still_rows

    q, qd, qdd, tau = (np.asarray(x, dtype=np.float64) for x in (q, qd, qdd, tau))
    N = len(q)
    res = np.empty_like(tau)
    armature, friction = fit_kwargs.get("armature", False), fit_kwargs.get("friction", False)
    still, _ = still_rows(qd, fit_kwargs.get("rest"))    # the rows the fit builds: a joint at rest still
    Y = arm.lagrange.regressor(q, still, qdd, armature=armature, friction=friction)   # once, sliced per fold
    known = known_torque(arm, still, qdd, armature, friction)
    for test in _masks(N, folds, masks, segments):
        kept = _kept_segments(segments, test)
        extra = {} if kept is None else {"segments": kept}
        r = fit(arm, q[~test], qd[~test], qdd[~test], tau[~test], **fit_kwargs, **extra, complete=False,
                regressor=Y[~test])
        res[test] = tau[test] - (r.base.regressor(Y[test]) @ r.beta + known[test])     # r.predict, from the sliced Y
        if refits is not None:
            refits.append((test, r.arm))
    return res


def held_out_leverage(arm, q, qd, qdd, folds: int, weights, smoothing, masks=None, segments=None) -> np.ndarray:
    """The leverage ratio ``u`` (N, n) of each held-out sample against the rows of the blocks its refit saw
    (:mod:`.leverage`; the blocks, or the ``masks``, of :func:`held_out_residuals`), over their own mean."""
    from .leverage import features, gram_basis

    Z = features(arm, q, qd, qdd, smoothing)
    u = np.empty(Z.shape[:2])
    w = np.asarray(weights, dtype=np.float64)
    for test in _masks(len(Z), folds, masks, segments):
        B, scale = gram_basis(Z[~test], w)
        h_fit = w**2 * np.sum(((Z[~test] / scale) @ B) ** 2, axis=2)
        h = w**2 * np.sum(((Z[test] / scale) @ B) ** 2, axis=2)
        u[test] = h / np.maximum(np.mean(h_fit, axis=0), 1e-300)
    return u


def _at_rest(qd, rest) -> np.ndarray:
    """(N, n) bool: the joints at rest at the fit's ``rest`` threshold (none without one): their torque holds a
    static friction the moving band does not describe (:mod:`manipdyn.model.friction_rest`)."""
    from ...model.friction_rest import rest_mask

    return np.zeros(np.shape(qd), dtype=bool) if rest is None else rest_mask(qd, rest)


def _weights(rms) -> np.ndarray:
    return 1.0 / np.maximum(rms, 1e-12 * max(float(np.max(rms)), 1e-300))


def calibrate_band(arm, q, qd, qdd, tau, folds: int = DEFAULT_FOLDS, level: float = DEFAULT_LEVEL,
                   smoothing: float | None = None, leverage: bool = True, labels=None, regions: bool = True,
                   refits: dict | None = None, notes: list | None = None,
                   **fit_kwargs) -> PredictionBand:
    """The :class:`PredictionBand` of a fit on ``q, qd, qdd, tau`` (N, n) by blocked hold-outs, and by held-out
    trajectories when ``labels`` (N,) gives two or more groups, else by held-out posture regions where they
    can be had (module docstring).

    With ``leverage`` (default) the half-width of a single trajectory's band grows with each sample's
    leverage ratio where the held-out errors say it should, and ``flag_leverage`` is calibrated (module
    docstring; ``smoothing`` v_s of the features, rad/s, default 0.01); without, a constant band per
    joint.  ``regions`` False: no posture regions, a single trajectory's band from the blocks alone (the
    within-run band).  Costs ``folds`` refits, and one per held-out group or posture region.  ``refits``: a
    dict that receives the refits' ``(test, arm)`` pairs (:func:`held_out_residuals`) under ``"blocks"``
    and, with two or more groups, ``"trajectories"`` (not the posture regions': scattered in time, they are
    no span an observer can watch).  When the other trajectories cannot be fitted without one of them (a
    run that alone leaves a base parameter unexcited), the band is one trajectory's, and ``notes`` (a list)
    receives the line that says why.  Raises :class:`ModelError` when the data is too short for the
    blocks or a block's refit fails.
    """
    if not 0 < float(level) < 1:
        raise ModelError(f"level: expected a fraction in (0, 1), got {level}")
    kept = None if refits is None else refits.setdefault("blocks", [])
    still = _at_rest(qd, fit_kwargs.get("rest"))       # the moving band: the joints at rest score elsewhere
    speed, slow = slow_speeds(qd, still) if fit_kwargs.get("rest") is not None else (None, None)
    res = np.where(still, np.nan, held_out_residuals(arm, q, qd, qdd, tau, folds=folds, refits=kept, **fit_kwargs))
    rms = np.sqrt(np.nanmean(res**2, axis=0))
    groups = None if labels is None else np.unique(np.asarray(labels))
    if groups is not None and len(labels) != len(q):
        raise ModelError(f"labels: expected {len(q)} group labels, one per sample, got {len(labels)}")
    n_regions = 0
    res_t = None
    if groups is not None and len(groups) >= 2:
        masks = [np.asarray(labels) == g for g in groups]
        kept = None if refits is None else []
        try:
            res_t = held_out_residuals(arm, q, qd, qdd, tau, masks=masks, refits=kept, **fit_kwargs)
        except ModelError as exc:       # a trajectory left out leaves the others unable to fit alone
            if notes is not None:
                notes.append(f"band: the {len(groups)} trajectories cannot each be predicted by a fit on the others "
                             f"({exc}); the band is calibrated within the runs instead")
            groups = labels = None
        else:
            if refits is not None:
                refits["trajectories"] = kept
    if (groups is None or len(groups) < 2) and regions:    # one trajectory: its posture regions (module docstring)
        from ..inputs.trajectories import posture_regions

        labels = posture_regions(q)
        groups = None if labels is None else np.unique(labels)
        n_regions = 0 if groups is None else len(groups)
    if groups is not None and len(groups) >= 2:
        if res_t is None:           # the posture regions of one trajectory
            masks = [np.asarray(labels) == g for g in groups]
            res_t = held_out_residuals(arm, q, qd, qdd, tau, masks=masks, **fit_kwargs)
        res_t = np.where(still, np.nan, res_t)
        rms_t = np.sqrt(np.nanmean(res_t**2, axis=0))
        width = np.maximum(conformal_half_width(res_t, level), conformal_half_width(res, level))
        flag = None
        if leverage:
            u = held_out_leverage(arm, q, qd, qdd, folds, _weights(rms_t), smoothing, masks=masks)
            flag = conformal_half_width(u, FLAG_LEVEL)
        return PredictionBand(level=float(level), half_width=width, folds=int(folds), samples=len(res_t),
                              held_out_rms=rms_t, leverage_gain=np.zeros(len(width)) if leverage else None,
                              trajectories=1 if n_regions else len(groups), flag_leverage=flag, regions=n_regions,
                              **slow_fields(speed, slow, [res, res_t], level, width))
    if not leverage:
        width = conformal_half_width(res, level)
        return PredictionBand(level=float(level), half_width=width, folds=int(folds), samples=len(res),
                              held_out_rms=rms, **slow_fields(speed, slow, [res], level, width))
    u = held_out_leverage(arm, q, qd, qdd, folds, _weights(rms), smoothing, segments=fit_kwargs.get("segments"))
    gains, widths = np.zeros(res.shape[1]), np.zeros(res.shape[1])
    for j in range(res.shape[1]):
        g, c = leverage_gain(np.abs(res[:, j]), u[:, j], level)
        gains[j], widths[j] = g, c * np.sqrt(1.0 + g)          # the width at u = 1
    return PredictionBand(level=float(level), half_width=widths, folds=int(folds), samples=len(res),
                          held_out_rms=rms, leverage_gain=gains, flag_leverage=conformal_half_width(u, FLAG_LEVEL),
                          **slow_fields(speed, slow, [res], level, widths))
