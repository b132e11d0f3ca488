"""Logs as the collision observer reads them: every sample, nearly raw, or arrays.

Layer 6 (control: collision).

A log is read as ``validate`` reads it (:func:`~manipdyn.identification.read_log`, the same options),
but every sample is kept (``decimate=False`` unless asked) and, unless ``cutoff=`` is given, the
reader's zero-phase low-pass is set at :data:`RAW_CUTOFF` (0.4) times the log's rate, so the signals are
nearly as logged (the reader's own choice, made for identification, is a few Hz, which would hide a
collision and look ahead in time).  When the log has no measured velocity, ``qd`` is differentiated
from ``q`` through that filter.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field

import numpy as np

from ..._support.errors import ModelError

__all__ = ["Observed", "read_observed", "RAW_CUTOFF"]

#: without a cut-off given, a log's signals are filtered at this fraction of its rate only (nearly raw)
RAW_CUTOFF = 0.4
#: samples dropped at each end of a file, beyond the reader's own edge trim, after the filter at RAW_CUTOFF: a
#: zero-phase filter that close to the Nyquist frequency rings at a file's ends when the arm moves there (on
#: the UR5 logs at 125 Hz the read qd left the measured one by up to 0.17 rad/s over the last 19 samples, the
#: residual jumped by 20 N m and the observer called the log's end a collision); a fixed count, since the
#: filter sits at a fixed fraction of the rate
EDGE_EXTRA = 24


@dataclass
class Observed:
    """One log as the observer sees it: ``t`` (N,) s, ``q``, ``qd``, ``tau`` (N, n), ``qdd`` (N, n) or None."""

    label: str
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    qdd: np.ndarray | None = None
    notes: list = field(default_factory=list)

    @property
    def dt(self) -> float:
        return float(np.median(np.diff(self.t)))


def _arrays(value, n, label) -> Observed:
    get = value.get if isinstance(value, dict) else (lambda k, d=None: getattr(value, k, d))
    missing = [k for k in ("t", "q", "qd", "tau") if get(k) is None]
    if missing:
        raise ModelError(f"{label}: expected a log file, or arrays t, q, qd, tau (qdd optional); "
                         f"missing {', '.join(missing)}")
    t = np.asarray(get("t"), dtype=np.float64).reshape(-1)
    arrs = [np.asarray(get(k), dtype=np.float64) for k in ("q", "qd", "tau")]
    qdd = get("qdd")
    for name, a in zip(("q", "qd", "tau"), arrs):
        if a.shape != (len(t), n):
            raise ModelError(f"{label}: {name}: expected shape ({len(t)}, {n}), got {a.shape}")
    if len(t) < 2 or not np.all(np.diff(t) > 0):
        raise ModelError(f"{label}: t: expected at least 2 increasing times, s")
    span = np.diff(t)
    if np.max(span) > 1.01 * np.min(span) + 1e-12:
        raise ModelError(f"{label}: t: the observer needs uniform samples (steps {np.min(span):.4g} to "
                         f"{np.max(span):.4g} s); read the log with read_log, which resamples")
    qdd = None if qdd is None else np.asarray(qdd, dtype=np.float64)
    return Observed(label, t, *arrs, qdd=qdd, notes=list(get("notes", None) or []))


def _trimmed(m, item, t_range):
    """``m`` without :data:`EDGE_EXTRA` samples at each end of the file, then windowed to ``t_range``."""
    from ...formats.logs.read import as_t_range

    k = EDGE_EXTRA if len(m.t) > 4 * EDGE_EXTRA and getattr(m, "cutoff", None) is not None else 0   # filtered only
    arrays = [a if a is None else a[k:len(a) - k] for a in (m.q, m.qd, m.qdd, m.tau)]
    t = m.t[k:len(m.t) - k]
    # the reader calls the cut-off "given": observe chose it, the user did not
    notes = [re.sub(r"; cutoff \S+ Hz not used", "", x).replace(
        " Hz (given)", f" Hz (observe's own: {RAW_CUTOFF:g} x the rate, nearly raw)") for x in m.notes] + ([f"observer: {k} more samples dropped at each end (the filter's ringing near the "
                              "Nyquist frequency)"] if k else [])
    t_range = as_t_range(t_range) if isinstance(t_range, str) else t_range
    if t_range is not None:
        lo, hi = (b if x is None else float(x) for x, b in zip(t_range, (-np.inf, np.inf)))
        keep = (t >= lo) & (t < hi)
        if keep.sum() < 2:
            raise ModelError(f"{os.path.basename(os.fspath(item))}: t_range {t_range!r} holds {int(keep.sum())} "
                             f"samples; the data spans {t[0]:.6g} to {t[-1]:.6g} s (after the filter's trimmed ends)")
        notes.append(f"window: {t[keep][0]:.6g} <= t <= {t[keep][-1]:.6g} s ({int(keep.sum())} samples)")
        t, arrays = t[keep], [a if a is None else a[keep] for a in arrays]
    m.t, (m.q, m.qd, m.qdd, m.tau), m.notes = t, arrays, notes
    return m


def read_observed(arm, source, **log_options) -> list[Observed]:
    """The logs of ``source`` (a path, a list of paths, a Measurements or a dict of arrays ``t, q, qd, tau``
    and optionally ``qdd``), read with :func:`~manipdyn.identification.read_log`'s ``log_options``."""
    from ...formats.logs.read import read_log

    items = list(source) if isinstance(source, (list, tuple)) else [source]
    if not items:
        raise ModelError("logs: expected at least one log")
    opts = dict(log_options)
    opts.setdefault("decimate", False)
    out = []
    for k, item in enumerate(items):
        if isinstance(item, (str, os.PathLike)):
            tr = getattr(arm, "transmission", None)
            if opts.get("cutoff") is None:
                # the signals as they come: a low-pass at 0.4 x the rate (the reader's default cut-off,
                # chosen for identification, is a few Hz, which a collision would not get through)
                fs = read_log(item, arm.n, transmission=tr, **dict(opts, t_range=None)).rate
                m = read_log(item, arm.n, transmission=tr, **dict(opts, cutoff=RAW_CUTOFF * fs, t_range=None))
                m = _trimmed(m, item, opts.get("t_range"))
            else:
                m = read_log(item, arm.n, transmission=tr, **opts)
            out.append(Observed(os.path.basename(os.fspath(item)), m.t, m.q, m.qd, m.tau, m.qdd, list(m.notes)))
        else:
            out.append(_arrays(item, arm.n, f"log {k + 1}"))
    return out
