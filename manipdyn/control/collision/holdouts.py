"""Collision thresholds from the model's own fit data: the band's blocked hold-outs, through the observer.

Layer 6 (control: collision).

The prediction band (:mod:`manipdyn.identification.uncertainty.bands`) cuts the fit data into
``folds`` contiguous blocks in time and predicts each from a fit on the others.  The thresholds
do the same, but score each block with the **momentum observer** of that refit on the log as it
was logged (nearly raw, :mod:`manipdyn.control.collision.reading`): the band's residuals live on identify's filtered and
decimated data (a cut-off of a few Hz), where the observer's noise is not, and thresholds read
off them would be several times too low.

* the log is checked against the model's trust record (file sha256), and read twice: as
  ``identify`` read it (the record's ``t_range``, the reader's default filter) for the refits, and
  nearly raw for the observer;
* each refit is :func:`manipdyn.identification.fit` with the record's ``method``, ``friction`` and
  ``armature``, the model itself as prior (its kinematics and drive);
* the observer of refit k runs on block k's time span only (it starts there, ``r = 0``), and the
  thresholds are :func:`~manipdyn.identification.uncertainty.thresholds.fit_thresholds` of the
  blocks' residuals together.
"""

from __future__ import annotations

import os

import numpy as np

from ..._support.errors import ModelError
from ...identification.uncertainty.bands import DEFAULT_FOLDS
from ...identification.uncertainty.thresholds import (DEFAULT_GAIN, DEFAULT_HYSTERESIS, DEFAULT_MIN_DURATION,
                                                      DEFAULT_RATE, CollisionThresholds, fit_thresholds)
from .observer import check_gain, momentum_residual
from .reading import read_observed

__all__ = ["held_out_thresholds"]


def _fit_options(record) -> dict:
    opts = dict(record.get("options") or {})
    friction = opts.get("friction", False)
    terms = opts.get("friction_terms")
    if terms:
        friction = tuple(str(t).strip() for t in str(terms).split(",") if str(t).strip())
    return {"method": str(record.get("method") or opts.get("method") or "consistent"),
            "friction": friction if isinstance(friction, (bool, tuple)) else bool(friction),
            "armature": bool(opts.get("armature", False))}


def held_out_thresholds(arm, log, gain: float = DEFAULT_GAIN, false_alarms: float = DEFAULT_RATE, *,
                        folds: int = DEFAULT_FOLDS, min_duration: float = DEFAULT_MIN_DURATION,
                        hysteresis: float = DEFAULT_HYSTERESIS, check_sha256: bool = True) -> CollisionThresholds:
    """Thresholds from blocked hold-outs of the log ``log`` that ``arm`` (a model from ``identify``, with its
    trust record) was fitted on (module docstring).  Raises :class:`ModelError` when the model has no
    trust record, or the log is not its fit data (sha256), or a refit fails."""
    from ...formats.logs.read import read_log
    from ...identification.estimation.fitting import fit
    from ...identification.results.provenance import file_sha256

    K = check_gain(gain)
    record = getattr(arm, "trust", None)
    if not isinstance(record, dict):
        raise ModelError("fit data: the model has no trust record (it was not identified by manipdyn identify); "
                         "give collision-free logs it was not fitted on instead (calibrate=, --calibrate)")
    where = os.fspath(log)
    if check_sha256 and record.get("data_sha256"):
        sha = file_sha256(where)
        if sha not in str(record["data_sha256"]).split(", "):
            raise ModelError(f"fit data {where}: sha256 {sha[:16]}... is not the model's fit data "
                             f"({record.get('data')}, sha256 {str(record['data_sha256'])[:16]}...)")
    opts = dict(record.get("options") or {})
    t_range = opts.get("t_range")
    t_range = None if t_range is None else tuple(None if x in (None, "none") else float(x) for x in t_range)
    read = {k: opts[k] for k in ("time_scale", "rate", "columns") if opts.get(k) is not None}
    data = read_log(where, arm.n, transmission=getattr(arm, "transmission", None), t_range=t_range, **read)
    (raw,) = read_observed(arm, where, t_range=t_range, **read)
    edges = np.linspace(data.t[0], data.t[-1], int(folds) + 1)
    edges[-1] = np.inf
    kwargs = _fit_options(record)
    parts = []
    for k in range(int(folds)):
        test = (data.t >= edges[k]) & (data.t < edges[k + 1])
        res = fit(arm, data.q[~test], data.qd[~test], data.qdd[~test], data.tau[~test], **kwargs)
        if res.arm is None:
            raise ModelError(f"fit data: the refit without block {k + 1} gives no arm ({res.arm_error})")
        inside = (raw.t >= edges[k]) & (raw.t < edges[k + 1])
        if np.sum(inside) < 10:
            raise ModelError(f"fit data: block {k + 1} holds {int(np.sum(inside))} samples; fewer folds")
        parts.append(momentum_residual(res.arm, raw.q[inside], raw.qd[inside], raw.tau[inside], raw.dt, K))
    return fit_thresholds(np.vstack(parts), raw.dt, false_alarms, gain=K, min_duration=min_duration,
                          hysteresis=hysteresis, source=f"{folds} blocked hold-outs of the fit data {record.get('data')}")
