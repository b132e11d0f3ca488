"""The arms the benchmark runs on, all built without rotors and without friction.

* :func:`bench_arms`: the bundled DH arms (puma560, stanford, and ur5/ur10 once
  bundled), with motor inertia and friction removed (``dataclasses.replace``),
  so that Pinocchio, the trace form and the Robotics Toolbox compute the same
  rigid-body dynamics.
* :func:`probe_arms`: seeded random arms that are only *checked* (never timed):
  a standard arm and a modified (Craig) arm whose first joint is prismatic,
  and a modified all-revolute arm, all with gravity off the base z axis.  They
  exercise the corners where the Toolbox has had bugs.
* :func:`random_chain`: seeded random all-revolute standard-DH chains with
  physical inertias, for the scaling study (n = 2..24).
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np

import manipdyn as md
from manipdyn.model.random_arms import random_arm

#: bundled arms timed when present, in this order
BENCH_ARMS = ("puma560", "stanford", "ur5", "ur10")


def strip_actuators(arm, name=None):
    """The same DH arm with ``motor_inertia = 0`` and no friction on every link."""
    links = [dataclasses.replace(l, motor_inertia=0.0, friction_viscous=0.0, friction_coulomb=0.0)
             for l in arm.links]
    with warnings.catch_warnings():
        # the published Puma/Stanford data are not physical (see their model
        # files); md.load already warned about that once
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.Manipulator(links, convention=arm.convention, gravity=arm.gravity,
                              name=name or arm.name, source=getattr(arm, "source", ""))


def bench_arms(names=None):
    """``(arms, skipped)``: the bundled arms to time, actuators stripped.

    ``skipped`` lists ``(name, reason)`` for requested arms that cannot be used.
    """
    available = set(md.models())
    arms, skipped = [], []
    for name in (names or BENCH_ARMS):
        if name not in available:
            skipped.append((name, "not bundled (md.models() has: " + ", ".join(sorted(available)) + ")"))
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
            arm = md.load(name)
        if not hasattr(arm, "links"):
            skipped.append((name, f"not a DH arm ({type(arm).__name__}): cannot strip rotors per link"))
            continue
        arms.append(strip_actuators(arm))
    return arms, skipped


def random_chain(n, seed=0, convention="standard", joints=None, gravity=(0.0, 0.0, -9.81), name=None):
    """A seeded random DH arm with physical inertias, no rotors (all revolute unless ``joints`` says)."""
    return random_arm(seed, convention=convention, joints=joints or "R" * n, gravity=gravity,
                      rotors=False, name=name)


def probe_arms():
    """Seeded arms checked against the Toolbox only (not timed)."""
    g = np.array([2.0, -3.0, -9.0])
    g = 9.81 * g / np.linalg.norm(g)
    return [
        random_chain(6, seed=11, convention="standard", joints="PRRRRR", gravity=g,
                     name="probe-std-P1"),
        random_chain(6, seed=12, convention="modified", joints="PRRRRR", gravity=g,
                     name="probe-mdh-P1"),
        random_chain(6, seed=13, convention="modified", joints="RRPRRR", gravity=g,
                     name="probe-mdh-R1"),
        random_chain(6, seed=14, convention="standard", joints="RRPRRP", gravity=g,
                     name="probe-std-R1"),
    ]
