"""Whether a model is scored on held-out data: what the validation figure's title says.

Layer 5 (identification).

An identified model names its data files and their sha256, and its options the window it was
fitted on (``t_range``; :mod:`.provenance`).  Against the logs a validation reads:

* no such record (a published or hand-written model): ``"not fitted by manipdyn"``;
* none of its data files is one of these logs (by sha256): ``"held out: another log"``;
* the same log, and the fit window does not meet the scored window: ``"held out: another window"``;
* the same log, windows that meet (or no fit window, so the whole log): ``"FIT DATA, not held out"``.
"""

from __future__ import annotations

import os
import re

__all__ = ["held_out_label", "scored_window"]

NOT_FITTED = "not fitted by manipdyn"
OTHER_LOG = "held out: another log"
OTHER_WINDOW = "held out: another window"
FIT_DATA = "FIT DATA, not held out"


def _record(model):
    data = getattr(model, "data", None)
    if isinstance(data, dict) and "base_parameters" in data:          # a base model
        prov = data.get("provenance")
        return prov if isinstance(prov, dict) else {}
    src = getattr(model, "sources", None)
    return src if isinstance(src, dict) else {}


def _log_shas(sources) -> set:
    from .provenance import file_sha256

    out = set()
    for src in sources:
        try:
            if isinstance(src, (str, os.PathLike)) and os.path.isfile(src):
                out.add(file_sha256(src))
        except (OSError, ValueError):
            continue
    return out


def scored_window(data) -> tuple[float, float]:
    """First and last time stamp (s) of the scored samples."""
    return float(data.t[0]), float(data.t[-1])


def held_out_label(model, data) -> str:
    """One of the module's four labels for ``model`` scored on ``data`` (stacked measurements
    with ``sources``, the log paths, and ``t``)."""
    rec = _record(model)
    fitted = re.findall(r"sha256 ([0-9a-f]{64})", str(rec.get("data") or ""))
    if not fitted:
        return NOT_FITTED
    if not set(fitted) & _log_shas(getattr(data, "sources", ()) or ()):
        return OTHER_LOG
    m = re.search(r"t_range=\[([^,\]]+), ([^\]]+)\]", str(rec.get("options") or ""))
    if m is None:
        return FIT_DATA
    try:
        lo, hi = float(m.group(1)), float(m.group(2))
    except ValueError:
        return FIT_DATA
    t0, t1 = scored_window(data)
    return OTHER_WINDOW if (t1 <= lo or t0 >= hi) else FIT_DATA
