"""Collision thresholds from the model's own fit data: the band's hold-outs, watched through the observer.

Layer 6 (control: collision).

The prediction band (:mod:`manipdyn.identification.uncertainty.bands`) predicts each part of the fit
data by a refit on the rest: each **trajectory** held out when the runs hold two or more different
ones (runs repeating one trajectory held out together, :mod:`manipdyn.identification.inputs.trajectories`),
else ``folds`` contiguous **blocks** in time (block k the k-th part of every run).  The thresholds use
the same hold-outs and the same refits (the ``held_out`` of :class:`~manipdyn.identification.IdentifyResult`),
but score each held-out part with the **momentum observer** of its refit on the log as it was logged
(nearly raw, :mod:`manipdyn.control.collision.reading`): the band's residuals live on identify's
filtered and decimated data (a cut-off of a few Hz), where the observer's noise is not, and
thresholds read off them would be several times too low.

* :func:`identified_thresholds` takes an :func:`~manipdyn.identification.identify` result and its logs:
  the observer of refit k runs on the raw samples of each held-out part's time span (it starts there,
  ``r = 0``; the samples before the first and after the last filtered sample, which no fit saw, go
  to the first and last part), and the thresholds are
  :func:`~manipdyn.identification.uncertainty.thresholds.fit_thresholds` of the parts' residuals
  together; with held-out trajectories, at least the blocks' thresholds per joint, as the band takes
  at least the blocks' width (two or three trajectories may carry over well on a joint by chance).
  ``manipdyn identify`` writes them into the model's trust record (key ``collision``).
* :func:`held_out_thresholds` does the same for a model file and the logs it was fitted on (``observe
  --fit-data``): the logs are checked against the trust record (sha256), and ``identify`` is run again
  with the record's options (the chosen smoothing, side and prior weight as recorded) on the record's
  prior when it still loads (else on the model itself, which the source says): the same hold-outs
  and, from the same prior, the same refits.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import replace

import numpy as np

from ..._support.errors import ModelError
from ...identification.inputs.options import OptionError, brace_safe
from ...identification.uncertainty.bands import DEFAULT_FOLDS
from ...identification.uncertainty.thresholds import (DEFAULT_HYSTERESIS, DEFAULT_MIN_DURATION,
                                                      DEFAULT_RATE, CollisionThresholds, fit_thresholds,
                                                      leverage_factor)
from .extrapolation import choose_leverage_gain, leverage_ratios, model_reference, refit_reference
from .gain import choose_gain
from .observer import check_gain, check_velocity_cutoff, momentum_input, observer_output
from .reading import read_observed

__all__ = ["held_out_thresholds", "identified_thresholds", "READ_KEYS"]

#: identify's reading options that the observer's reading takes too (its own cut-off and no decimation)
READ_KEYS = ("columns", "deg", "rate", "time_scale", "resample", "t_range", "topic", "joint_names", "extra_joints")


def _spans(mask, t):
    """The contiguous held-out stretches of one run: ``[(t0, t1), ...]`` with ``-inf``/``inf`` at the run's ends."""
    idx = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    out = []
    for a, b in zip(idx[::2], idx[1::2]):
        out.append((-np.inf if a == 0 else t[a], np.inf if b == len(t) else t[b]))
    return out


def _names(sources) -> list[str]:
    return [os.path.basename(os.fspath(s)) if s else f"run {k + 1}" for k, s in enumerate(sources)]


