"""Where an identified model came from: data file and its sha256, method, options, date.

Layer 5 (identification).

An identified model replaces the prior's citation with its own story: the prior's
``source``, ``sources`` and ``description`` are about the prior's numbers, which the fit
has changed, so none of their text survives into the identified model.  What is kept
instead, in the model file's ``source`` and ``[sources]`` table (and in a base model's
``provenance`` object):

* ``data``: the data file's name and the sha256 of its bytes;
* ``method`` and ``options`` (the command-line or API options of the fit);
* ``date``: UTC, ISO 8601;
* ``prior``: the prior's name (only its name: the label the user gave);
* ``residuals``: the RMS residual per joint on the fit data, N m;
* ``fitted_range``: the states the fit saw (:mod:`.coverage`) and ``prediction_band``: the
  band's half-widths from blocked hold-outs of the fit data (:mod:`.bands`), both written by
  :func:`fit_record`, with ``leverage`` (:mod:`.leverage`) and ``rest`` (the rest threshold and the
  static friction levels, :mod:`..inputs.rest`), and read back from a model or a base
  model by :func:`carried_trust`, which is how ``validate`` reports extrapolation and bands on
  new data.

These travel as the model's **trust record** (:func:`trust_record`: ``format``, the data,
its sha256, method, options, date, prior, residuals, fitted range, band, leverage and
``doubts``, what the fit found doubtful), ``arm.trust``, which
:mod:`manipdyn.formats.trust` alone writes to and reads from every kind of file: a model
file's ``[trust]`` table (DH or with an embedded URDF, bundled or not), a URDF comment
(``md.to_urdf``, ``manipdyn urdf``, ``identify -o OUT.urdf``) and a base model's ``"trust"``.
The ``[sources]`` lines stay for the reader; :func:`carried_trust` reads them only from
files written before the record.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import os
from dataclasses import dataclass, field

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError

__all__ = ["file_sha256", "provenance", "model_metadata", "fit_record", "carried", "carried_trust", "Carried",
           "trust_record", "TRUST_KEYS"]


def file_sha256(path, label: str | None = None) -> str:
    """Hex sha256 of the regular file ``path`` (``hashlib.file_digest``; a FIFO is refused)."""
    where = label or os.fspath(path)
    try:
        with limits.open_regular(os.fspath(path), f"{where}: cannot read the data file") as fh:
            return hashlib.file_digest(fh, "sha256").hexdigest()
    except OSError as exc:
        raise ModelError(f"{where}: cannot read the data file: {exc.strerror or exc}") from None


def provenance(data_path, method: str, options: dict, prior_label: str, rms_residual,
               sha256: str | None = None, date: str | None = None) -> dict:
    """The provenance record (module docstring) as a JSON-ready dict of plain values."""
    return {
        "data": os.path.basename(os.fspath(data_path)),
        "data_sha256": sha256 if sha256 is not None else file_sha256(data_path),
        "method": str(method),
        "options": {str(k): v for k, v in sorted(options.items())},
        "date": date or _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat(),
        "prior": str(prior_label),
        "rms_residual": [float(x) for x in rms_residual],
    }


def _one_line(value) -> str:
    if isinstance(value, dict):
        return ", ".join(f"{k}={_one_line(v)}" for k, v in value.items())
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(f"{x:.4g}" if isinstance(x, float) else str(x) for x in value) + "]"
    return str(value)


def model_metadata(prov: dict) -> tuple[str, dict, str]:
    """``(source, sources, description)`` of an identified model file from :func:`provenance`."""
    source = (f"identified by manipdyn ({prov['method']}) from {prov['data']} "
              f"(sha256 {prov['data_sha256']}) on {prov['date']}")
    sources = {
        "data": f"{prov['data']}, sha256 {prov['data_sha256']}",
        "method": prov["method"],
        "options": _one_line(prov["options"]) or "defaults",
        "date": prov["date"],
        "prior": prov["prior"],
        "residuals": "RMS residual per joint on the fit data, N m: " + _one_line(prov["rms_residual"]),
    }
    n = len(prov["rms_residual"])
    if prov.get("fitted_range") is not None:
        from ..uncertainty.coverage import StateRange

        sources["fitted_range"] = StateRange.from_dict(prov["fitted_range"], n, "fitted_range").to_text()
    if prov.get("prediction_band") is not None:
        from ..uncertainty.bands import PredictionBand

        sources["prediction_band"] = PredictionBand.from_dict(prov["prediction_band"], n,
                                                              "prediction_band").to_text()
    description = (f"Inertial parameters identified from {prov['data']}; kinematics, limits and "
                   f"drives of the prior {prov['prior']}.")
    return source, sources, description


def fit_record(arm, data, folds: int | None = None, smoothing: float | None = None, labels=None,
               refits: dict | None = None, **fit_kwargs) -> tuple[dict, list]:
    """``(record, notes)``: what a fit on ``data`` (``q``, ``qd``, ``qdd``, ``tau`` (N, n)) adds
    to its provenance: ``fitted_range`` (:func:`.coverage.fitted_range`) and, unless
    ``folds`` is 0, ``prediction_band`` (:func:`.bands.calibrate_band` with ``fit_kwargs``,
    the fit's own options; ``folds`` None: the default 5) and ``leverage``, the extrapolation
    measure's reference (:class:`.leverage.Leverage`, features with the Coulomb smoothing
    ``smoothing``, joints weighed by their held-out RMS).  When the band cannot be had (data
    too short for the blocks, a refit failing) it is left out and ``notes`` says why.  ``labels`` (N,):
    the held-out trajectory group of each sample (two or more: the band is calibrated on held-out
    runs, :mod:`.bands`); a band within one trajectory says so in ``notes``.  ``refits``: a dict that
    receives the band's refits (:func:`.bands.calibrate_band`).
    """
    from ..uncertainty.bands import DEFAULT_FOLDS, WITHIN_ONE_TRAJECTORY, calibrate_band
    from ..uncertainty.coverage import fitted_range
    from ..uncertainty.leverage import Leverage

    record = {"fitted_range": fitted_range(data.q, data.qd, data.tau).to_dict()}
    notes = []
    folds = DEFAULT_FOLDS if folds is None else int(folds)
    if folds:
        try:
            band = calibrate_band(arm, data.q, data.qd, data.qdd, data.tau, folds=folds, smoothing=smoothing,
                                  labels=labels, refits=refits, notes=notes, **fit_kwargs)
            record["prediction_band"] = band.to_dict()
            weights = 1.0 / np.maximum(band.held_out_rms, 1e-12 * max(float(np.max(band.held_out_rms)), 1e-300))
            record["leverage"] = Leverage.of_fit(arm, data.q, data.qd, data.qdd, weights, smoothing or 0.01,
                                                 threshold=band.flag_leverage).to_dict()
            if band.within_one_trajectory:
                notes.append(WITHIN_ONE_TRAJECTORY)
        except ModelError as exc:
            notes.append(f"no prediction band from blocked hold-outs: {exc}")
    return record, notes


#: the provenance keys that go into the trust record (manipdyn.formats.trust), in order
TRUST_KEYS = ("data", "data_sha256", "method", "options", "date", "prior", "rms_residual", "fitted_range",
              "prediction_band", "leverage", "doubts", "collision", "decided", "torque_constants", "rest")


def trust_record(prov: dict) -> dict:
    """The trust record (:mod:`manipdyn.formats.trust`) of a fit's provenance ``prov``."""
    from ...formats.trust import TRUST_FORMAT, check_trust

    return check_trust({"format": TRUST_FORMAT, **{k: prov[k] for k in TRUST_KEYS if prov.get(k) is not None}})


