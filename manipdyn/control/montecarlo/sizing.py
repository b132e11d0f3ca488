"""The arm's own scales, to which a study's default draws are sized.

Layer 6 (control: montecarlo).

Absolute draws (N m, kg) mean different things on different arms: 0.5 N m of added
Coulomb friction is 2 % of a Puma's shoulder torque and 250 times what the bundled
UR5's last joint needs on the demo path (2e-3 N m: its link's inertia about the axis is
1.3e-4 kg m^2), so with them every controller erred by a radian on the UR5 (issue 46).
The defaults of :class:`.Distributions` are therefore fractions of each joint's scale:

* ``torque`` (n,): ``tau_j``, the largest ``|tau_j|`` of the nominal arm's inverse dynamics
  over the reference samples of the path (N m or N);
* ``speed`` (n,): ``qd_j``, the path's largest ``|qd_j|`` (rad/s or m/s);
* ``payload_kg``: the largest payload mass (kg) whose torque, at any corner of the payload's
  box, stays within ``tau_j`` on every joint along the path (the inverse dynamics with a
  1 kg point mass there, minus the nominal's): the joint it saturates first is ``payload_joint``.

All are computed from the nominal arm and the path, never from a plant: the same numbers in
every process.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

__all__ = ["Sizes", "arm_sizes", "sized_source"]

#: the smallest scale a joint is given (a joint the path does not load still gets a finite bound)
TINY = 1e-12


@dataclass(frozen=True)
class Sizes:
    """An arm's scales on a path (module docstring): ``torque`` (n,) N m (N), ``speed`` (n,)
    rad/s (m/s), ``payload_kg`` kg, ``payload_joint`` the joint (1-based) that bounds it."""

    torque: np.ndarray
    speed: np.ndarray
    payload_kg: float
    payload_joint: int

    def to_dict(self) -> dict:
        return {"torque": self.torque.tolist(), "speed": self.speed.tolist(), "payload_kg": self.payload_kg,
                "payload_joint": self.payload_joint}


def arm_sizes(arm, q, qd, qdd, payload_com) -> Sizes:
    """:class:`Sizes` of ``arm`` on the path samples ``q, qd, qdd`` (N, n), for a payload box
    ``payload_com = (cx, cy, cz)`` m of the tool frame (:class:`.Distributions`)."""
    from .distributions import RunDraw
    from .plant import make_plant

    q, qd, qdd = (np.atleast_2d(np.asarray(a, dtype=np.float64)) for a in (q, qd, qdd))
    n = arm.n
    tau = arm.inverse_dynamics(q, qd, qdd)
    torque = np.maximum(np.max(np.abs(tau), axis=0), TINY)
    speed = np.maximum(np.max(np.abs(qd), axis=0), TINY)
    cx, cy, cz = payload_com
    def payload(mass, com):
        d = RunDraw(-1, mass, np.asarray(com, dtype=np.float64), np.ones(n), np.zeros((2, n)), np.zeros(n),
                    np.zeros((1, n)))
        return make_plant(arm, d).pinocchio.inverse_dynamics(q, qd, qdd)

    base = payload(0.0, (0.0, 0.0, 0.0))
    per_kg = np.zeros(n)
    for sx, sy, z in itertools.product((-1.0, 1.0), (-1.0, 1.0), (0.0, 1.0)):
        extra = payload(1.0, (sx * cx, sy * cy, z * cz)) - base
        per_kg = np.maximum(per_kg, np.max(np.abs(extra), axis=0))
    kg = np.where(per_kg > 0, torque / np.maximum(per_kg, TINY), np.inf)
    j = int(np.argmin(kg))
    return Sizes(torque, speed, float(kg[j]) if np.isfinite(kg[j]) else 0.0, j + 1)


def sized_source(study) -> str:
    """The header line of a study whose draws are sized to the arm (:mod:`.sizing`)."""
    d, z, b = study.distributions, study.sizes(), study.bounds()

    def part(rel, absolute, what, unit):
        if not (rel or absolute):
            return None
        sized = f"{rel:g} tau_j{what}" if rel else ""
        return " + ".join(x for x in (sized, f"{absolute:g} {unit}" if absolute else "") if x)

    pay = (f"payload <= {b.payload_mass:.3g} kg" + (f" (its torque <= {d.payload_rel:g} tau_j: joint {z.payload_joint} "
                                                    "bounds it)" if d.payload_rel else "")
           if b.payload_mass else "no payload")
    fr = [f"{name} <= {p}" for name, p in (("viscous", part(d.friction_viscous_rel, d.friction_viscous, " / qd_j",
                                                            "N m s/rad")),
                                          ("Coulomb", part(d.friction_coulomb_rel, d.friction_coulomb, "", "N m"))) if p]
    noise = part(d.torque_noise_rel, d.torque_noise, "", "N m")
    varied = [f"links x 1 +- {d.link_scale:g}" if d.link_scale else "links as the model", pay,
              ("added friction: " + ", ".join(fr)) if fr else "no added friction",
              f"torque noise sd {noise}" if noise else "no torque noise"]
    torque = ", ".join(f"{x:.3g}" for x in z.torque)
    return (f"plants: distributions sized to the arm ({', '.join(varied)}; tau_j, joint j's largest torque on the "
            f"path: {torque} N m)")
