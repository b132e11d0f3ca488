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

Torque and forward dynamics: the prior weight's score
-----------------------------------------------------
Torque alone cannot choose the prior weight: the directions a simulation divides by (a wrist's inertia
about its axis, which a slow log hardly accelerates) make almost no torque, so every held-out block
scores the data-alone fit best, and that fit is the worst simulator (Panda: replay error at 50 ms
1.02e-2 rad pooled against 6.49e-3 for the published model, joint 7's ``D_77`` at 8e-4 kg m^2 against
4.9e-3).  A replay score alone is no better: a model that damps everything drifts little (the LWR4's
weight-1 fit, 32 N m s/rad of viscous friction on joint 6 and 292 N m of torque error, replayed better
than the default).  So each fold scores both, on the same held-out samples:

    fold score(w) = mean over joints of log RMS_j(tau error) + mean over joints of log RMS_j(qdd error)

with the acceleration error ``M(q)^-1 (tau - tau_hat)`` on the candidate's own mass matrix (the forward
dynamics' error at the logged state, exactly: ``qdd_hat - qdd = M^-1 (tau - tau_hat(q, qd, qdd))``),
``M`` from the base regressor at ``qd = 0`` and unit accelerations (computed once per fold on up to
:data:`ACCEL_SAMPLES` of its samples, evenly spread; each candidate's ``M`` is then a product with its
``beta``).  The torque error is first averaged over :data:`ACCEL_HORIZON` (50 ms, the middle horizon of
``replay``) within each contiguous stretch of held-out samples: white torque noise integrates to almost
nothing in position over a simulation's horizon, while ``M^-1`` of it grows as ``M`` shrinks, so scoring it
raw rewards a heavier model for hiding the noise; averaged over ``w`` samples the noise's part shrinks by about
``sqrt(w)`` while a model error that follows the motion stays.  (On a synthetic UR5 whose wrist barely moves,
a prior 15 % off the truth and 0.02 N m of wrist noise at 100 Hz, both the raw and the averaged score choose
weight 0.1; on a noise-free new motion that fit's acceleration error on the wrist is 3.7 times the data
alone's there, because this prior is wrong where the data are silent: a pull can only be as good as its prior.)
A model whose masses inflate to hide its torque error pays in torque; one whose wrist is
too light pays in acceleration.  The one-standard-error rule above then applies to the sum, and a
candidate must also keep its pooled held-out torque RMS within :data:`TORQUE_SLACK` (5 %) of the default's on
average over the joints, and within twice that on every joint: the forward dynamics may not be bought with a
worse torque prediction.  (Measured on the real logs, ratios of each candidate's held-out torque RMS to the data
alone's: the Panda's weight 1 is at most 1.085 on a joint (joint 6) and 1.009 on average, and simulates best;
its weight 10, 1.151 on joint 6, is passed over.  A per-joint bound of 5 % alone passed over the Panda's weight
1 for that one joint and kept a model whose replay at 50 ms was 4.79e-3 rad pooled against weight 1's 3.64e-3.)
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError

__all__ = ["choose_prior_weight", "DEFAULT_WEIGHTS", "fold_masks", "one_se_choice", "describe_choice",
           "fold_factors", "fold_kind", "MIN_GAIN", "ACCEL_SAMPLES", "TORQUE_SLACK", "describe_weight_choice",
           "mass_matrix_regressor", "exclude_worse_torque", "horizon_mean", "ACCEL_HORIZON"]

#: the weights tried by default (0: the data alone)
DEFAULT_WEIGHTS = (0.0, 0.01, 0.1, 1.0, 10.0)
#: the least gain in score (mean log held-out RMS) that lets a candidate replace the default (module docstring)
MIN_GAIN = 0.005
#: held-out samples per fold on which the acceleration error is scored (module docstring)
ACCEL_SAMPLES = 200
#: the horizon (s) over which the torque error is averaged before it is turned into an acceleration error
ACCEL_HORIZON = 0.05
#: the most a candidate prior weight may raise the pooled held-out torque RMS over the default's, on average over the
#: joints (twice that on any one joint)
TORQUE_SLACK = 0.05


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
    ok = [row for row in ok if row is base or not row.get("excluded")]
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
                        segments=None, dt=None, **fit_kwargs):
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
    dt : float, optional
        The sample period (s): the torque error is averaged over :data:`ACCEL_HORIZON` before the acceleration
        error is scored (:func:`horizon_mean`); None scores it sample by sample.
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
    accel = [_accel_setup(arm, q[test], base, armature, friction) for test in masks]
    table = []
    for w in weights:
        sq, sa, count_a, fold_scores, fold_tau, fold_acc = np.zeros(q.shape[1]), np.zeros(q.shape[1]), 0, [], [], []
        failed = None
        for f, test in enumerate(masks):
            try:
                r = fit(arm, q[~test], qd[~test], qdd[~test], tau[~test], method="consistent",
                        prior_weight=w, base=base, regressor=Y[~test], factors=train[f], **fit_kwargs)
            except ModelError as exc:
                if w == 0.0:
                    raise               # the data alone must fit: their error is the user's to see
                failed = str(exc).splitlines()[0]
                break
            pred = base.regressor(Y[test]) @ r.beta + known[test]       # r.predict, from the sliced Y
            err = tau[test] - pred
            e2 = np.sum(err ** 2, axis=0)
            sq += e2
            ts = float(np.mean(np.log(np.maximum(np.sqrt(e2 / np.sum(test)), 1e-300))))
            a2 = _accel_error_sq(accel[f], r.beta, horizon_mean(err, test, dt))
            sa += a2
            count_a += len(accel[f][0])
            acs = float(np.mean(np.log(np.maximum(np.sqrt(a2 / len(accel[f][0])), 1e-300))))
            fold_tau.append(ts)
            fold_acc.append(acs)
            fold_scores.append(ts + acs)
        if failed is not None:       # a pull the solver cannot hold at this data's scale: passed over, said
            table.append({"prior_weight": w, "score": None, "fold_scores": None, "rms": None, "failed": failed})
            continue
        rms = np.sqrt(sq / N)
        table.append({"prior_weight": w, "score": float(np.mean(fold_scores)), "fold_scores": fold_scores,
                      "torque_score": float(np.mean(fold_tau)), "accel_score": float(np.mean(fold_acc)),
                      "rms": [float(x) for x in rms], "accel_rms": [float(x) for x in np.sqrt(sa / count_a)]})
    default = 0.0 if 0.0 in weights else min(weights)
    exclude_worse_torque(table, "prior_weight", default)
    best, _ = one_se_choice(table, "prior_weight", default)
    return best["prior_weight"], table


def exclude_worse_torque(table, key: str, default) -> None:
    """Mark (``row["excluded"]``, the reason) every candidate whose pooled held-out torque RMS (``row["rms"]``, per
    joint) is, against the default's, over :data:`TORQUE_SLACK` worse on average over the joints (geometric mean
    of the ratios) or over twice that on some joint: :func:`one_se_choice` then passes it over, whatever its
    forward dynamics."""
    ref = next((row for row in table if row[key] == default and row.get("rms") is not None), None)
    if ref is None:
        return
    base = np.maximum(np.asarray(ref["rms"], dtype=np.float64), 1e-300)
    for row in table:
        if row is ref or row.get("rms") is None:
            continue
        ratio = np.asarray(row["rms"], dtype=np.float64) / base
        mean = float(np.exp(np.mean(np.log(np.maximum(ratio, 1e-300)))))
        worse = [j + 1 for j, r in enumerate(ratio) if r > 1 + 2 * TORQUE_SLACK]
        if worse:
            row["excluded"] = (f"its held-out torque RMS is over {200 * TORQUE_SLACK:g} % above the default's on "
                               f"joint{'s' if len(worse) > 1 else ''} " + ", ".join(map(str, worse)))
        elif mean > 1 + TORQUE_SLACK:
            row["excluded"] = (f"its held-out torque RMS is {100 * (mean - 1):.1f} % above the default's on average "
                               f"over the joints (over {100 * TORQUE_SLACK:g} %)")


def horizon_mean(err, test, dt) -> np.ndarray:
    """``err`` (the fold's held-out samples, in time order) averaged over a centred window of :data:`ACCEL_HORIZON`
    within each contiguous stretch of ``test`` (a new run or a gap starts a new stretch); ``err`` as it is when
    ``dt`` is None or the window is one sample."""
    if dt is None or not dt > 0:
        return err
    w = int(round(ACCEL_HORIZON / float(dt)))
    if w < 2:
        return err
    idx = np.flatnonzero(test)
    breaks = np.flatnonzero(np.diff(idx) != 1) + 1
    out = np.empty_like(err)
    for a, b in zip(np.r_[0, breaks], np.r_[breaks, len(idx)]):
        seg = err[a:b]
        c = np.vstack([np.zeros((1, seg.shape[1])), np.cumsum(seg, axis=0)])
        k = np.arange(b - a)
        lo, hi = np.maximum(k - w // 2, 0), np.minimum(k - w // 2 + w, b - a)
        out[a:b] = (c[hi] - c[lo]) / (hi - lo)[:, None]
    return out


def mass_matrix_regressor(arm, q, base, armature, friction) -> np.ndarray:
    """``(S, n, n, r)``: ``M(q)[:, :, j] = out[:, :, j] @ beta`` for the base parameters ``beta`` (the regressor at
    ``qd = 0`` and the unit acceleration ``e_j``, less its value at ``qdd = 0``: gravity and friction cancel)."""
    q = np.asarray(q, dtype=np.float64)
    S, n = q.shape
    z = np.zeros_like(q)
    Y0 = arm.lagrange.regressor(q, z, z, armature=armature, friction=friction)
    out = np.empty((S, n, n, base.count))
    for j in range(n):
        e = np.zeros_like(q)
        e[:, j] = 1.0
        out[:, :, j, :] = base.regressor(arm.lagrange.regressor(q, z, e, armature=armature, friction=friction) - Y0)
    return out


def _accel_setup(arm, q_test, base, armature, friction):
    """``(idx, Ymm, Mknown)`` of one fold: up to :data:`ACCEL_SAMPLES` of its samples, evenly spread, their mass
    matrix regressor and the known (not identified) rotor inertia's part of ``M``."""
    from .fitting import known_torque

    k = len(q_test)
    idx = np.unique(np.linspace(0, k - 1, min(k, ACCEL_SAMPLES)).round().astype(int))
    qs = q_test[idx]
    n = qs.shape[1]
    z = np.zeros_like(qs)
    Mk = np.empty((len(idx), n, n))
    k0 = known_torque(arm, z, z, armature, friction)
    for j in range(n):
        e = np.zeros_like(qs)
        e[:, j] = 1.0
        Mk[:, :, j] = known_torque(arm, z, e, armature, friction) - k0
    return idx, mass_matrix_regressor(arm, qs, base, armature, friction), Mk


def _accel_error_sq(setup, beta, err) -> np.ndarray:
    """Per joint, the sum over the fold's scored samples of ``(M^-1 err)^2`` (rad^2/s^4), (n,); a candidate whose
    ``M`` is singular there scores infinity."""
    idx, Ymm, Mk = setup
    M = np.einsum("snjr,r->snj", Ymm, beta) + Mk
    try:
        a = np.linalg.solve(M, err[idx][..., None])[..., 0]
    except np.linalg.LinAlgError:
        return np.full(err.shape[1], np.inf)
    return np.sum(a ** 2, axis=0)


def describe_weight_choice(table, chosen, why: str, how: str) -> str:
    """The prior weight's note: every candidate with its torque and acceleration scores, its gain over the
    default +- spread (or why it was excluded), the choice and why."""
    def cell(row):
        w = row["prior_weight"]
        if row.get("score") is None:
            return f"{w:.3g}: failed ({row['failed']})" if row.get("failed") else f"{w:.3g}: failed"
        head = (f"{w:.3g}: torque {row['torque_score']:.3f}, acceleration {row['accel_score']:.3f}"
                if "torque_score" in row else f"{w:.3g}: score {row['score']:.4f}")
        if row.get("excluded"):
            return head + f" (excluded: {row['excluded']})"
        if "gain" in row and w != 0.0:
            return head + f", gain {row['gain']:+.4f} +- {row['spread']:.4f}"
        return head + (" (default)" if w == 0.0 else "")
    return (f"prior weight {chosen:.3g} chosen by {how} (score per fold: mean over the joints of log held-out "
            "torque RMS plus mean over the joints of log held-out acceleration error M^-1 (tau - tau_hat), "
            "lower is better; gain: the default's score minus the candidate's, +- its standard error over the "
            "folds): " + "; ".join(cell(row) for row in table) + f" -> {chosen:.3g}, {why}")


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
