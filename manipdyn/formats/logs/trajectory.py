"""A joint trajectory file: ``t,q1..qn`` with optional ``qd1..qdn,qdd1..qddn``.

Layer 2 (formats: logs).

``manipdyn excite`` writes ``t,q1..qn,qd1..qdn,qdd1..qddn``; ``synthesize`` reads it back to
compute the torques a robot would log along it.  A reference path given by a user (``track
--trajectory``) may hold the positions alone.  The file is read by :func:`read_table` (the log
reader's streamed, capped CSV parser: a FIFO or device refused, rows and columns named in every
error), capped at :data:`manipdyn.limits.MAX_TRAJECTORY_BYTES`, and checked here for its header,
a strictly increasing ``t`` and at least two samples.  Units are the arm's: rad (m for a prismatic
joint), rad/s, rad/s^2, and s for ``t``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError
from .table import read_table

__all__ = ["Trajectory", "read_trajectory", "trajectory_header"]


@dataclass(frozen=True)
class Trajectory:
    """Samples of a joint trajectory: ``t`` (N,) s; ``q``, ``qd``, ``qdd`` (N, n) in rad
    (m), rad/s (m/s), rad/s^2 (m/s^2).  ``qd`` and ``qdd`` are None for a file of positions
    alone (``read_trajectory(..., derivatives=False)``)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray | None
    qdd: np.ndarray | None


def trajectory_header(n: int, derivatives: bool = True) -> list[str]:
    """The column names of a trajectory of ``n`` joints: ``t,q1..qn[,qd1..qdn,qdd1..qddn]``."""
    names = ["t"] + [f"q{i + 1}" for i in range(n)]
    if derivatives:
        names += [f"{p}{i + 1}" for p in ("qd", "qdd") for i in range(n)]
    return names


def read_trajectory(path, n: int, derivatives: bool = True) -> Trajectory:
    """Read a trajectory CSV of an arm of ``n`` joints.

    ``derivatives=True`` (``synthesize``) requires the header ``t,q1..qn,qd1..qdn,qdd1..qddn``
    that ``manipdyn excite`` writes; ``derivatives=False`` also accepts ``t,q1..qn`` (then
    ``qd`` and ``qdd`` are None).  A regular file of at most
    :data:`manipdyn.limits.MAX_TRAJECTORY_BYTES`; a :class:`~manipdyn.ModelError` names the
    file and the row (1-based, the header is row 1) and column of the first problem.
    """
    where = os.fspath(path)
    full = trajectory_header(n)
    accepted = [full] if derivatives else [full, trajectory_header(n, False)]
    with limits.open_regular(where, f"{where}: cannot read the trajectory file") as fh:
        size = os.fstat(fh.fileno()).st_size
        if size > limits.MAX_TRAJECTORY_BYTES:
            raise limits.over_limit(where, "the trajectory file size", f"{size} bytes", "MAX_TRAJECTORY_BYTES")
        head = fh.read(64 * 1024).decode("utf-8", "replace").lstrip("\ufeff")
    first = next((ln.strip() for ln in head.splitlines() if ln.strip() and not ln.lstrip().startswith("#")), "")
    header = [h.strip() for h in first.split(",")]
    if header not in accepted:          # before the numbers: a wrong file is named as such, not by its row 2
        raise ModelError(f"{where}: expected the header {' or '.join(','.join(h) for h in accepted)} (a trajectory "
                         f"of an arm of {n} joints{', as manipdyn excite writes it' if derivatives else ''}), "
                         f"got {first[:200] or 'an empty file'!r}")
    table = read_table(where)
    data = table.data
    if len(data) < 2:
        raise ModelError(f"{where}: expected at least 2 rows of samples, got {len(data)}")
    steps = np.diff(data[:, 0])
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0)) + 1
        raise ModelError(f"{where}: column 't' must increase strictly (row {int(table.rows[k])})")
    q = data[:, 1:1 + n]
    if len(header) == len(full):
        return Trajectory(data[:, 0], q, data[:, 1 + n:1 + 2 * n], data[:, 1 + 2 * n:])
    return Trajectory(data[:, 0], q, None, None)
