"""The Coulomb smoothing chosen by held-out error: blocked hold-outs of the fit data.

Layer 5 (identification), room ``inputs``.

The smoothed sign ``tanh(v / v_s)`` of the Coulomb term has one number that the linear fit
cannot estimate, ``v_s``.  It used to be the velocity's noise level measured on the log
(:func:`.choices.coulomb_smoothing`), a criterion about the sensor, not about the model: on
an arm whose filter removes vibration as well as noise the measured "noise" was 0.0022 rad/s,
and a wrist joint predicted another run at 0.90 N m where ``v_s = 1e-4`` gave 0.58.  What
decides is the error on data the fit did not see, which the blocked hold-outs measure
already (:mod:`..uncertainty.bands`, :mod:`..estimation.selection`).  So
:func:`choose_smoothing` tries, in two rounds,

    ``v_0 x (1/10, 1, 10)``, then the best of these ``x (1/3, 3)``

(``v_0`` the noise-level choice, which stays the starting point and the **default**: five fits
cover ``v_0 / 30`` to ``30 v_0`` on a grid of factors of about 3), fits each on all folds but
one with the user's method and options, predicts the one left out, and scores each fold by

    ``mean over joints of log(held-out RMS_j)``

(every joint counts alike whatever its torque scale; the prior weight's criterion).  The folds
are the held-out trajectories when the runs hold two or more (``labels``,
:mod:`.trajectories`: a fit on some trajectories predicting another, which is what the next
run asks), else five contiguous blocks of the fit data.  A candidate replaces ``v_0`` only when
it beats it by more than one standard error of the paired fold differences
(:func:`..estimation.selection.one_se_choice`): on a 6-joint arm the blocked hold-outs picked ten
times the noise level for a gain of 0.006, well inside that spread, and two joints then predicted
a point-to-point run worse.  The single note lists every candidate with its score, its gain and
spread, and the choice; ``--smoothing`` overrides all of it.

Cost: ``5 x folds`` fits (folds: blocks or trajectories), each on precomputed per-block least-squares factors (the rigid-body
regressor of the whole window is built once, each candidate adds its friction columns; no fit
runs a QR over the samples).
The runs' separate noise weights are not used inside the folds (one weight per joint over the
stacked data), which changes the fits a little, not the ranking they are used for.
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError

__all__ = ["choose_smoothing", "smoothing_candidates", "FACTORS"]

#: the first round of candidates, as multiples of the noise-level choice ...
FACTORS = (0.1, 1.0, 10.0)
#: ... and the second, as multiples of the first round's best
REFINE = (1 / 3, 3.0)


def smoothing_candidates(v0: float, best: float | None = None) -> list[float]:
    """The candidate ``v_s`` (rad/s), ascending: the first round ``v0`` times :data:`FACTORS` (``best`` None),
    the second round the first round's ``best`` times :data:`REFINE`, rounded to 3 digits."""
    if best is None:
        return sorted({float(f"{v0 * f:.3g}") for f in FACTORS})
    return sorted({float(f"{best * f:.3g}") for f in REFINE})


