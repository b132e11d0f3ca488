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

from benchmarks.bench_completion import mujoco_agreement  # noqa: F401  (one implementation, the benchmark's)

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


