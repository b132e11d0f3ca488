"""Motor-side signals of a log brought to the joints (CONVENTIONS.md, "Drives").

Layer 2 (formats: logs).

With the transmission matrix ``R`` (n, n) (gear ratios on the diagonal,
signs allowed, coupling entries off it), the motor offsets ``offset`` (n,)
(rad at the motor) and the torque constants ``k_t`` (n,) (N m/A at the
motor):

* ``q_m = R q + offset``, so ``q = R^-1 (q_m - offset)``;
* ``qd_m = R qd``, so ``qd = R^-1 qd_m`` (and ``qdd`` alike);
* ``tau = R^T tau_m`` and ``tau_m = k_t i`` for a current ``i`` in A.

Power balances: ``tau_m . qd_m = tau . qd``.  Rows of samples are converted
all at once: ``q = (q_m - offset) R^-T`` for q of shape (N, n).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..._support.errors import ModelError

__all__ = ["Drive", "as_drive"]


class Drive:
    """``R`` (n, n), ``offset`` (n,) and ``torque_constant`` (n,) or None, validated."""

    def __init__(self, R, offset, torque_constant):
        self.R, self.offset, self.torque_constant = R, offset, torque_constant
        self._Rinv = np.linalg.inv(R)

    def positions(self, qm):
        """Joint positions (N, n) from motor positions ``qm`` (N, n), rad at the motor."""
        return (np.asarray(qm) - self.offset) @ self._Rinv.T

    def rates(self, qdm):
        """Joint velocities or accelerations (N, n) from the motor's (N, n)."""
        return np.asarray(qdm) @ self._Rinv.T

    def motor_rates(self, qd):
        """Motor velocities ``qd_m = R qd`` (N, n) from joint velocities (N, n)."""
        return np.asarray(qd) @ self.R.T

    def torques(self, taum=None, current=None):
        """Joint torques ``tau = R^T tau_m`` (N, n) from motor torques (N m) or currents (A)."""
        if current is not None:
            taum = np.asarray(current) * self.torque_constant
        return np.asarray(taum) @ self.R


def _get(obj, name):
    if obj is None:
        return None
    if isinstance(obj, Mapping):
        return obj.get(name)
    return getattr(obj, name, None)


def as_drive(n: int, transmission=None, *, R=None, motor_offset=None, torque_constant=None,
             where: str = "transmission") -> Drive | None:
    """A :class:`Drive` for an arm of ``n`` joints, or None when nothing is given.

    ``transmission`` is any object (or mapping) with ``R``, ``motor_offset`` and
    ``torque_constant`` (e.g. the model's transmission); the keyword arrays
    override its attributes.  ``R`` is required; the offset defaults to zeros;
    ``torque_constant`` is needed only to convert currents.  Raises
    :class:`ModelError` naming the argument for a wrong shape, a non-finite
    entry or a singular ``R``.
    """
    R = R if R is not None else _get(transmission, "R")
    off = motor_offset if motor_offset is not None else _get(transmission, "motor_offset")
    kt = torque_constant if torque_constant is not None else _get(transmission, "torque_constant")
    if R is None and off is None and kt is None:
        if transmission is not None:
            raise ModelError(f"{where}: expected an object or mapping with R (n, n), motor_offset (n,) and "
                             f"torque_constant (n,), got {type(transmission).__name__}")
        return None
    if R is None:
        raise ModelError(f"{where}: R (n, n), the transmission matrix q_m = R q + offset, is required")

    def arr(x, shape, name):
        try:
            a = np.array(x, dtype=np.float64)
        except (TypeError, ValueError):
            raise ModelError(f"{where}: {name}: expected numbers of shape {shape}, got {x!r:.60}") from None
        if a.shape != shape:
            if a.ndim == 0 and len(shape) == 1:
                a = np.full(shape, float(a))
            elif shape == (n, n) and a.shape == (n,):
                a = np.diag(a)               # gear ratios only: a diagonal R
            else:
                raise ModelError(f"{where}: {name}: expected shape {shape} for {n} joints, got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ModelError(f"{where}: {name}: every entry must be finite")
        return a

    Rm = arr(R, (n, n), "R")
    if np.linalg.cond(Rm) > 1e12:
        raise ModelError(f"{where}: R is singular (condition number {np.linalg.cond(Rm):.3g}); every joint "
                         "needs a motor: q = R^-1 (q_m - offset)")
    offset = np.zeros(n) if off is None else arr(off, (n,), "motor_offset")
    k = None if kt is None else arr(kt, (n,), "torque_constant")
    return Drive(Rm, offset, k)
