"""A log's own torque columns as one more model in ``validate``: e.g. the UR controller's target torque.

Layer 5 (identification).

Many controllers log, beside the measurement, what their own model predicts: a UR arm's
``target_moment`` (``m1..m6`` in the logs of the UR5 real-data set: its internal
model evaluated on the target motion, N m at the joints).  ``validate MODEL LOG --compare-column
"m=UR controller target torque"`` reads those columns, with the measured torque's time base and
samples (each log's columns interpolated at the measured samples' times), and scores them as one
more model beside the others: the same table, the best per joint marked.  The measured torque is
the measured one as the first model reads it, currents through its torque constants included; so on such a log the comparison is the controller's
torque against ``k_t i``, which per joint is the comparison in current through the same ``k_t``.
The logged torque carries no band and no fitted range: it is no identified model.
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError

__all__ = ["LoggedTorque", "compare_column", "read_logged"]


class LoggedTorque:
    """The torque columns of a log as a model of the stacked samples it was read with: ``inverse_dynamics``
    returns them (N, n) for exactly those samples' ``q``, and refuses any other states."""

    def __init__(self, name: str, q: np.ndarray, tau: np.ndarray):
        self.name, self._q, self._tau = name, np.asarray(q), np.asarray(tau)
        self.n = self._tau.shape[1]

    def inverse_dynamics(self, q, qd=None, qdd=None) -> np.ndarray:
        """The logged torques (N, n) of the samples whose positions are ``q`` (N, n)."""
        q = np.asarray(q)
        if q.shape != self._q.shape or not np.array_equal(q, self._q):
            raise ModelError(f"{self.name}: a logged torque predicts only the samples it was logged with")
        return self._tau.copy()


def compare_column(spec) -> tuple[str, str]:
    """``(pattern, label)`` of ``"m"``, ``"m{i}"`` or ``"m=UR controller target torque"``: the header pattern of
    the logged torque columns (``{i}`` the joint number, added when absent) and the model's name."""
    if not isinstance(spec, str) or not spec.partition("=")[0].strip():
        raise ModelError(f"compare_column: expected a column name like 'm' (columns m1..mn) or "
                         f"'m=UR controller target torque', got {spec!r:.60}")
    pattern, _, label = (x.strip() for x in spec.partition("="))
    if "{i" not in pattern:
        pattern += "{i}"
    return pattern, label or f"logged torque {pattern.replace('{i}', '1')}.."


def read_logged(spec, data, read_options: dict) -> LoggedTorque:
    """The logged torque named by ``spec`` (:func:`compare_column`) on the samples of ``data`` (the stacked
    measurements, each run's ``source`` a CSV file read with ``read_options``): each file's columns read as
    they are and interpolated linearly at that run's sample times (the measured torque's own time base; a
    controller's target is logged as it is, so duplicate rows, which the measured signals' reading drops,
    are kept here: the first of equal time stamps)."""
    from ...formats.logs.columns import column_map
    from ...formats.logs.table import read_table

    pattern, label = compare_column(spec)
    cmap = column_map(read_options.get("columns"), "columns")
    n = data.q.shape[1]
    names = [pattern.replace("{i0}", str(j)).replace("{i}", str(j + 1)) for j in range(n)]
    scale = float(read_options.get("time_scale") or 1.0)
    rate = read_options.get("rate")
    parts, start = [], 0
    for src, k in zip(getattr(data, "sources", [data.source]), getattr(data, "segments", [len(data.t)])):
        where = str(src)
        if not where.lower().endswith((".csv", ".txt", ".tsv")):
            raise ModelError(f"compare_column {spec!r}: {where}: only a CSV log holds such columns")
        table = read_table(where, where)
        missing = [x for x in names if x not in table.header]
        if missing:
            raise ModelError(f"compare_column {spec!r}: {where}: missing column(s) {missing}; expected "
                             f"{names[0]}..{names[-1]} (N m at the joints)")
        d = table.data
        t = (np.arange(len(d)) / float(rate) if rate is not None
             else d[:, table.column(cmap.names("t", n)[0])] * scale)
        t, first = np.unique(t, return_index=True)            # the first row of each time stamp
        values = d[first][:, [table.column(x) for x in names]]
        ts = data.t[start:start + k]
        parts.append(np.column_stack([np.interp(ts, t, values[:, j]) for j in range(n)]))
        start += k
    return LoggedTorque(label, data.q, np.concatenate(parts))
