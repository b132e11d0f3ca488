"""Identification data as CSV: reading, writing, and derivatives of q.

Layer 2 (formats: logs).

Files
-----
* trajectory (``manipdyn excite``): header ``t,q1..qn,qd1..qdn,qdd1..qddn``;
* measurements (``manipdyn identify``): header ``t,q1..qn,tau1..taun``,
  optionally with ``qd1..qdn`` and ``qdd1..qddn`` (any column order); logs
  as they come (other names, degrees, motor side, uneven time stamps, ROS
  bags) are read by :func:`~manipdyn.formats.logs.read.read_log`.

SI units: s, rad or m, rad/s or m/s, N m or N.

When ``qd`` and ``qdd`` are absent they are derived from ``q`` by zero-phase
filtering and differentiation (:func:`derivatives`): a 4th-order
Butterworth low-pass filter run forwards and backwards (``scipy.signal.
sosfiltfilt``: no phase lag, effective order 8) with cut-off ``cutoff`` Hz
(:func:`read_log` chooses it from the spectrum of q, see
:mod:`~manipdyn.formats.logs.filtering`; :func:`derivatives` defaults to
:data:`DEFAULT_CUTOFF` = 5 Hz, or a fifth of the Nyquist frequency if that
is lower: well above the bandwidth of excitation trajectories, which rarely
exceeds 1 to 2 Hz, and low enough that the twice-differentiated encoder
noise stays small), then
second-order central differences (``numpy.gradient``).  The filter's
edges are continued over ``6 / cutoff`` s by an odd reflection corrected
for curvature, and the first and last ``0.75 / cutoff`` seconds are
dropped (the filter's transients and the one-sided differences live there;
measured errors in :mod:`~manipdyn.formats.logs.filtering`, "Edges").  The torques are NOT
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
import os

import numpy as np

from ..._support.files import atomic_write, atomic_write_text
from .filtering import zero_phase
from .read import read_log
from .measurements import Measurements

#: default cut-off of the zero-phase low-pass filter, Hz
DEFAULT_CUTOFF = 5.0

__all__ = ["DEFAULT_CUTOFF", "Measurements", "read_measurements", "write_measurements_csv",
           "write_trajectory_csv", "derivatives"]


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


def write_measurements_csv(path, t, q, tau, qd=None, qdd=None, then=None) -> None:
    """Write ``t,q1..qn,[qd..,qdd..,]tau1..taun`` atomically.

    ``then``: a callable run once the log is on disk beside ``path`` but before it is renamed into place
    (a second file that goes with the log): when it raises, ``path`` is left as it was."""
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
    text = _to_text(header, cols)
    if then is None:
        atomic_write_text(path, text)
        return

    def write(fh):
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
        then()

    atomic_write(path, write)


def derivatives(t, q, tau=None, cutoff: float | None = None, order: int = 4):
    """Zero-phase filtered ``(t, q, qd, qdd, tau)`` from samples of q (module docstring).

    ``t`` (N,) uniformly spaced, s; ``q`` (N, n); ``tau`` (N, n) or None
    (trimmed alike, not filtered); ``cutoff`` in Hz (default
    :data:`DEFAULT_CUTOFF`, or a tenth of the rate if lower; :func:`read_log`
    chooses it from the data instead).  The outputs are shorter than the
    inputs: ``0.75 / cutoff`` s are dropped at each end; nothing is decimated.
    """
    rate = 1.0 / float(np.median(np.diff(t)))
    fc = min(DEFAULT_CUTOFF, rate / 10.0) if cutoff is None else float(cutoff)
    others = () if tau is None else (np.asarray(tau),)
    tt, qf, qd, qdd, rest = zero_phase(np.asarray(t), np.asarray(q, dtype=np.float64), fc, others=others,
                                       order=order)
    return tt, qf, qd, qdd, (rest[0] if rest else None)


def read_measurements(path, n: int, cutoff: float | None = None) -> Measurements:
    """Read a measurement CSV for an arm of ``n`` joints: :func:`read_log` with its defaults
    (the cut-off chosen from the data unless ``cutoff`` Hz is given).

    Raises :class:`ModelError` naming the file and the missing or malformed
    column or row.
    """
    return read_log(path, n, cutoff=cutoff)
