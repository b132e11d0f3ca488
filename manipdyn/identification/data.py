"""Identification data as CSV: reading, writing, and derivatives of q.

Layer: application (identification).

Files
-----
* trajectory (``manipdyn excite``): header ``t,q1..qn,qd1..qdn,qdd1..qddn``;
* measurements (``manipdyn identify``): header ``t,q1..qn,tau1..taun``,
  optionally with ``qd1..qdn`` and ``qdd1..qddn`` (any column order).

SI units: s, rad or m, rad/s or m/s, N m or N.

When ``qd`` and ``qdd`` are absent they are derived from ``q`` by zero-phase
filtering and differentiation (:func:`derivatives`): a 4th-order
Butterworth low-pass filter run forwards and backwards (``scipy.signal.
filtfilt``: no phase lag, effective order 8) with cut-off ``cutoff`` Hz
(default :data:`DEFAULT_CUTOFF` = 5 Hz, or a fifth of the Nyquist frequency
if that is lower: well above the bandwidth of excitation trajectories, which
rarely exceeds 1 to 2 Hz, and low enough that the twice-differentiated
encoder noise stays small; give the cut-off that suits your data), then
second-order central differences (``numpy.gradient``).  The filter's
edges are padded by odd extension over ``6 rate / cutoff`` samples, and the
first and last ``3 / cutoff`` seconds are dropped (the filter's transients
and the one-sided differences live there: on a sine at 0.2 to 0.35 Hz the
error of qdd is 4 % of its amplitude at ``1 / cutoff`` from the edge, 0.3 %
at ``2 / cutoff``, 0.02 % at ``3 / cutoff``).  The torques are NOT
filtered, only trimmed alike: least squares averages their white noise
anyway, and a low-pass filter on tau alone would smear the Coulomb-friction
step ``sign(qd)`` that the regressor keeps sharp (filtering tau made the
held-out error of the wrist joints 30 % worse in the identification tests;
Gautier's parallel filtering filters the regressor columns too, which a
state-based fit cannot).
"""

from __future__ import annotations

import csv
import io
import math
import os

import numpy as np

from .._files import atomic_write_text
from ..errors import ModelError

#: default cut-off of the zero-phase low-pass filter, Hz
DEFAULT_CUTOFF = 5.0

__all__ = ["DEFAULT_CUTOFF", "Measurements", "read_measurements", "write_measurements_csv",
           "write_trajectory_csv", "derivatives"]


class Measurements:
    """Samples of one experiment: ``t`` (N,), ``q``, ``qd``, ``qdd``, ``tau`` (N, n).

    ``derived`` is True when qd and qdd were derived from q (filtered q, trimmed ends).
    """

    def __init__(self, t, q, qd, qdd, tau, derived=False):
        self.t, self.q, self.qd, self.qdd, self.tau = t, q, qd, qdd, tau
        self.derived = bool(derived)

    @property
    def n(self) -> int:
        return self.q.shape[1]

    def __len__(self) -> int:
        return len(self.t)


def _columns(prefix, n):
    return [f"{prefix}{j + 1}" for j in range(n)]


def _to_text(header, cols) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for row in np.column_stack(cols):
        w.writerow([repr(float(x)) for x in row])
    return buf.getvalue()


def write_trajectory_csv(path, t, q, qd, qdd) -> None:
    """Write ``t,q1..qn,qd1..qdn,qdd1..qddn`` atomically."""
    n = q.shape[1]
    header = ["t"] + _columns("q", n) + _columns("qd", n) + _columns("qdd", n)
    atomic_write_text(path, _to_text(header, [t, q, qd, qdd]))


def write_measurements_csv(path, t, q, tau, qd=None, qdd=None) -> None:
    """Write ``t,q1..qn,[qd..,qdd..,]tau1..taun`` atomically."""
    n = q.shape[1]
    header, cols = ["t"] + _columns("q", n), [t, q]
    if qd is not None:
        header += _columns("qd", n)
        cols.append(qd)
    if qdd is not None:
        header += _columns("qdd", n)
        cols.append(qdd)
    header += _columns("tau", n)
    cols.append(tau)
    atomic_write_text(path, _to_text(header, cols))


