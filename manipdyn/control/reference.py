"""The user's own reference path for ``track``: a CSV of ``t, q1..qn`` read into a trajectory.

Layer 6 (control).  :func:`read_path` reads the file with the trajectory reader of the logs
(:func:`manipdyn.formats.logs.trajectory.read_trajectory`: streamed, capped, the header checked,
rows and columns named in every error), checks it against the arm and interpolates it with
:class:`~manipdyn.control.trajectory.Sampled`:

* the header ``t,q1..qn`` (s; rad, m for prismatic joints), or ``t,q1..qn,qd1..qdn,qdd1..qddn``
  as ``manipdyn excite`` writes it, whose velocities and accelerations the interpolation then
  matches (quintic Hermite; with positions alone, the natural cubic spline);
* times strictly increasing, at least 2 rows; the path starts at its first time, which
  becomes t = 0 of the run;
* every position within the arm's joint limits (``arm.qlim``): the row, the column and
  the limit are named.

After its last sample the reference holds the last position at rest.
"""

from __future__ import annotations

import os

import numpy as np

from .._support.errors import ModelError
from ..formats.logs.trajectory import read_trajectory
from .trajectory import Sampled

__all__ = ["ReferencePath", "read_path"]


class ReferencePath(Sampled):
    """A :class:`~manipdyn.control.trajectory.Sampled` trajectory read from a file:
    ``source`` (the file, for headers and figures), ``samples`` (rows), ``t0`` (the file's
    first time, s; the run's t = 0) and ``columns`` (what the file gave: ``"q"`` or
    ``"q, qd, qdd"``)."""

    def __init__(self, t, q, qd=None, qdd=None, *, source: str = "", t0: float = 0.0, columns: str = "q"):
        super().__init__(t, q, qd, qdd)
        self.source, self.samples, self.t0, self.columns = source, len(t), float(t0), columns


def read_path(path, arm) -> ReferencePath:
    """The reference path in the CSV file ``path`` for ``arm`` (module docstring).

    Raises :class:`~manipdyn.ModelError` naming the file, and the row and column at fault.
    """
    where = os.fspath(path)
    traj = read_trajectory(path, arm.n, derivatives=False)
    q, lo, hi = traj.q, arm.qlim[:, 0], arm.qlim[:, 1]
    out = (q < lo) | (q > hi)
    if np.any(out):
        r, j = np.argwhere(out)[0]
        unit = "m" if arm.joint_types[j] == "prismatic" else "rad"
        raise ModelError(f"{where}: row {_file_row(where, r)}, column {j + 2} ('q{j + 1}'): {q[r, j]:g} {unit} is "
                         f"outside joint {j + 1}'s limits [{lo[j]:g}, {hi[j]:g}] {unit} (degrees for radians?)")
    columns = "q" if traj.qd is None else "q, qd, qdd"
    return ReferencePath(traj.t - traj.t[0], q, traj.qd, traj.qdd, source=where, t0=float(traj.t[0]),
                         columns=columns)


def _file_row(where: str, k: int) -> int:
    """The 1-based line of the file (header included) of data row ``k``: blank and ``#`` lines
    are skipped by the reader, so they are counted here, only when an error is reported."""
    seen = -1
    with open(where, encoding="utf-8", errors="replace") as fh:
        for line, text in enumerate(fh, 1):
            if text.strip() and not text.lstrip().startswith("#"):
                if seen == k:
                    return line
                seen += 1
    return k + 2
