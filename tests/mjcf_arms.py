"""Arms with every drive MJCF can hold, for the MJCF and MuJoCo-engine tests (a helper, no tests).

* ``drive_arm(seed, kind)``: a seeded random arm (:func:`manipdyn.model.random_arms.random_arm`,
  rotors on) given viscous friction joint side (``"joint"``), motor side through a diagonal
  transmission (``"motor"``), or motor side through a coupled transmission whose last motor
  also turns with the joint before it (``"coupled"``: the tendon case).
"""

from __future__ import annotations

import warnings

import numpy as np

import manipdyn as md
from manipdyn.model.random_arms import random_arm

KINDS = ("joint", "motor", "coupled")


def drive_arm(seed: int, kind: str, n: int | None = None) -> md.Manipulator:
    """A physical random arm with rotor inertia and viscous friction of the given ``kind``."""
    rng = np.random.default_rng(10_000 + seed)
    base = random_arm(seed, n=n, rotors=True)
    k = base.n
    fv = rng.uniform(0.01, 2.0, k)
    G = [l.gear_ratio for l in base.links]
    transmission = None
    if kind == "coupled" and k >= 2:
        transmission = md.Transmission.from_gear_ratios(G, coupling=[[k, k - 1, float(rng.uniform(0.3, 2.0))]])
    if kind == "joint":
        law = md.Friction(viscous=fv, smoothing=0.0)
    else:                       # motor side: coefficients at the motor, N m s/rad (reflected by G^2)
        law = md.Friction(viscous=fv / np.square(G), side="motor", smoothing=0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", md.PhysicalConsistencyWarning)
        return md.Manipulator(base.links, convention=base.convention, gravity=base.gravity,
                              name=f"{base.name}_{kind}", transmission=transmission, friction=law)


def mujoco_agreement(arm, text: str, states: int = 40, seed: int = 0) -> dict:
    """MuJoCo on the MJCF ``text`` against manipdyn's trace form of ``arm``: the largest difference of
    ``M`` and of the rigid-body torque ``M qdd + h + g`` (friction taken out on both sides: MuJoCo's
    ``qfrc_passive`` and manipdyn's law), over ``states`` seeded random states, relative to
    ``max(1, |reference|)`` per state (``tau_abs``: the largest absolute torque difference, N m; ``tau_max``: the largest torque);
    constraints (frictionloss, limits) disabled."""
    import mujoco

    m = mujoco.MjModel.from_xml_string(text)
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(seed)
    q = arm.random_state(rng, states)
    qd = rng.uniform(-2.0, 2.0, q.shape)
    qdd = rng.uniform(-5.0, 5.0, q.shape)
    tau_ref = arm.lagrange.inverse_dynamics(q, qd, qdd)
    if arm.friction_model is not None:
        tau_ref = tau_ref - arm.friction_model.torque(qd, arm.transmission)
    M_ref = arm.lagrange.mass_matrix(q)
    worst = {"M": 0.0, "tau": 0.0, "tau_abs": 0.0, "tau_max": float(np.abs(tau_ref).max())}
    for k in range(states):
        d.qpos[:], d.qvel[:], d.qacc[:] = q[k], qd[k], qdd[k]
        mujoco.mj_inverse(m, d)
        tau = d.qfrc_inverse + d.qfrc_passive
        M = np.zeros((arm.n, arm.n))
        mujoco.mj_fullM(m, d, M)
        worst["tau_abs"] = max(worst["tau_abs"], float(np.abs(tau - tau_ref[k]).max()))
        worst["tau"] = max(worst["tau"], float(np.abs(tau - tau_ref[k]).max() / max(1.0, np.abs(tau_ref[k]).max())))
        worst["M"] = max(worst["M"], float(np.abs(M - M_ref[k]).max() / max(1.0, np.abs(M_ref[k]).max())))
    return worst