def choose_smoothing(arm, data, law_of, v0: float, folds: int = 5, progress=None, labels=None, rest=None,
                     **fit_kwargs) -> tuple[float, list, str]:
    """``(v_s, table, note)``: the Coulomb smoothing with the lowest blocked held-out error (module docstring).

    ``data``: the stacked Measurements (``q, qd, qdd, tau`` (N, n)); ``law_of(v)``: the friction law
    (what :func:`.fit` takes as ``friction=``) with smoothing ``v``; ``v0``: the noise-level choice,
    rad/s; ``labels`` (N,): the held-out group of each sample (two or more: the folds are the groups);
    ``rest`` (n,), a function of ``v`` giving it, or None: the fit's rest threshold (:mod:`.rest`; a function
    where it follows the smoothing: a log with no measured velocity noise): each refit keeps a joint at rest
    still and out of its rows as the fit does, and the held-out scores leave its rest samples out (a static friction no
    candidate models; at rest no smoothing changes the prediction);
    ``fit_kwargs``: ``method``, ``armature``, ``bounds``, ``prior_weight``.  ``table``: one
    ``{"smoothing", "score", "fold_scores", "gain", "spread", "rms"}`` per candidate (``rms`` (n,), N m).  A candidate whose fits
    fail is left out (the table says why); all failing: a :class:`ModelError`.
    """
    from ..estimation.base import base_parameters
    from ..estimation.fitting import fit, known_torque, moving_mean_square, still_rows
    from ..estimation.selection import describe_choice, fold_factors, fold_kind, fold_masks, one_se_choice
    from ...model.parameters import with_extra_columns

    q, qd, qdd, tau = (np.asarray(x, dtype=np.float64) for x in (data.q, data.qd, data.qdd, data.tau))
    N = len(q)
    try:
        masks = fold_masks(N, folds, labels, least=20, segments=getattr(data, "segments", None))
    except ModelError as exc:
        raise ModelError(f"{exc} to choose the smoothing") from None
    armature = fit_kwargs.get("armature", False)
    rigid = {}                                         # the rigid-body columns, common to the candidates

    def rows(v):
        """``(threshold, qd, keep, Y0)`` of candidate ``v``: the fit's rows, a joint at rest still and out."""
        threshold = rest(v) if callable(rest) else rest
        still, keep = still_rows(qd, threshold)
        key = None if threshold is None else np.asarray(threshold, dtype=np.float64).tobytes()
        if key not in rigid:
            rigid[key] = arm.lagrange.regressor(q, still, qdd)
        return threshold, still, keep, rigid[key]

    table = []

    def score(v):
        law = law_of(v)
        try:
            threshold, still, keep, Y0 = rows(v)
            base = base_parameters(arm, armature=armature, friction=law)
            Y = with_extra_columns(Y0, still, qdd, armature, law, arm.transmission)
            known = known_torque(arm, still, qdd, armature, law)
            Yb = base.regressor(Y)
            train = fold_factors(Yb, tau - known, masks) if keep is None else \
                fold_factors(Yb * keep[:, :, None], (tau - known) * keep, masks)
            sq, fold_scores = np.zeros(q.shape[1]), []
            for f, test in enumerate(masks):
                r = fit(arm, q[~test], qd[~test], qdd[~test], tau[~test], friction=law, base=base,
                        regressor=Y[~test], factors=train[f], complete=False, rest=threshold, **fit_kwargs)
                err = tau[test] - Yb[test] @ r.beta - known[test]
                if keep is not None:             # at rest: a static friction no candidate models
                    err = np.where(keep[test], err, 0.0)
                sq += np.sum(err ** 2, axis=0)
                ms = moving_mean_square(err, None if keep is None else keep[test])
                fold_scores.append(float(np.mean(np.log(np.maximum(np.sqrt(ms), 1e-300)))))
        except ModelError as exc:
            table.append({"smoothing": v, "score": None, "rms": None, "error": str(exc)})
            return
        finally:
            if progress is not None:
                progress()
        rms = np.sqrt(sq / (N if keep is None else np.maximum(np.sum(keep, axis=0), 1)))
        table.append({"smoothing": v, "score": float(np.mean(fold_scores)), "fold_scores": fold_scores,
                      "rms": [float(x) for x in rms]})

    def best_so_far():
        scored = [row for row in table if row["score"] is not None]
        return min(scored, key=lambda row: (row["score"], -row["smoothing"]))["smoothing"] if scored else None

    for v in smoothing_candidates(v0):
        score(v)
    if best_so_far() is not None:
        for v in smoothing_candidates(v0, best_so_far()):
            if all(row["smoothing"] != v for row in table):
                score(v)
    table.sort(key=lambda row: row["smoothing"])
    scored = [row for row in table if row["score"] is not None]
    if not scored:
        if labels is not None and len(np.unique(np.asarray(labels))) >= 2:
            # a trajectory held out leaves the others unable to fit alone (a run that never moves a joint): the
            # choice within the runs, blocks in time, as the band then is (uncertainty/bands.py), and said so
            why = table[0]["error"]
            v, table, note = choose_smoothing(arm, data, law_of, v0, folds=folds, progress=progress, labels=None,
                                              rest=rest, **fit_kwargs)
            return v, table, (f"{note} (the trajectories cannot each be predicted by a fit on the others: {why}; "
                              "blocks in time instead)")
        raise ModelError("smoothing: every candidate's fit failed: " + "; ".join(row["error"] for row in table))
    default = float(f"{v0:.3g}")
    best, why = one_se_choice(table, "smoothing", default)
    note = describe_choice("Coulomb smoothing tanh(v / V): V =", " rad/s", table, "smoothing", best["smoothing"],
                           default, why + f" (default: the velocity's noise level on the log, {default:.3g} rad/s); "
                           "--smoothing to override", fold_kind(masks, labels))
    return best["smoothing"], table, note