def derivatives(t, q, tau=None, cutoff: float | None = None, order: int = 4):
    """Zero-phase filtered ``(t, q, qd, qdd, tau)`` from samples of q (module docstring).

    ``t`` (N,) uniformly spaced, s; ``q`` (N, n); ``tau`` (N, n) or None
    (trimmed alike, not filtered); ``cutoff`` in Hz.  The outputs are
    shorter than the inputs: ``3 / cutoff`` s are dropped at each end.
    """
    from ._deps import require

    signal = require("scipy.signal", "deriving qd and qdd from q")
    dt = float(np.median(np.diff(t)))
    rate = 1.0 / dt
    fc = min(DEFAULT_CUTOFF, rate / 10.0) if cutoff is None else float(cutoff)
    if not 0 < fc < rate / 2:
        raise ModelError(f"cutoff: expected 0 < cutoff < {rate / 2:g} Hz (the Nyquist frequency), got {fc:g}")
    bb, aa = signal.butter(order, fc / (rate / 2))
    trim = int(math.ceil(3 * rate / fc))
    if len(t) <= 4 * trim:
        raise ModelError(f"data: {len(t)} samples are too few to filter at {fc:g} Hz; need more than "
                         f"{4 * trim} ({12 / fc:g} s)")
    pad = min(len(t) - 1, int(6 * rate / fc))
    qf = signal.filtfilt(bb, aa, q, axis=0, padlen=pad)
    qd = np.gradient(qf, dt, axis=0)
    qdd = np.gradient(qd, dt, axis=0)
    keep = slice(trim, len(t) - trim)
    return t[keep], qf[keep], qd[keep], qdd[keep], None if tau is None else np.asarray(tau)[keep]


def read_measurements(path, n: int, cutoff: float | None = None) -> Measurements:
    """Read a measurement CSV for an arm of ``n`` joints (module docstring).

    Raises :class:`ModelError` naming the file and the missing or malformed
    column or row.
    """
    where = os.fspath(path)
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise ModelError(f"{where}: cannot read data file: {exc.strerror or exc}") from None
    if not rows:
        raise ModelError(f"{where}: empty file; expected a header t,q1..q{n},tau1..tau{n}")
    header = [h.strip() for h in rows[0]]
    index = {h: k for k, h in enumerate(header)}
    if len(index) != len(header):
        raise ModelError(f"{where}: duplicate column names in the header {header}")
    need = ["t"] + _columns("q", n) + _columns("tau", n)
    missing = [c for c in need if c not in index]
    if missing:
        raise ModelError(f"{where}: missing column(s) {missing}; expected a header "
                         f"t,q1..q{n},tau1..tau{n} (optionally qd1..qd{n}, qdd1..qdd{n}) for {n} joints")
    has_qd = all(c in index for c in _columns("qd", n))
    has_qdd = all(c in index for c in _columns("qdd", n))
    extra = [h for h in header if h not in set(need + _columns("qd", n) + _columns("qdd", n))]
    if extra:
        raise ModelError(f"{where}: unexpected column(s) {extra} for an arm of {n} joints")
    try:
        data = np.array([[float(x) for x in r] for r in rows[1:] if r], dtype=np.float64)
    except ValueError as exc:
        raise ModelError(f"{where}: a value is not a number ({exc})") from None
    if data.ndim != 2 or data.shape[0] < 2 or data.shape[1] != len(header):
        raise ModelError(f"{where}: expected rows of {len(header)} numbers under the header, "
                         f"and at least 2 rows")
    if not np.all(np.isfinite(data)):
        r, c = np.argwhere(~np.isfinite(data))[0]
        raise ModelError(f"{where}: row {r + 2}, column {header[c]!r} is not finite")

    def cols(names):
        return data[:, [index[c] for c in names]]

    t = data[:, index["t"]]
    dt = np.diff(t)
    if np.any(dt <= 0):
        raise ModelError(f"{where}: column 't' must increase strictly (row {int(np.argmax(dt <= 0)) + 3})")
    q, tau = cols(_columns("q", n)), cols(_columns("tau", n))
    if has_qd and has_qdd:
        return Measurements(t, q, cols(_columns("qd", n)), cols(_columns("qdd", n)), tau)
    if not math.isclose(dt.min(), dt.max(), rel_tol=1e-3):
        raise ModelError(f"{where}: qd/qdd are absent and must be derived from q, which needs uniform "
                         f"sampling; the steps of 't' range from {dt.min():g} to {dt.max():g} s")
    tt, qf, qd, qdd, tf = derivatives(t, q, tau, cutoff)
    return Measurements(tt, qf, qd, qdd, tf, derived=True)
