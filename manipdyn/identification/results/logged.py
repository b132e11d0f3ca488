"""A log's own torque columns as one more model in ``validate``: e.g. the UR controller's target torque.

Layer 5 (identification).

Many controllers log, beside the measurement, what their own model predicts: a UR arm's
``target_moment`` (``m1..m6`` in the logs of ``../shared/realdata/ur5_kufieta2013``: its internal
model evaluated on the target motion, N m at the joints).  ``validate MODEL LOG --compare-column
"m=UR controller target torque"`` reads those columns, with the same time base, filter and
samples as the measured torque (the log is read a second time with the torque signal mapped to
them), and scores them as one more model beside the others: the same table, the best per joint
marked.  The measured torque is the measured one as the first model reads it, currents
through its torque constants included; so on such a log the comparison is the controller's
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


def read_logged(spec, logs, arm, data, read_options: dict) -> LoggedTorque:
    """The logged torque named by ``spec`` (:func:`compare_column`) on the samples of ``data`` (the stacked
    measurements of ``logs``, read with ``read_options``): each log read again with the torque signal
    mapped to those columns (and currents and motor torques mapped away), stacked, checked to be the
    same samples."""
    from ...formats.logs.columns import column_map
    from ..inputs.runs import read_runs, stack

    pattern, label = compare_column(spec)
    patterns = dict(column_map(read_options.get("columns"), "columns").patterns)
    patterns.update({"tau": pattern, "i": "\0unused_i{i}", "taum": "\0unused_taum{i}"})
    opts = dict(read_options, columns=patterns)
    try:
        runs = read_runs(logs, arm, **opts)
    except ModelError as exc:
        raise ModelError(f"compare_column {spec!r}: {exc}") from None
    other = stack([d for d, _ in runs])
    if other.q.shape != data.q.shape or not np.allclose(other.t, data.t):
        raise ModelError(f"compare_column {spec!r}: the logged torque was not read on the measured torque's samples")
    return LoggedTorque(label, data.q, other.tau)