def identified_thresholds(result, logs, gain: float | None = None, false_alarms: float = DEFAULT_RATE, *,
                          min_duration: float = DEFAULT_MIN_DURATION, hysteresis: float = DEFAULT_HYSTERESIS,
                          kind: str | None = None, velocity_cutoff: float | None = None,
                          **read_options) -> CollisionThresholds:
    """Thresholds from the hold-outs of an identification (module docstring).

    ``result``: an :class:`~manipdyn.identification.IdentifyResult` with its band's hold-outs
    (``band_folds`` > 0); ``logs``: the logs it was given (paths, RUNS.toml or LogSpecs, not arrays: the
    observer reads each file again, nearly raw); ``read_options``: identify's reading options
    (:data:`READ_KEYS`; others are ignored).  ``gain`` 1/s (None: chosen on the hold-outs for the smallest
    torque detected within 20 ms, :mod:`manipdyn.control.collision.gain`), ``false_alarms`` per hour, ``min_duration`` s
    and ``hysteresis`` as :func:`~manipdyn.control.collision.observe` takes them.  ``kind``: ``"trajectories"``
    or ``"blocks"`` (default: the band's own, held-out trajectories when there are two or more; the blocks are
    computed too, for a comparison).  ``velocity_cutoff``: Hz of the observer's output low-pass (None: the
    default, :data:`~manipdyn.control.collision.observer.DEFAULT_VELOCITY_CUTOFF`; 0: none), recorded with
    the thresholds.  Raises :class:`ModelError`
    when the result has no hold-outs, a refit is no physical arm, a run carried a known payload, or a
    log is no file.
    """
    from ...formats.logs.read import model_joint_names
    from ...identification.inputs.runs import Measurements, as_log_specs

    K = None if gain is None else check_gain(gain)
    fc = check_velocity_cutoff(velocity_cutoff)
    held = getattr(result, "held_out", None)
    if held is None:
        raise ModelError("thresholds: the identification has no hold-outs (band_folds 0, --band-folds 0, or the "
                         "band could not be had); observe then needs calibrate= (--calibrate LOG...), fit_data= "
                         "(--fit-data LOG...: refits of its own) or threshold=")
    if result.arm is None:
        raise ModelError("thresholds: the identified parameters are no physical arm; no observer to watch with")
    if getattr(result, "payload_logs", None):
        raise ModelError("thresholds: runs with a known payload (" + ", ".join(result.payload_logs) + ") are not "
                         "watched by the observer; give calibrate= (--calibrate LOG...) instead")
    specs = as_log_specs(logs)
    data = result.data
    segments = list(getattr(data, "segments", None) or [len(data.t)])
    if len(specs) != len(segments) or any(isinstance(s, Measurements) for s in specs):
        raise ModelError("thresholds: the observer reads each fit log again as a file; the logs must be the "
                         f"{len(segments)} files identify read, got {len(specs)} item(s)")
    pairs = held.pairs(kind)
    kind = held.kind if kind is None else kind
    bad = [k + 1 for k, (_, a) in enumerate(pairs) if a is None]
    if bad:
        raise ModelError(f"thresholds: the refit without hold-out {', '.join(map(str, bad))} is no physical arm "
                         "(--method consistent always gives one); give calibrate= instead")
    opts = {k: v for k, v in read_options.items() if k in READ_KEYS and v is not None}
    opts.setdefault("joint_names", model_joint_names(result.arm))
    starts = np.concatenate([[0], np.cumsum(segments)])
    both = kind == "trajectories" and held.kind == "trajectories" and bool(held.refits.get("blocks"))
    parts, dts, block_parts = [], [], []
    ratios = {id(parts): [], id(block_parts): []}        # the leverage ratios of the held-out samples (extrapolation)
    reference = model_reference(result.arm)
    for r, spec in enumerate(specs):
        run_opts = dict(opts)
        for key in ("t_range", "rate", "columns"):
            if getattr(spec, key, None) is not None:
                run_opts[key] = getattr(spec, key)
        (raw,) = read_observed(result.arm, spec.path, **run_opts)
        dts.append(raw.dt)
        t = data.t[starts[r]:starts[r + 1]]
        for watched, out in ((pairs, parts), (held.pairs("blocks") if both else [], block_parts)):
            for mask, arm in watched:
                for t0, t1 in _spans(np.asarray(mask[starts[r]:starts[r + 1]], dtype=bool), t):
                    inside = (raw.t >= t0) & (raw.t < t1)
                    if np.sum(inside) < 10:
                        raise ModelError(f"thresholds: a hold-out of {os.path.basename(spec.path)} holds "
                                         f"{int(np.sum(inside))} raw samples; fewer folds")
                    out.append(momentum_input(arm, raw.q[inside], raw.qd[inside], raw.tau[inside], raw.dt))
                    if reference is not None:
                        ratios[id(out)].append(leverage_ratios(refit_reference(reference, arm, data, mask), arm,
                                                               raw.q[inside], raw.qd[inside], raw.dt))
    if max(dts) > 1.01 * min(dts):
        raise ModelError(f"thresholds: the fit logs' sample periods differ ({min(dts):.4g} to {max(dts):.4g} s); "
                         "resample them to one rate (--resample)")
    names = _names([s.path for s in specs])
    if kind == "trajectories":
        labels = np.asarray(held.labels)
        groups = [" + ".join(n for k, n in enumerate(names) if labels[starts[k]] == g)
                  for g in np.unique(labels)]
        source = (f"{len(pairs)} held-out trajectories of the fit data ({' | '.join(groups)}), each watched by "
                  "the observer of the band's refit on the others")
    else:
        source = (f"{held.folds} blocked hold-outs of the fit data {', '.join(names)}, each watched by the observer "
                  "of the band's refit on the others")
    dt = float(np.median(dts))

    def at(k, g=0.0):
        return _at_gain(parts, block_parts, dt, k, fc, false_alarms, min_duration, hysteresis, source, held.folds,
                        (ratios[id(parts)], ratios[id(block_parts)]) if g > 0 else None, g)

    thr = at(K) if K is not None else choose_gain(at)
    if reference is None or kind != "trajectories":
        # blocks of one trajectory: a held-out block's leverage against its refit barely differs from the rest,
        # and a gain picked on it lowered the Panda's joint 3 threshold at gain 100 into a false event on the
        # log's next 11 s; the leverage is a tested measure only across runs (extrapolation.py)
        return thr
    # then each joint's threshold may grow with the leverage ratio, at the chosen K (extrapolation.py)
    return choose_leverage_gain(lambda g: at(thr.gain, g) if g > 0 else thr, ratios[id(parts)])


