"""The samples of one experiment, ready for identification, and what was done to them.

Layer 2 (formats: logs).
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError

__all__ = ["Measurements", "segment_edges"]


class Measurements:
    """Samples of one experiment: ``t`` (N,) s, ``q``, ``qd``, ``qdd``, ``tau`` (N, n), joint side, SI.

    ``derived`` is True when qdd (and qd, unless measured: ``measured_qd``)
    came from the zero-phase filter (filtered q, trimmed ends).  What
    :func:`~manipdyn.identification.read_log` also records:

    * ``notes``: one line per thing done to the data (duplicates dropped, gaps,
      resampling, the cut-off and why, decimation, the time window);
    * ``rate``: the sample rate of ``t``, Hz; ``cutoff``: the low-pass cut-off
      in Hz, or None when nothing was filtered;
    * ``decimation``: the factor D applied after filtering (1: none);
    * ``qd_motor`` (N, n): motor velocities ``R qd``, rad/s at the motor, when a
      transmission was given, else None;
    * ``source`` (the file name) and ``source_sha256`` (of its bytes; of a bag's
      files, name and bytes in name order);
    * ``qd_noise`` (n,): the velocity's noise level per joint, rad/s, measured on
      what the filter removed (:func:`~manipdyn.formats.logs.filtering.velocity_noise`),
      or None when nothing was filtered;
    * ``motor_signals``: which signals were read at the motors (some of ``"qm"``,
      ``"qdm"``, ``"taum"``, ``"i"``), empty for a joint-side log.
    """

    def __init__(self, t, q, qd, qdd, tau, derived=False, *, notes=(), rate=None, cutoff=None,
                 decimation=1, qd_motor=None, measured_qd=False, source=None, source_sha256=None,
                 qd_noise=None, motor_signals=()):
        self.t, self.q, self.qd, self.qdd, self.tau = t, q, qd, qdd, tau
        self.derived = bool(derived)
        self.notes = list(notes)
        self.rate, self.cutoff, self.decimation = rate, cutoff, int(decimation)
        self.qd_motor, self.measured_qd = qd_motor, bool(measured_qd)
        self.source, self.source_sha256 = source, source_sha256
        self.qd_noise, self.motor_signals = qd_noise, tuple(motor_signals)

    @property
    def n(self) -> int:
        return self.q.shape[1]

    def __len__(self) -> int:
        return len(self.t)

    def __repr__(self) -> str:
        rate = "" if self.rate is None else f", {self.rate:.6g} Hz"
        return f"<Measurements {len(self)} samples of {self.n} joints{rate}>"


def segment_edges(segments, N: int) -> np.ndarray:
    """``[0, N_1, N_1 + N_2, ..., N]`` from the runs' sample counts (``Measurements.segments``; None: one run)."""
    if segments is None:
        return np.array([0, N])
    try:
        counts = np.array([int(k) for k in segments])
    except (TypeError, ValueError):
        raise ModelError(f"segments: expected the runs' sample counts, got {segments!r:.80}") from None
    if counts.size == 0 or np.any(counts < 1) or counts.sum() != N:
        raise ModelError(f"segments: expected sample counts >= 1 adding up to the {N} samples, got {counts.tolist()}")
    return np.concatenate([[0], np.cumsum(counts)])
