"""Choosing the prior weight of the consistent fit from the data alone: blocked cross-validation.

Layer 5 (identification).

The entropic pull towards the prior (``fit(..., prior_weight=w)``) trades data against the
prior.  Which ``w`` predicts best is a question about data the fit has not seen, and the
held-out file a user scores on must not answer it (that would make the score a fit).  So the
fit window itself is cut into ``folds`` contiguous blocks in time (neighbouring samples are
correlated, so random folds would leak), each block is predicted by a fit on the others, and
the weight with the smallest score wins:

    score(w) = mean over joints of log(RMS_j(w))

(the log makes every joint count alike whatever its torque scale, and is the log-likelihood
of independent Gaussian joints up to constants).

Held-out runs, and a win that is not noise
------------------------------------------
With several runs of distinct trajectories (``labels``: the group of each sample, the runs
that repeat one trajectory held out together, :mod:`..inputs.trajectories`), the folds are
those groups instead of blocks in time: a weight is judged on how a fit on some trajectories
predicts another, the question a user's next run asks.  Either way each fold has its own
score (``mean over joints of log RMS_j`` on that fold), and a candidate replaces the
**default** (weight 0, the data alone) only when it wins by more than the spread of the
folds: when the mean over the folds of ``score_default - score_candidate`` exceeds its
standard error (:func:`one_se_choice`, paired by fold, since the folds differ in difficulty
far more than the candidates do), and by at least :data:`MIN_GAIN` (0.005 in mean log RMS, half a percent
of the held-out error: less changes no prediction a user would see, and with two folds the standard
error of two differences can itself be next to nothing).  A candidate that wins by less than that is noise: on a
6-joint arm a Coulomb smoothing ten times the noise level won by 0.006 in score, well inside
the folds' spread, and predicted the next run worse.  Among the candidates that clear it, the
best mean score is taken.

Cost: ``len(weights) x folds`` consistent fits (25 by default).  What does not depend on the
fold or the weight is done once: the base parameters (a pivoted QR of the regressor at random
states, :func:`.base.base_parameters`, which every fit used to recompute), the regressor of the
whole window, which each fold slices, and the least-squares reduction: each block's per-joint
triangular factors (:func:`.fitting.joint_factors`, one QR over the samples), which stack
into each fold's training factors with a small QR, so no fit runs a QR over the samples.
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError

__all__ = ["choose_prior_weight", "DEFAULT_WEIGHTS", "fold_masks", "one_se_choice", "describe_choice",
           "fold_factors", "fold_kind", "MIN_GAIN"]

#: the weights tried by default (0: the data alone)
DEFAULT_WEIGHTS = (0.0, 0.01, 0.1, 1.0, 10.0)
#: the least gain in score (mean log held-out RMS) that lets a candidate replace the default (module docstring)
MIN_GAIN = 0.005


def fold_masks(N: int, folds: int = 5, labels=None, least: int = 2, segments=None) -> list[np.ndarray]:
    """The test samples of each fold, (N,) bool each: the groups of ``labels`` (N,) when it has two or more
    (held-out trajectories), else ``folds`` contiguous blocks in time of at least ``least`` samples; with
    several runs (``segments``, their sample counts) block k is the k-th part of every run (runs repeating
    one trajectory are held out at the same phase together)."""
    if labels is not None:
        labels = np.asarray(labels)
        if len(labels) != N:
            raise ModelError(f"labels: expected {N} group labels, one per sample, got {len(labels)}")
        groups = np.unique(labels)
        if len(groups) >= 2:
            return [labels == g for g in groups]
    if int(folds) != folds or folds < 2:
        raise ModelError(f"folds: expected an integer >= 2, got {folds!r}")
    counts = [int(c) for c in segments] if segments is not None and len(segments) > 1 else [N]
    if sum(counts) != N:
        raise ModelError(f"segments: expected sample counts adding up to the {N} samples, got {counts}")
    edges = np.linspace(0, N, int(folds) + 1).astype(int)
    if np.min(np.diff(edges)) < least:
        raise ModelError(f"data: {N} samples are too few for {folds} folds of at least {least}")
    out = [np.zeros(N, dtype=bool) for _ in range(int(folds))]
    start = 0
    for c in counts:
        e = np.linspace(0, c, int(folds) + 1).astype(int)
        for k in range(int(folds)):
            out[k][start + e[k]:start + e[k + 1]] = True
        start += c
    return out


def one_se_choice(table, key: str, default) -> tuple[dict, str]:
    """``(row, why)``: the row of ``table`` (rows with ``key``, ``score`` and ``fold_scores``; a failed
    candidate's ``score`` None) to use: the default's unless a candidate beats it by more than one standard
    error of the paired fold differences (module docstring).  Each row gets ``gain`` (mean of
    ``score_default - score``) and ``spread`` (its standard error) added."""
    ok = [row for row in table if row.get("score") is not None]
    base = next((row for row in ok if row[key] == default), None)
    if base is None:             # the default failed or was not tried: the best score
        best = min(ok, key=lambda row: row["score"])
        return best, "the default was not scored"
    d0 = np.asarray(base["fold_scores"], dtype=np.float64)
    winners = []
    for row in ok:
        d = d0 - np.asarray(row["fold_scores"], dtype=np.float64)
        row["gain"] = float(np.mean(d))
        row["spread"] = float(np.std(d, ddof=1) / np.sqrt(len(d))) if len(d) > 1 else float("inf")
        if row is not base and row["gain"] > max(row["spread"], MIN_GAIN):
            winners.append(row)
    if not winners:
        return base, (f"no candidate beats the default by more than one standard error of the folds and "
                      f"{MIN_GAIN:g}")
    best = min(winners, key=lambda row: row["score"])
    return best, (f"it beats the default by {best['gain']:.4f} in score, more than one standard error of the "
                  f"folds ({best['spread']:.4f}) and {MIN_GAIN:g}")


def describe_choice(what: str, unit: str, table, key: str, chosen, default, why: str, how: str) -> str:
    """One note: every candidate with its score, its gain over the default +- spread, the choice and why."""
    def cell(row):
        if row.get("score") is None:
            return f"{row[key]:.3g}{unit}: failed"
        return (f"{row[key]:.3g}{unit}: score {row['score']:.4f}"
                + (f", gain {row['gain']:+.4f} +- {row['spread']:.4f}" if "gain" in row and row[key] != default
                   else " (default)" if row[key] == default else ""))
    return (f"{what} {chosen:.3g}{unit} chosen by {how} (score: mean over the folds of the mean over the joints of "
            "log held-out RMS, lower is better; gain: the default's score minus the candidate's, +- its standard "
            "error over the folds): " + "; ".join(cell(row) for row in table)
            + f" -> {chosen:.3g}{unit}, {why}")


def fold_kind(masks, labels) -> str:
    """How the folds were cut, for the notes."""
    if labels is not None and len(np.unique(labels)) >= 2:
        return f"held-out trajectories ({len(masks)} groups of runs, each predicted by a fit on the others)"
    return f"{len(masks)}-fold blocked hold-outs of the fit data"


#: blocks of :func:`choose_prior_weight` when the runs do not give two or more held-out groups
PRIOR_WEIGHT_FOLDS = 5


def choose_prior_weight(arm, q, qd, qdd, tau, weights=DEFAULT_WEIGHTS, folds: int = PRIOR_WEIGHT_FOLDS, labels=None,
                        segments=None, **fit_kwargs):
    """``(best_weight, table)``: the prior weight of ``consistent`` by blocked cross-validation.

    Parameters
    ----------
    arm : manipdyn.Arm
        The prior.
    q, qd, qdd, tau : (N, n)
        The fit window's samples, in time order.
    weights : sequence of float
        Candidate weights (each >= 0).
    folds : int
        Contiguous blocks (>= 2), when ``labels`` does not give two or more groups.
    labels : (N,) ints, optional
        The held-out group of each sample (runs repeating one trajectory share one); two or more
        groups make the folds the groups (module docstring).
    segments : sequence of int, optional
        The stacked runs' sample counts: the blocks then cut every run (:func:`fold_masks`).
    **fit_kwargs
        Passed to :func:`manipdyn.identification.fit` (``friction``, ``armature``, ``bounds``).

    ``table`` is a list of ``{"prior_weight", "score", "fold_scores", "gain", "spread", "rms"}``
    (``rms`` per joint, N m, pooled over the folds); the weight is the default 0 unless another
    beats it by more than one standard error of the folds (:func:`one_se_choice`).
    """
    from .base import base_parameters
    from .fitting import fit, known_torque

    weights = [float(w) for w in weights]
    if not weights or any(not (0 <= w < float("inf")) for w in weights):
        raise ModelError(f"weights: expected finite numbers >= 0, got {weights}")
    q, qd, qdd, tau = (np.asarray(x, dtype=np.float64) for x in (q, qd, qdd, tau))
    N = len(q)
    masks = fold_masks(N, folds, labels, segments=segments)
    armature, friction = fit_kwargs.get("armature", False), fit_kwargs.get("friction", False)
    base = fit_kwargs.pop("base", None) or base_parameters(arm, armature=armature, friction=friction)
    Y = arm.lagrange.regressor(q, qd, qdd, armature=armature, friction=friction)     # (N, n, p)
    known = known_torque(arm, qd, qdd, armature, friction)
    Yb = base.regressor(Y)
    train = fold_factors(Yb, tau - known, masks)
    table = []
    for w in weights:
        sq, fold_scores = np.zeros(q.shape[1]), []
        for f, test in enumerate(masks):
            r = fit(arm, q[~test], qd[~test], qdd[~test], tau[~test], method="consistent",
                    prior_weight=w, base=base, regressor=Y[~test], factors=train[f], **fit_kwargs)
            pred = base.regressor(Y[test]) @ r.beta + known[test]       # r.predict, from the sliced Y
            e2 = np.sum((tau[test] - pred) ** 2, axis=0)
            sq += e2
            fold_scores.append(float(np.mean(np.log(np.maximum(np.sqrt(e2 / np.sum(test)), 1e-300)))))
        rms = np.sqrt(sq / N)
        table.append({"prior_weight": w, "score": float(np.mean(fold_scores)), "fold_scores": fold_scores,
                      "rms": [float(x) for x in rms]})
    best, _ = one_se_choice(table, "prior_weight", 0.0 if 0.0 in weights else min(weights))
    return best["prior_weight"], table


def fold_factors(Yb, y, masks) -> list[np.ndarray]:
    """Each fold's training factors (:func:`.fitting.joint_factors` of the samples outside its mask), built from
    the folds' own factors with one small QR per joint (no QR over the samples per fold)."""
    from .fitting import joint_factors

    blocks = [joint_factors(Yb[m], y[m]) for m in masks]
    train = []
    for f in range(len(masks)):
        rest = np.concatenate([blocks[b] for b in range(len(masks)) if b != f], axis=1)    # (n, k (r+1), r+1)
        F = np.zeros_like(blocks[f])
        for j in range(F.shape[0]):
            Rj = np.linalg.qr(rest[j], mode="r")
            F[j, :Rj.shape[0]] = Rj
        train.append(F)
    return train