@dataclass
class Carried:
    """What a model carries from its fit (:func:`carried_trust`), each None when it has none:
    ``fitted_range`` (:class:`.coverage.StateRange`), ``band`` (:class:`.band_record.PredictionBand`),
    ``leverage`` (:class:`.leverage.Leverage`), ``record`` (the trust record, a dict) and ``notes``
    (records that did not read, and the fit's ``doubts``)."""

    fitted_range: object = None
    band: object = None
    leverage: object = None
    rest: object = None             # model.friction_rest.StaticFriction: the rest threshold and static levels
    record: dict | None = None
    notes: list = field(default_factory=list)


def _record_of(model):
    """``(record, legacy)``: the trust record of an arm, a base model or an IdentifyResult; ``legacy``: the
    older ``[sources]`` strings of a model file written before the trust record."""
    trust = getattr(model, "trust", None)
    if isinstance(trust, dict):
        return trust, None
    data = getattr(model, "data", None)
    if isinstance(data, dict) and "base_parameters" in data:       # a base model of an older manipdyn
        return (data.get("provenance") if isinstance(data.get("provenance"), dict) else None), None
    prov = getattr(model, "provenance", None)
    if isinstance(prov, dict):                                     # an IdentifyResult with no arm
        return prov, None
    sources = getattr(model, "sources", None) or {}
    return None, sources


def carried_trust(model) -> Carried:
    """:class:`Carried` from ``model``: an arm (``arm.trust``, read from any model file or URDF by
    :mod:`manipdyn.formats.trust`), a base model, an :class:`.result.IdentifyResult`.  A record
    that does not read is reported in ``notes``, not raised: the model still predicts."""
    from ..uncertainty.bands import PredictionBand
    from ..uncertainty.coverage import StateRange
    from ..uncertainty.leverage import Leverage
    from ...model.friction_rest import StaticFriction

    n = model.n
    record, legacy = _record_of(model)
    out = Carried(record=record)
    if record is not None:
        readers = {"fitted_range": StateRange.from_dict, "band": PredictionBand.from_dict,
                   "leverage": Leverage.from_dict, "rest": StaticFriction.from_dict}
        keys = {"fitted_range": "fitted_range", "band": "prediction_band", "leverage": "leverage", "rest": "rest"}
        prov = record
    else:
        readers = {"fitted_range": StateRange.from_text, "band": PredictionBand.from_text}
        keys = {"fitted_range": "fitted_range", "band": "prediction_band"}
        prov = legacy
    for attr, read in readers.items():
        value = prov.get(keys[attr])
        if value is None:
            continue
        try:
            setattr(out, attr, read(value, n, f"the model's {keys[attr]}"))
        except ModelError as exc:
            out.notes.append(f"{exc}; ignored")
    doubts = record.get("doubts") if record is not None else None
    if isinstance(doubts, list):
        out.notes += [f"the fit doubted: {d}" for d in doubts if isinstance(d, str)]
    return out


def carried(model) -> tuple[object, object, list]:
    """``(fitted_range, prediction_band, notes)`` that ``model`` carries from its fit
    (:func:`carried_trust`, kept for its callers)."""
    c = carried_trust(model)
    return c.fitted_range, c.band, c.notes
