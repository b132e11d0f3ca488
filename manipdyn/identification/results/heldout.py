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

__all__ = ["held_out_label", "scored_window", "fit_data_logs", "fit_data_note", "fit_shas"]

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


def fit_shas(model) -> list:
    """The sha256 (hex) of every log ``model`` was fitted on, from its trust record (``data_sha256``,
    ", "-separated) or its provenance (every 64-hex word of ``data``); [] for a model manipdyn did not fit."""
    trust = getattr(model, "trust", None) or getattr(getattr(model, "arm", None), "trust", None)
    rec = _record(model)
    for text in ((trust or {}).get("data_sha256") if isinstance(trust, dict) else None, rec.get("data_sha256"),
                 rec.get("data")):
        found = re.findall(r"\b[0-9a-f]{64}\b", str(text or ""))
        if found:
            return found
    return []


def _fit_window(model):
    """The record's fit window ``(lo, hi)`` in s, or None (the whole logs)."""
    trust = getattr(model, "trust", None) or getattr(getattr(model, "arm", None), "trust", None)
    t_range = (trust.get("options") or {}).get("t_range") if isinstance(trust, dict) else None
    if isinstance(t_range, (list, tuple)) and len(t_range) == 2:
        try:
            return (float("-inf") if t_range[0] is None else float(t_range[0]),
                    float("inf") if t_range[1] is None else float(t_range[1]))
        except (TypeError, ValueError):
            return None
    m = re.search(r"t_range=\[([^,\]]+), ([^\]]+)\]", str(_record(model).get("options") or ""))
    if m is None:
        return None
    try:
        return float(m.group(1)), float(m.group(2))
    except ValueError:
        return None


def fit_data_logs(model, logs, window=None) -> list:
    """The logs among ``logs`` (paths; others are skipped) that ``model`` was fitted on (their sha256 is
    in its record), and whose window meets the fit window; ``window``: the ``(t0, t1)`` s read of
    them (None: the whole log).  [] for a model manipdyn did not fit, or when every log is held out."""
    known = set(fit_shas(model))
    if not known:
        return []
    fw = _fit_window(model)
    if fw is not None and window is not None and (window[1] <= fw[0] or window[0] >= fw[1]):
        return []
    out = []
    for src in logs:
        if src is not None and _log_shas([src]) & known:
            out.append(src)
    return out


def fit_data_note(model, logs, window=None, name: str | None = None, what: str = "its scores") -> str | None:
    """One line, or None: that ``model`` (shown as ``name``) is scored on the data it was fitted on
    (:func:`fit_data_logs`), so ``what`` measure the fit and not a prediction.  ``validate``,
    ``replay`` and ``observe --calibrate`` say it."""
    hits = fit_data_logs(model, logs, window)
    if not hits:
        return None
    label = name or getattr(model, "name", None) or "the model"
    files = ", ".join(os.path.basename(os.fspath(x)) for x in hits)
    return (f"FIT DATA: {label} was fitted on {files} (by the sha256 in its trust record): {what} here are on its "
            "own fit data, not held out, and say how well it fits, not how well it predicts; score it on a log it "
            "was not fitted on")


def held_out_label(model, data) -> str:
    """One of the module's four labels for ``model`` scored on ``data`` (stacked measurements
    with ``sources``, the log paths, and ``t``)."""
    if not fit_shas(model):
        return NOT_FITTED
    sources = list(getattr(data, "sources", ()) or ())
    if not fit_data_logs(model, sources):
        return OTHER_LOG
    return FIT_DATA if fit_data_logs(model, sources, scored_window(data)) else OTHER_WINDOW
