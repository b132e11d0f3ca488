"""The forward dynamics scored beside the torque: the acceleration error ``D^-1 (tau - tau_hat)``.

Layer 5 (identification).

``validate`` scores the inverse dynamics: the torque a model predicts for measured states.  A
simulator (``replay``, MuJoCo, an MPC's model) runs the forward dynamics, ``qdd = D^-1 (tau - h -
g - F)``, and a torque error ``e = tau - tau_hat`` on a direction the arm is light in becomes an
acceleration error ``D^-1 e`` that the torque RMS does not show: a wrist whose inertia about its
axis is a sixth of the truth's predicts torque as well (the torque is small) and accelerates six
times too fast.  So, per sample, with the model's OWN mass matrix ``D(q)`` (rotor inertia
included) at the measured ``q``::

    a_err = D(q)^-1 (tau_measured - tau_predicted)       (n,), rad/s^2 (m/s^2 for a prismatic joint)

is exactly the measured acceleration minus what the model's forward dynamics give for the
measured torque and state (``FD(q, qd, tau) - qdd = D^-1 (tau - ID(q, qd, qdd))``), and its RMS
per joint is scored beside the torque's.  Several models side by side: the best per joint is
the smallest, marked as for torque.

A base model (its JSON) carries base parameters, which do not give ``D``: no acceleration
error is scored for it, and its notes say so.
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError, SingularMassMatrixError, StateError

__all__ = ["acceleration_error", "acceleration_units", "best_accel_per_joint", "format_accel_side_by_side",
           "ACCEL_NOTE"]

#: why a model has no acceleration error
ACCEL_NOTE = ("no acceleration error: a base model's parameters do not give its mass matrix D, so "
              "D^-1 (tau - tau_hat) is not scored (score the model file identify wrote, -o X.toml)")


def acceleration_error(model, q, err):
    """``(a_err, note)``: ``D(q)^-1 err`` per sample (N, n), rad/s^2 or m/s^2, on ``model``'s own
    ``mass_matrix``; ``q`` (N, n) rad or m, ``err`` (N, n) N m or N (measured minus predicted).
    ``a_err`` is None, with the reason as ``note``, when the model has no mass matrix (a base model)
    or it is singular at a sample."""
    mass = getattr(model, "mass_matrix", None) or getattr(getattr(model, "arm", None), "mass_matrix", None)
    if not callable(mass):
        return None, ACCEL_NOTE
    try:
        D = np.asarray(mass(q), dtype=np.float64).reshape(len(q), q.shape[1], q.shape[1])
        return np.linalg.solve(D, err[..., None])[..., 0], None
    except (SingularMassMatrixError, StateError, ModelError, np.linalg.LinAlgError) as exc:
        return None, f"no acceleration error: the mass matrix could not be inverted on these samples ({exc})"


def acceleration_units(units) -> list:
    """The acceleration's unit per joint from the torque's: N m -> rad/s^2, N -> m/s^2."""
    return ["m/s^2" if u == "N" else "rad/s^2" for u in units]


def best_accel_per_joint(results):
    """Index (n,) of the result with the smallest acceleration RMS on each joint, or None when a model
    has none (the first of equals)."""
    if any(r.accel_rms is None for r in results):
        return None
    a = np.array([np.where(np.isfinite(r.accel_rms), r.accel_rms, np.inf) for r in results])
    return np.argmin(a, axis=0)


def format_accel_side_by_side(results, labels, units) -> list:
    """Lines: the acceleration RMS per joint (rows) and model (columns), the best per joint ``*``;
    [] when no model has one."""
    if all(r.accel_rms is None for r in results):
        return []
    best = best_accel_per_joint(results)
    aunits = acceleration_units(units)
    same = len(set(aunits)) == 1
    width = max(12, *(len(lab) + 2 for lab in labels))
    lines = ["forward dynamics: RMS acceleration error D^-1 (tau - tau_hat) on each model's own D"
             + (f" ({aunits[0]})" if same else " (unit at the end of each row)") + ", * = best on the joint",
             "joint " + "".join(f"{lab:>{width}}" for lab in labels)]
    for j in range(len(units)):
        cells = [("-" if r.accel_rms is None else f"{r.accel_rms[j]:.4g}")
                 + ("*" if best is not None and best[j] == k else " ") for k, r in enumerate(results)]
        lines.append(f"{j + 1:>5} " + "".join(f"{c:>{width}}" for c in cells) + ("" if same else f"  {aunits[j]}"))
    if best is not None:
        lines.append("best  " + ", ".join(f"j{j + 1}: {labels[best[j]]}" for j in range(len(units))))
    return lines
