"""The completion of bodies MuJoCo refuses, measured on 200 seeded random arms (issue 40's target).

Each arm (3 to 6 joints, :func:`manipdyn.model.random_arms.random_arm`) gets one hostile body in
turn: a wholly massless last link, a rod (a zero principal moment) on a random link, or a massless
link carrying an inertia (the Puma 560's link 1).  ``md.to_mjcf`` writes it; MuJoCo compiles the
file; where a completion exists, ``M`` and the rigid-body torque agree with manipdyn's trace form
(relative to ``max(1, |reference|)``, 60 seeded states); elsewhere the difference the file states
is compared with the one MuJoCo shows on the same states (to 1e-9 of ``max(1, |tau|)``: a nearest
arm may hold a body at the margin of ``J >= 0``, whose principal axes MuJoCo's compiler resolves to
about 1e-10 of the torque; the exact completions agree to 1e-14).

Run: ``python benchmarks/bench_completion.py [ARMS]`` (default 200).  Needs mujoco and cvxpy.
"""

from __future__ import annotations

import dataclasses
import sys
import time
import warnings

import numpy as np

import manipdyn as md
from manipdyn.formats.losses import written_bodies
from manipdyn.model.random_arms import random_arm


def hostile(seed: int):
    arm = random_arm(seed, n=3 + seed % 4)
    rng = np.random.default_rng(seed)
    k = int(rng.integers(arm.n))
    kind = seed % 3
    links = list(arm.links)
    if kind == 0:
        k, body = arm.n - 1, md.LinkInertia()
    elif kind == 1:
        a = float(rng.uniform(0.01, 0.1))
        body = md.LinkInertia(mass=1.0, com=arm.links[k].body.com, inertia=np.diag([0.0, a, a]))
    else:
        body = md.LinkInertia(mass=0.0, inertia=np.diag([0.0, 0.0, float(rng.uniform(0.01, 0.5))]))
    links[k] = dataclasses.replace(links[k], body=body)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.Manipulator(links, convention=arm.convention, gravity=arm.gravity, name=f"{arm.name}_{kind}"), kind


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


def main(count: int = 200) -> int:
    t0 = time.process_time()
    loaded, exact, worst_exact, worst_stated, nearest = 0, 0, 0.0, 0.0, []
    by_kind = {0: [0, 0], 1: [0, 0], 2: [0, 0]}
    for seed in range(count):
        arm, kind = hostile(seed)
        text = md.to_mjcf(arm)
        got = mujoco_agreement(arm, text, states=60)          # compiles: raises if MuJoCo refuses the file
        loaded += 1
        _bodies, c = written_bodies(arm)
        by_kind[kind][0] += 1
        if c.exact:
            exact += 1
            by_kind[kind][1] += 1
            worst_exact = max(worst_exact, got["M"], got["tau"])
        else:
            nearest.append(c.torque_difference)
            worst_stated = max(worst_stated, abs(got["tau_abs"] - c.torque_difference) / max(1.0, got["tau_max"]))
    cpu = time.process_time() - t0
    print(f"{count} random arms: {loaded} load in MuJoCo; {exact} completed exactly, worst relative M/tau "
          f"difference {worst_exact:.2g}; {len(nearest)} nearest arms, stated difference "
          f"{min(nearest, default=0):.2g} to {max(nearest, default=0):.2g} N m, measured within "
          f"{worst_stated:.2g} (relative to max(1, |tau|)) of the stated; {cpu:.0f} s CPU")
    names = {0: "massless last link", 1: "rod", 2: "massless link with inertia"}
    for kind, (n, e) in by_kind.items():
        print(f"  {names[kind]}: {e} of {n} exact")
    ok = loaded == count and worst_exact <= 1e-10 and worst_stated <= 1e-9
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(int(sys.argv[1]) if len(sys.argv) > 1 else 200))
