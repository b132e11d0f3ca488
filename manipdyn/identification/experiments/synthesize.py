"""A measurement log synthesised from a model: identification without a robot.

Layer 5 (identification).

``manipdyn excite`` writes a trajectory ``t,q1..qn,qd1..qdn,qdd1..qddn``; a
robot run along it logs its joint torques.  Without a robot,
:func:`synthesize` computes them from a model (inverse dynamics, the fast
path, friction included) and adds seeded Gaussian noise of ``noise`` times
each joint's peak torque, the way :mod:`manipdyn.identification.experiments.demo` does::

    traj = read_trajectory("traj.csv", arm.n)      # manipdyn.formats.logs.trajectory
    tau = synthesize(arm, traj.q, traj.qd, traj.qdd, noise=0.01, seed=0)

:func:`manipdyn.identification.experiments.demo.true_arm` gives an arm around a prior
(masses +-20 %, centres of mass moved by up to 2 cm, friction added), for a
log that the prior does not fit exactly (``manipdyn synthesize --perturb``).
"""

from __future__ import annotations

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError
from ...formats.logs.trajectory import Trajectory, read_trajectory

__all__ = ["Trajectory", "read_trajectory", "synthesize"]


def synthesize(arm, q, qd, qdd, noise: float = 0.01, seed: int = 0) -> np.ndarray:
    """Joint torques of ``arm`` along ``(q, qd, qdd)`` (N, n) with noise, N m (N), shape (N, n).

    ``tau = arm.inverse_dynamics(q, qd, qdd) + noise * peak_j * e``, with
    ``peak_j = max |tau_j|`` over the samples and ``e`` standard normal from
    ``numpy.random.default_rng(seed)``.  ``noise = 0`` gives the exact torques.
    """
    noise = limits.nonnegative(noise, "noise")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ModelError(f"seed: expected an integer >= 0, got {seed!r}")
    tau = np.asarray(arm.inverse_dynamics(q, qd, qdd), dtype=np.float64).reshape(len(q), arm.n)
    if not np.all(np.isfinite(tau)):
        raise ModelError("synthesize: the torques along this trajectory overflow; check the model's units")
    peak = np.abs(tau).max(axis=0)
    return tau + noise * peak * np.random.default_rng(seed).standard_normal(tau.shape)
