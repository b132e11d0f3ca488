"""Torques in another unit than the model's: said, not scored or fitted in silence.

Layer 5 (identification).

A log whose torques are in mN m, read as N m, is 1000 times what any model of the arm predicts:
``validate`` would print an R^2 of -2.5 and ``identify`` fit a model 1000 times too heavy.  manipdyn
reads torques in N m (N for a prismatic joint) and has no torque-unit option, so the way out is to
convert the log's columns.  :func:`torque_scale_note` says it, naming the likely unit, from the ratio
of the measured torque's RMS to the predicted one's (all joints together).
"""

from __future__ import annotations

import numpy as np

__all__ = ["torque_ratio", "torque_scale_note", "prior_torque_note", "RATIO"]

#: a measured torque this many times the model's (or this many times smaller) is said
RATIO = 10.0
#: the units a ratio points to (to within 25 %), for the hint
_UNITS = ((1e3, "mN m read as N m give 1000"), (1e2, "N cm read as N m give 100"),
          (1e-3, "kN m read as N m give 1/1000"), (1e6, "uN m read as N m give 1e6"))


def torque_ratio(measured, predicted) -> float:
    """RMS of ``measured`` over RMS of ``predicted`` ((N, n) each, N m or N), all joints pooled;
    nan when the prediction is zero or not finite."""
    m = np.asarray(measured, dtype=np.float64)
    p = np.asarray(predicted, dtype=np.float64)
    ok = np.isfinite(m) & np.isfinite(p)
    if not ok.any():
        return float("nan")
    pm, pp = float(np.sqrt(np.mean(m[ok] ** 2))), float(np.sqrt(np.mean(p[ok] ** 2)))
    return pm / pp if pp > 0 and np.isfinite(pp) else float("nan")


def torque_scale_note(measured, predicted, who: str = "the model") -> str | None:
    """One line when the measured torques are over :data:`RATIO` times (or under 1/RATIO of) what
    ``who`` predicts on the same samples, else None."""
    r = torque_ratio(measured, predicted)
    if not (np.isfinite(r) and r > 0) or 1.0 / RATIO <= r <= RATIO:
        return None
    hint = next((text for u, text in _UNITS if abs(np.log(r / u)) < np.log(1.25)), None)
    return (f"UNITS? the measured torques are {r:.4g} times what {who} predicts on these motions (RMS, all joints)"
            + (f" ({hint})" if hint else "") + ": manipdyn reads torques in N m (N for a prismatic joint) and has "
            "no torque-unit option; convert the log's torque columns, or check that the model is this arm")


def prior_torque_note(arm, data, who: str = "the prior", samples: int = 200) -> str | None:
    """:func:`torque_scale_note` of ``data`` (Measurements: q, qd, qdd, tau) against ``arm``'s inverse
    dynamics on at most ``samples`` evenly spaced samples (the cost of a few ms of fitting)."""
    idx = np.unique(np.linspace(0, len(data.q) - 1, min(samples, len(data.q))).astype(int))
    try:
        pred = np.asarray(arm.inverse_dynamics(data.q[idx], data.qd[idx], data.qdd[idx]), dtype=np.float64)
    except (ValueError, FloatingPointError, ArithmeticError):
        return None
    return torque_scale_note(np.asarray(data.tau)[idx], pred, who)
