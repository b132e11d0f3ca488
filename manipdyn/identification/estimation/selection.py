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
of independent Gaussian joints up to constants).  Ties go to the smaller weight (the data).

Cost: ``len(weights) x folds`` consistent fits (25 by default).  What does not depend on the
fold or the weight is done once: the base parameters (a pivoted QR of the regressor at random
states, :func:`.base.base_parameters`, which every fit used to recompute), the regressor of the
whole window, which each fold slices, and the least-squares reduction: each block's per-joint
triangular factors (:func:`.estimation.joint_factors`, one QR over the samples), which stack
into each fold's training factors with a small QR, so no fit runs a QR over the samples.
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError

__all__ = ["choose_prior_weight", "DEFAULT_WEIGHTS"]

#: the weights tried by default (0: the data alone)
DEFAULT_WEIGHTS = (0.0, 0.01, 0.1, 1.0, 10.0)


def choose_prior_weight(arm, q, qd, qdd, tau, weights=DEFAULT_WEIGHTS, folds: int = 5, **fit_kwargs):
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
        Contiguous blocks (>= 2).
    **fit_kwargs
        Passed to :func:`manipdyn.identification.fit` (``friction``, ``armature``, ``bounds``).

    ``table`` is a list of ``{"prior_weight", "score", "rms"}`` (``rms`` per joint, N m, pooled
    over the folds).
    """
    from .base import base_parameters
    from .fitting import fit, joint_factors, known_torque

    if int(folds) != folds or folds < 2:
        raise ModelError(f"folds: expected an integer >= 2, got {folds!r}")
    weights = [float(w) for w in weights]
    if not weights or any(not (0 <= w < float("inf")) for w in weights):
        raise ModelError(f"weights: expected finite numbers >= 0, got {weights}")
    q, qd, qdd, tau = (np.asarray(x, dtype=np.float64) for x in (q, qd, qdd, tau))
    N = len(q)
    edges = np.linspace(0, N, int(folds) + 1).astype(int)
    if np.min(np.diff(edges)) < 2:
        raise ModelError(f"data: {N} samples are too few for {folds} folds")
    armature, friction = fit_kwargs.get("armature", False), fit_kwargs.get("friction", False)
    base = fit_kwargs.pop("base", None) or base_parameters(arm, armature=armature, friction=friction)
    Y = arm.lagrange.regressor(q, qd, qdd, armature=armature, friction=friction)     # (N, n, p)
    known = known_torque(arm, qd, qdd, armature, friction)
    Yb = base.regressor(Y)
    blocks = [joint_factors(Yb[edges[b]:edges[b + 1]], (tau - known)[edges[b]:edges[b + 1]]) for b in range(int(folds))]
    train = []          # each fold's factors, stacked from the other blocks' (one small QR per joint)
    for f in range(int(folds)):
        rest = np.concatenate([blocks[b] for b in range(int(folds)) if b != f], axis=1)    # (n, k (r+1), r+1)
        F = np.zeros_like(blocks[f])
        for j in range(F.shape[0]):
            Rj = np.linalg.qr(rest[j], mode="r")
            F[j, :Rj.shape[0]] = Rj
        train.append(F)
    table = []
    for w in weights:
        sq = np.zeros(q.shape[1])
        for f in range(int(folds)):
            test = np.zeros(N, dtype=bool)
            test[edges[f]:edges[f + 1]] = True
            r = fit(arm, q[~test], qd[~test], qdd[~test], tau[~test], method="consistent",
                    prior_weight=w, base=base, regressor=Y[~test], factors=train[f], **fit_kwargs)
            pred = base.regressor(Y[test]) @ r.beta + known[test]       # r.predict, from the sliced Y
            sq += np.sum((tau[test] - pred) ** 2, axis=0)
        rms = np.sqrt(sq / N)
        table.append({"prior_weight": w, "score": float(np.mean(np.log(np.maximum(rms, 1e-300)))),
                      "rms": [float(x) for x in rms]})
    best = min(table, key=lambda row: (row["score"], row["prior_weight"]))
    return best["prior_weight"], table
