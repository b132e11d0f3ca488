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
* ``residuals``: the RMS residual per joint on the fit data, N m.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import os

from .._support import limits
from .._support.errors import ModelError

__all__ = ["file_sha256", "provenance", "model_metadata"]


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
    description = (f"Inertial parameters identified from {prov['data']}; kinematics, limits and "
                   f"drives of the prior {prov['prior']}.")
    return source, sources, description