def _at_gain(parts, block_parts, dt, K, fc, false_alarms, min_duration, hysteresis, source, folds, ratios=None,
             leverage_gain=0.0):
    """:func:`identified_thresholds` at gain ``K``: ``parts`` (and ``block_parts``) the observer's inputs of
    the hold-outs (:func:`~manipdyn.control.collision.observer.momentum_input`); with ``ratios`` (the parts' and
    the block parts' leverage ratios, lists of (N_k, n)), the residuals divided by
    :func:`~manipdyn.identification.uncertainty.thresholds.leverage_factor` at ``leverage_gain``."""
    def residuals(xs, us=None):
        return np.vstack([observer_output(x, dt, K, fc) / (1.0 if us is None else leverage_factor(leverage_gain, u))
                          for x, u in zip(xs, us if us is not None else [None] * len(xs))])

    us, block_us = ratios if ratios is not None else (None, None)
    thr = fit_thresholds(residuals(parts, us), dt, false_alarms, gain=K, min_duration=min_duration,
                         hysteresis=hysteresis, source=source, velocity_cutoff=fc)
    if not block_parts:
        return thr
    # as the band does: at least the blocks' thresholds per joint (two or three held-out trajectories may
    # happen to carry over well on a joint, below what the noise and the within-run error give on any run)
    blocks = fit_thresholds(residuals(block_parts, block_us), dt, false_alarms, gain=K, min_duration=min_duration,
                            hysteresis=hysteresis)
    wider = blocks.threshold > thr.threshold
    if not np.any(wider):
        return thr
    pick = {k: np.where(wider, getattr(blocks, k), getattr(thr, k)) for k in ("threshold", "tail_a", "tail_b",
                                                                               "observed_max")}
    # the blocks' tail per hour, in the record's hours (ln N = a - b u counts events in `hours`): the picked
    # joints' stored threshold stays their tail's level, and for_rate moves them as their own data say
    pick["tail_a"] = np.where(wider, blocks.tail_a + np.log(thr.hours) - np.log(blocks.hours), thr.tail_a)
    joints = ", ".join(str(j + 1) for j in np.flatnonzero(wider))
    return replace(thr, **pick, source=f"{source}; at least the {folds} blocked hold-outs' thresholds, which "
                                        f"set joint(s) {joints}")


#: identify's options that a refit for --fit-data does not redo
_NOT_REDONE = ("bootstrap", "scheduler")


def _identify_options(record) -> dict:
    """identify's keyword arguments from the trust record's ``options`` (and ``method``), checked in shape:
    a record edited by hand is refused naming its key, never blamed on a command-line option."""
    raw = record.get("options")
    if raw is not None and not isinstance(raw, dict):
        raise ModelError(f"the model's trust record: options: expected a table of identify's options, got {raw!r:.60}")
    opts = dict(raw or {})
    out = {k: v for k, v in opts.items() if k not in _NOT_REDONE}
    method = record.get("method") or opts.get("method") or "consistent"
    if not isinstance(method, str):
        raise ModelError(f"the model's trust record: method: expected a method's name, got {method!r:.60}")
    out["method"] = method
    t_range = opts.get("t_range")
    if t_range is not None:
        ok = isinstance(t_range, (list, tuple)) and len(t_range) == 2
        vals = []
        for x in (t_range if ok else []):
            if x in (None, "none"):
                vals.append(None)
            elif isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(float(x)):
                vals.append(float(x))
            else:
                ok = False
        if not ok:
            raise ModelError(f"the model's trust record: options.t_range: expected [t0, t1] (s, or \"none\"), got "
                             f"{t_range!r:.60}")
        out["t_range"] = tuple(vals)
    return out


