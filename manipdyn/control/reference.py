"""The user's own reference path for ``track``: a CSV of ``t, q1..qn`` read into a trajectory.

Layer 6 (control).  :func:`read_path` reads the file with the logs' CSV reader
(:func:`manipdyn.formats.logs.table.read_table`: streamed, capped, rows and columns named
in every error), checks it against the arm and interpolates it with
:class:`~manipdyn.control.trajectory.Sampled`:

* columns ``t`` (s) and ``q1`` .. ``qn`` (rad, m for prismatic joints), in any order;
  optionally ``qd1`` .. ``qdn`` (and then optionally ``qdd1`` .. ``qddn``), which the
  interpolation then matches (cubic or quintic Hermite; with positions alone, the natural
  cubic spline);
* any other column is refused by name (a measurement log's ``tau1`` is not a path);
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
from ..formats.logs.table import read_table
from .trajectory import Sampled

__all__ = ["ReferencePath", "read_path"]


class ReferencePath(Sampled):
    """A :class:`~manipdyn.control.trajectory.Sampled` trajectory read from a file:
    ``source`` (the file, for headers and figures), ``samples`` (rows), ``t0`` (the file's
    first time, s; the run's t = 0) and ``columns`` (what the file gave: ``"q"``,
    ``"q, qd"`` or ``"q, qd, qdd"``)."""

    def __init__(self, t, q, qd=None, qdd=None, *, source: str = "", t0: float = 0.0, columns: str = "q"):
        super().__init__(t, q, qd, qdd)
        self.source, self.samples, self.t0, self.columns = source, len(t), float(t0), columns


def read_path(path, arm, label: str | None = None) -> ReferencePath:
    """The reference path in the CSV file ``path`` for ``arm`` (module docstring).

    ``label`` names the file in messages (default: the path; the command line passes
    ``"--path FILE"``).  Raises :class:`~manipdyn.ModelError` naming the file and the row
    and column at fault.
    """
    where = label or os.fspath(path)
    table = read_table(path, where)
    n = arm.n
    header = [h.strip() for h in table.header]
    seen = {h: c for c, h in enumerate(header)}          # read_table refuses a repeated name
    groups = {"t": ["t"], "q": [f"q{j}" for j in range(1, n + 1)], "qd": [f"qd{j}" for j in range(1, n + 1)],
              "qdd": [f"qdd{j}" for j in range(1, n + 1)]}
    known = {name for names in groups.values() for name in names}
    extra = [f"column {c + 1} ({h!r})" for c, h in enumerate(header) if h not in known]
    if extra:
        raise ModelError(f"{where}: {', '.join(extra[:5])}{' ...' if len(extra) > 5 else ''} not part of a "
                         f"reference path for {arm.name or 'the arm'}'s {n} joints: expected t, q1..q{n} "
                         f"(optionally qd1..qd{n}, then qdd1..qdd{n})")
    for g in ("t", "q"):
        missing = [h for h in groups[g] if h not in seen]
        if missing:
            raise ModelError(f"{where}: no column {', '.join(missing[:5])}{' ...' if len(missing) > 5 else ''}: "
                             f"expected t, q1..q{n} (one position column per joint of {arm.name or 'the arm'})")
    given = {g: [h in seen for h in groups[g]] for g in ("qd", "qdd")}
    for g in ("qd", "qdd"):
        if any(given[g]) and not all(given[g]):
            missing = [h for h, ok in zip(groups[g], given[g]) if not ok]
            raise ModelError(f"{where}: column(s) {', '.join(missing)} missing: give all of {g}1..{g}{n} or none")
    if all(given["qdd"]) and not all(given["qd"]):
        raise ModelError(f"{where}: qdd1..qdd{n} without qd1..qd{n}: give the velocities too (or neither)")
    data, rows = table.data, table.rows
    if len(data) < 2:
        raise ModelError(f"{where}: {len(data)} data row(s); a path needs at least 2 (t, q1..q{n} per row)")
    col = {g: data[:, [seen[h] for h in groups[g]]] for g in groups if all(h in seen for h in groups[g])}
    t = col["t"][:, 0]
    step = np.diff(t)
    if np.any(~(step > 0)):
        k = int(np.argmax(~(step > 0))) + 1
        raise ModelError(f"{where}: row {rows[k]}, column {seen['t'] + 1} ('t'): time {t[k]:g} s does not "
                         f"come after {t[k - 1]:g} s (row {rows[k - 1]}): times must increase strictly")
    q = col["q"]
    lo, hi = arm.qlim[:, 0], arm.qlim[:, 1]
    out = (q < lo) | (q > hi)
    if np.any(out):
        r, j = np.argwhere(out)[0]
        unit = "m" if arm.joint_types[j] == "prismatic" else "rad"
        raise ModelError(f"{where}: row {rows[r]}, column {seen[f'q{j + 1}'] + 1} ('q{j + 1}'): {q[r, j]:g} {unit} "
                         f"is outside joint {j + 1}'s limits [{lo[j]:g}, {hi[j]:g}] {unit} (degrees for radians?)")
    columns = ", ".join(g for g in ("q", "qd", "qdd") if g in col)
    return ReferencePath(t - t[0], q, col.get("qd"), col.get("qdd"), source=where, t0=float(t[0]), columns=columns)
