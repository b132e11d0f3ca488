"""The floor under a joint's noise estimate: rounding, not noise.

Layer 5 (identification).

:func:`.fitting.fit` weighs each joint by ``1 / sigma_j``, its noise level from its own OLS
residuals.  On exact data (synthetic, or a joint whose torque is a model's output) every
``sigma_j`` is float64 rounding, ~1e-12 of the torque and arbitrary, and the weights would be
noise.  A joint's estimate is taken for rounding when it is below ``FLOOR`` (1e-6) times **that
joint's own** RMS torque; such a joint is weighed as if its noise were ``FLOOR`` times the
largest joint's RMS torque (so exact data weigh the joints equally, and the semidefinite program
stays well scaled).  The test is each joint's own, so it never replaces a real noise level of a
weak joint: a UR5 wrist with 1e-3 N m torques and 6e-6 N m of noise keeps its estimate (a floor
of 1e-6 of the shoulder's torque, 4.9e-5 N m, used to replace it and weighed that joint as 8 times
noisier than it is).  Which joints hit the floor is said (``report["noise_floor_joints"]`` and
the ``identify`` text), since their "noise" is then the floor and not an estimate.
"""

from __future__ import annotations

import numpy as np

__all__ = ["FLOOR", "floor_noise"]

#: a joint's noise level below this fraction of its own RMS torque is rounding, not noise
FLOOR = 1e-6


def floor_noise(sigmas, y):
    """``sigmas`` (k, n): per run (k runs) and joint, the OLS noise levels (N m, N); ``y`` (N, n):
    the torques the fit explains.  Returns ``(sigmas with the floor where they are rounding (k, n),
    joints (list of 1-based indices) whose estimate, in any run, was rounding)``."""
    sigmas = np.asarray(sigmas, dtype=np.float64)
    rms = np.sqrt(np.mean(np.asarray(y, dtype=np.float64) ** 2, axis=0))
    top = max(float(rms.max()), 1e-300)
    rounding = ~(sigmas >= FLOOR * np.maximum(rms, FLOOR * top))          # (k, n): below its own floor
    out = np.where(rounding, np.maximum(sigmas, FLOOR * top), sigmas)
    return out, [int(j) + 1 for j in np.flatnonzero(rounding.any(axis=0))]
