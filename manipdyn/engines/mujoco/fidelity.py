"""How far MuJoCo's forward dynamics on an arm's own MJCF, constraints as the file has them,
lie from the model's: what ``manipdyn mjcf`` prints beside the file's losses.

Layer 3 (engines: mujoco).

MJCF holds Coulomb friction as ``frictionloss``, which MuJoCo solves as a soft constraint
(regularised by ``solref``/``solimp``), not as the law's sign function; comparing the two
laws' formulas says nothing of that.  :func:`forward_dynamics_difference` measures it: on
seeded states inside the joint ranges (limits inactive) and sliding (every ``|qd_j|`` at
least :data:`SLIDING` rad/s or m/s, where the law's smoothing has saturated), it sets
``tau = arm.inverse_dynamics(q, qd, qdd)`` for a known ``qdd`` and asks ``mj_forward`` on
the file's model (:meth:`.engine.MujocoEngine.simulation_model`: frictionloss and limits
active) for ``qacc``.  ``qacc - qdd`` is the whole difference a MuJoCo user meets: the soft
constraint, and any term of the friction law the file cannot hold.  As a joint torque,
``M (qacc - qdd)`` (MuJoCo's mass matrix, ``mj_fullM``) is the friction MuJoCo applies less
the law's: on a light joint with a large Coulomb level the soft constraint, whose force grows
with the sliding velocity up to ``frictionloss``, applies a fraction of it.
"""

from __future__ import annotations

import numpy as np


__all__ = ["forward_dynamics_difference", "SLIDING", "SAMPLES"]

#: smallest ``|qd_j|`` of the measured states, rad/s (m/s): the joints slide, away from stiction
SLIDING = 0.2
#: states measured by default
SAMPLES = 32


def forward_dynamics_difference(arm, samples: int = SAMPLES, seed: int = 0) -> dict:
    """MuJoCo's ``qacc`` on ``arm``'s MJCF against the model's ``qdd`` (module docstring).

    Parameters
    ----------
    arm : manipdyn.Arm
    samples : int
        Seeded states (``numpy.random.default_rng(seed)``).

    Returns
    -------
    dict
        ``"qdd"`` (n,): largest ``|qacc_j - qdd_j|`` over the states, rad/s^2 (m/s^2);
        ``"torque"`` (n,): largest ``|(M (qacc - qdd))_j|``, N m (N);
        ``"samples"``, ``"sliding"`` (the smallest ``|qd|``, rad/s or m/s).
    """
    mj, m = arm.engine("mujoco").simulation_model(1e-3)     # the arm's own engine, compiled once per arm
    d = mj.MjData(m)
    rng = np.random.default_rng(seed)
    n = arm.n
    lo, hi = arm.qlim[:, 0], arm.qlim[:, 1]
    q = lo + (hi - lo) * (0.1 + 0.8 * rng.random((samples, n)))          # inside the ranges: limits inactive
    qd = rng.choice([-1.0, 1.0], (samples, n)) * rng.uniform(SLIDING, 5 * SLIDING, (samples, n))
    qdd = rng.uniform(-1.0, 1.0, (samples, n))
    tau = np.asarray(arm.inverse_dynamics(q, qd, qdd), dtype=np.float64)
    diff = np.empty_like(qdd)
    force = np.empty_like(qdd)
    M = np.zeros((m.nv, m.nv))
    for k in range(samples):
        d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q[k], qd[k], tau[k]
        d.ctrl[:] = 0.0
        mj.mj_forward(m, d)
        mj.mj_fullM(m, d, M)
        diff[k] = d.qacc - qdd[k]
        force[k] = M @ diff[k]
    return {"qdd": np.abs(diff).max(axis=0), "torque": np.abs(force).max(axis=0), "samples": int(samples),
            "sliding": SLIDING}
