"""The limits an excitation keeps: joint range (with a margin), velocity and acceleration.

Layer 5 (identification).

Both designs, the Fourier series (:mod:`manipdyn.identification.experiments.trajectory`) and the point-to-point run (:mod:`manipdyn.identification.experiments.ptp`), keep
the same limits: the model's joint limits ``arm.qlim`` shrunk by a margin (default 5 % of the range
at each end), ``|qd_j| <= vmax_j`` and ``|qdd_j| <= amax_j``.  Default limits, per joint: revolute
1.5 rad/s and 5 rad/s^2, prismatic 0.3 m/s and 1 m/s^2 (comfortable for the bundled arms; give the
real arm's limits).
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError

__all__ = ["motion_limits", "DEFAULT_VMAX", "DEFAULT_AMAX"]

#: default velocity limit: revolute (rad/s), prismatic (m/s)
DEFAULT_VMAX = {"revolute": 1.5, "prismatic": 0.3}
#: default acceleration limit: revolute (rad/s^2), prismatic (m/s^2)
DEFAULT_AMAX = {"revolute": 5.0, "prismatic": 1.0}


def motion_limits(arm, vmax=None, amax=None, margin: float = 0.05):
    """``(vmax, amax, lo, hi)``, each (n,): the velocity and acceleration limits per joint (``vmax``, ``amax``:
    None for the defaults by joint type, one value for all, or n values; rad/s, rad/s^2, or m/s, m/s^2)
    and the joint limits ``arm.qlim`` shrunk by ``margin`` of each joint's range at both ends (rad or m).
    A :class:`ModelError` names ``vmax``, ``amax`` or ``margin`` when it is not of that form."""
    n = arm.n

    def per_joint(value, default, what):
        if value is None:
            return np.array([default[t] for t in arm.joint_types])
        v = np.asarray(value, dtype=np.float64).reshape(-1)
        if v.size not in (1, n):
            raise ModelError(f"{what}: expected 1 or {n} values, got {v.size}")
        v = np.broadcast_to(v, (n,)).copy()
        if not np.all(np.isfinite(v)) or np.any(v <= 0):
            raise ModelError(f"{what}: expected positive finite limits (one or {n} values), got {value!r}")
        return v

    vmax = per_joint(vmax, DEFAULT_VMAX, "vmax")
    amax = per_joint(amax, DEFAULT_AMAX, "amax")
    if not 0 <= margin < 0.5:
        raise ModelError(f"margin: expected a fraction in [0, 0.5), got {margin!r}")
    lo, hi = arm.qlim[:, 0], arm.qlim[:, 1]
    span = hi - lo
    return vmax, amax, lo + margin * span, hi - margin * span