def _record_folds(record) -> int:
    """The record's band's folds (``prediction_band.folds``), else :data:`DEFAULT_FOLDS`; refused when not an integer >= 2."""
    band = record.get("prediction_band") or {}
    folds = band.get("folds") if isinstance(band, dict) else None
    if folds is None:
        return DEFAULT_FOLDS
    if (isinstance(folds, bool) or not isinstance(folds, (int, float)) or not 2 <= folds <= 1000
            or folds != int(folds)):
        raise ModelError(f"the model's trust record: prediction_band.folds: expected an integer from 2 to 1000, got "
                         f"{folds!r:.60}")
    return int(folds)


def _prior(arm, record):
    """``(prior, note)``: the record's prior when it still loads with the model's joints, else the model."""
    from ...formats.loading import load_with_notes

    label = str(record.get("prior") or "")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            prior, _ = load_with_notes(label)
        if prior.n == arm.n:
            return label, ""
    except (ModelError, OSError, ValueError):
        pass
    return arm, f"; refits on the model itself (its prior {label or '?'} does not load)"


def held_out_thresholds(arm, log, gain: float | None = None, false_alarms: float = DEFAULT_RATE, *,
                        folds: int | None = None, min_duration: float = DEFAULT_MIN_DURATION,
                        hysteresis: float = DEFAULT_HYSTERESIS, check_sha256: bool = True,
                        velocity_cutoff: float | None = None) -> CollisionThresholds:
    """Thresholds from the hold-outs of the log(s) ``log`` (a path or a list, every log the model was fitted
    on) that ``arm`` (a model from ``identify``, with its trust record) was fitted on: ``identify`` again with
    the record's options and ``folds`` blocks (default: the record's band's, else 5), then
    :func:`identified_thresholds` (module docstring), with the observer's output low-pass at
    ``velocity_cutoff`` Hz (None: the default).  Raises :class:`ModelError`
    when the model has no trust record, a log is not its fit data (sha256) or one is missing, or a refit fails."""
    from ...identification.pipeline import identify
    from ...identification.results.provenance import file_sha256

    K = None if gain is None else check_gain(gain)
    record = getattr(arm, "trust", None)
    if not isinstance(record, dict):
        raise OptionError("{}: the model has no trust record (it was not identified by manipdyn identify); "
                          "give collision-free logs it was not fitted on instead ({})", "fit_data", "calibrate")
    logs = [os.fspath(x) for x in (log if isinstance(log, (list, tuple)) else [log])]
    if check_sha256 and record.get("data_sha256"):
        known = str(record["data_sha256"]).split(", ")
        shas = [file_sha256(x) for x in logs]
        for where, sha in zip(logs, shas):
            if sha not in known:
                raise OptionError("{} " + brace_safe(f"{where}: sha256 {sha[:16]}... is not the model's fit data "
                                                     f"({record.get('data')}, sha256 "
                                                     f"{str(record['data_sha256'])[:16]}...)"), "fit_data")
        if len(set(shas)) < len(set(known)):
            raise OptionError("{}: " + brace_safe(f"the model was fitted on {len(set(known))} logs "
                                                  f"({record.get('data')}); give them all, for the same hold-outs"),
                              "fit_data")
        logs = sorted(logs, key=lambda x: known.index(shas[logs.index(x)]))      # identify's order
    if folds is None:
        folds = _record_folds(record)
    prior, note = _prior(arm, record)
    options = _identify_options(record)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = identify(prior, logs, band_folds=int(folds), **options)
        out = identified_thresholds(result, logs, K, false_alarms, min_duration=min_duration, hysteresis=hysteresis,
                                    velocity_cutoff=velocity_cutoff, **options)
    except (TypeError, ValueError, KeyError, OverflowError) as exc:   # an option this identify does not take
        raise ModelError(f"the model's trust record: its identify options do not replay ({exc!s:.200})") from None
    except ModelError as exc:
        if isinstance(exc, OptionError):    # an option of the record's, not one the user gave on the command line
            exc = ModelError(str(exc))
        raise ModelError(f"the model's trust record: identify with its options "
                         f"({', '.join(sorted(options)) or 'none'}) failed: {exc}") from None
    return replace(out, source=out.source + note) if note else out
