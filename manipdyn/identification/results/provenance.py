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
  :func:`fit_record`, and read back from a model or a base model by :func:`carried`, which is
  how ``validate`` reports extrapolation and bands on new data.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import os

from ..._support import limits
from ..._support.errors import ModelError

__all__ = ["file_sha256", "provenance", "model_metadata", "fit_record", "carried"]


def file_sha256(path, label: str | None = None) -> str:
    """Hex sha256 of the regular file ``path`` (read in 1 MiB blocks; a FIFO is refused)."""
    where = label or os.fspath(path)
    h = hashlib.sha256()
    try:
        with limits.open_regular(os.fspath(path), f"{where}: cannot read the data file") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
    except OSError as exc:
        raise ModelError(f"{where}: cannot read the data file: {exc.strerror or exc}") from None
    return h.hexdigest()


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


def fit_record(arm, data, folds: int | None = None, **fit_kwargs) -> tuple[dict, list]:
    """``(record, notes)``: what a fit on ``data`` (``q``, ``qd``, ``qdd``, ``tau`` (N, n)) adds
    to its provenance: ``fitted_range`` (:func:`.coverage.fitted_range`) and, unless
    ``folds`` is 0, ``prediction_band`` (:func:`.bands.calibrate_band` with ``fit_kwargs``,
    the fit's own options; ``folds`` None: the default 5).  When the band cannot be had (data
    too short for the blocks, a refit failing) it is left out and ``notes`` says why.
    """
    from ..uncertainty.bands import DEFAULT_FOLDS, calibrate_band
    from ..uncertainty.coverage import fitted_range

    record = {"fitted_range": fitted_range(data.q, data.qd, data.tau).to_dict()}
    notes = []
    folds = DEFAULT_FOLDS if folds is None else int(folds)
    if folds:
        try:
            band = calibrate_band(arm, data.q, data.qd, data.qdd, data.tau, folds=folds, **fit_kwargs)
            record["prediction_band"] = band.to_dict()
        except ModelError as exc:
            notes.append(f"no prediction band from blocked hold-outs: {exc}")
    return record, notes


def carried(model) -> tuple[object, object, list]:
    """``(fitted_range, prediction_band, notes)`` that ``model`` carries from its fit, each None when
    it has none: an arm read from a model file (its ``sources``), or a base model (its
    ``provenance``).  A record that does not read is reported in ``notes``, not raised: the
    model still predicts."""
    from ..uncertainty.bands import PredictionBand
    from ..uncertainty.coverage import StateRange

    n = model.n
    data = getattr(model, "data", None)
    if isinstance(data, dict) and "base_parameters" in data:       # a base model
        prov = data.get("provenance") if isinstance(data.get("provenance"), dict) else {}
        readers = {"fitted_range": StateRange.from_dict, "prediction_band": PredictionBand.from_dict}
    else:
        prov = getattr(model, "sources", None) or {}
        readers = {"fitted_range": StateRange.from_text, "prediction_band": PredictionBand.from_text}
    out, notes = [], []
    for key, read in readers.items():
        value = prov.get(key)
        if value is None:
            out.append(None)
            continue
        try:
            out.append(read(value, n, f"the model's {key}"))
        except ModelError as exc:
            out.append(None)
            notes.append(f"{exc}; ignored")
    return out[0], out[1], notes
