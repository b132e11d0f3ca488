"""What varies from run to run of a study, and how it is drawn.

Layer 6 (control: montecarlo).

Every run of a study simulates one *plant*: the nominal arm as the
controllers know it, changed in ways nobody told them about.  The changes are
drawn from the distributions of :class:`Distributions`, with a generator
seeded by ``(study seed, run index)`` only::

    rng = numpy.random.default_rng(numpy.random.SeedSequence(seed, spawn_key=(run,)))

so a run's plant does not depend on how many runs there are, on the order in
which they execute, or on the machine that draws it.  Every controller of the
study meets the same plant in a given run (paired comparisons).

Draw order (fixed; changing it changes every study's plants): payload mass,
payload centre of mass (x, y, z), the link scale factors (n), the viscous
then the Coulomb friction coefficients (n each), the initial position offset
(n), then the torque noise (one row of n per sample of the run).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..._support import limits
from ..._support.limits import nonnegative

__all__ = ["Distributions", "RunDraw", "draw", "run_rng", "DISTRIBUTIONS_HELP", "effect_on_arm"]


@dataclass(frozen=True)
class Distributions:
    """The documented distributions of a study's plant variations (all independent).

    Attributes
    ----------
    payload_mass : float
        kg; the payload mass is uniform in ``[0, payload_mass]``.
    payload_com : (3,) tuple of float
        m; the payload's centre of mass is uniform in the box
        ``[-cx, cx] x [-cy, cy] x [0, cz]`` of the *tool frame* (DH frame n for a
        DH arm, the tip link's frame for a URDF arm).  The payload is a point mass.
    link_scale : float
        Each link's mass and inertia (its whole pseudo-inertia: the centre of
        mass stays) is multiplied by ``1 + u``, ``u`` uniform in
        ``[-link_scale, link_scale]``, independently per link (0.2: off by up to 20 %).
        Rotor inertias (armature) are not scaled.
    friction_viscous, friction_coulomb : float
        Added to the arm's own friction, per joint, uniform in ``[0, value]``:
        N m s/rad (N s/m) and N m (N).
    q0_offset : float
        rad (m for prismatic joints, divided by 10); the run starts at
        ``q_d(0) + offset``, offset normal with this standard deviation per
        joint, at rest.
    torque_noise : float
        N m (N); the torque the joints apply is the commanded torque plus
        white Gaussian noise of this standard deviation, drawn per joint and
        per sample and held over the step (what a torque loop closed on a noisy
        torque sensor delivers).
    """

    payload_mass: float = 2.0
    payload_com: tuple = (0.05, 0.05, 0.15)
    link_scale: float = 0.2
    friction_viscous: float = 0.5
    friction_coulomb: float = 0.5
    q0_offset: float = 0.01
    torque_noise: float = 0.05

    def __post_init__(self):
        for name in ("payload_mass", "link_scale", "friction_viscous", "friction_coulomb",
                     "q0_offset", "torque_noise"):
            object.__setattr__(self, name, nonnegative(getattr(self, name), name))
        # beyond these no plant is an arm any more, and its numbers overflow float64
        for name, limit in (("payload_mass", "MAX_MASS"), ("q0_offset", "MAX_ANGLE"),
                            ("friction_viscous", "MAX_MAGNITUDE"), ("friction_coulomb", "MAX_MAGNITUDE"),
                            ("torque_noise", "MAX_MAGNITUDE")):
            limits.check_count(getattr(self, name), name, f"{name}", limit)
        if self.link_scale >= 1.0:
            raise ValueError(f"link_scale: must be < 1 (a factor 1 - link_scale must stay > 0), "
                             f"got {self.link_scale}")
        com = tuple(self.payload_com) if np.ndim(self.payload_com) == 1 else ()
        if len(com) != 3:
            raise ValueError(f"payload_com: expected 3 numbers (cx, cy, cz) in m, got {self.payload_com!r}")
        object.__setattr__(self, "payload_com",
                           tuple(nonnegative(c, f"payload_com[{i}]") for i, c in enumerate(com)))

    def to_dict(self) -> dict:
        d = asdict(self)
        d["payload_com"] = list(self.payload_com)
        return d


#: the text of ``manipdyn montecarlo --help`` on the default distributions
DISTRIBUTIONS_HELP = """\
Default distributions (independent; every run draws its own plant from its seed,
and every controller meets the same plant in that run):
  payload      mass uniform in [0, 2] kg, a point mass at a centre of mass uniform
               in [-0.05, 0.05] x [-0.05, 0.05] x [0, 0.15] m of the tool frame
               (DH frame n, or the tip link of a URDF arm)
  links        each link's mass and inertia times 1 + U(-0.2, 0.2) (COM kept)
  friction     added per joint: viscous U(0, 0.5) N m s/rad, Coulomb U(0, 0.5) N m
  start        q(0) = q_d(0) + N(0, 0.01 rad) per joint (0.001 m prismatic), at rest
  torque noise applied torque = commanded + N(0, 0.05 N m) per joint and sample
The controllers know none of this: they are built on the nominal arm."""


@dataclass(frozen=True)
class RunDraw:
    """The variations of one run (see :class:`Distributions` for their meaning).

    ``scale`` (n,), ``friction`` (2, n) (viscous, Coulomb), ``q0_offset`` (n,)
    and ``torque_noise`` (N+1, n) are arrays; ``payload_com`` is (3,) in m.
    """

    run: int
    payload_mass: float
    payload_com: np.ndarray
    scale: np.ndarray
    friction: np.ndarray
    q0_offset: np.ndarray
    torque_noise: np.ndarray


def run_rng(seed: int, run: int) -> np.random.Generator:
    """The generator of run ``run`` of the study seeded ``seed``."""
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(int(run),)))


def draw(dist: Distributions, seed: int, run: int, joint_types, samples: int) -> RunDraw:
    """Draw run ``run``'s variations; ``samples`` is the number of samples of the run (N+1)."""
    rng = run_rng(seed, run)
    n = len(joint_types)
    prismatic = np.array([t == "prismatic" for t in joint_types])
    mass = dist.payload_mass * rng.random()
    cx, cy, cz = dist.payload_com
    u = rng.uniform(-1.0, 1.0, 2)
    com = np.array([cx * u[0], cy * u[1], cz * rng.random()])
    scale = 1.0 + dist.link_scale * rng.uniform(-1.0, 1.0, n)
    friction = np.array([dist.friction_viscous, dist.friction_coulomb])[:, None] * rng.random((2, n))
    q0 = dist.q0_offset * np.where(prismatic, 0.1, 1.0) * rng.standard_normal(n)
    noise = dist.torque_noise * rng.standard_normal((int(samples), n))
    return RunDraw(int(run), float(mass), com, scale, friction, q0, noise)


def effect_on_arm(dist: Distributions, arm, bandwidth: float) -> dict:
    """What the added friction and the torque noise of ``dist`` do to ``arm`` under the demo gains.

    The distributions are absolute (N m), the same for every arm, so on a light joint they
    may dwarf the controllers: with ``Kp_j = wn^2 D_jj`` and ``Kd_j = 2 wn D_jj`` at mid-range
    (:func:`manipdyn.control.controllers.pd_gains`, ``wn = bandwidth``), the largest added
    Coulomb friction holds joint j ``Fc / Kp_j`` off (rad or m), one standard deviation of
    torque noise pushes it ``sigma / Kp_j``, and the largest added viscous friction is ``Fv /
    Kd_j`` times the controller's damping.  Returns, for the joint where each is largest,
    ``{"coulomb_offset": (value, joint), "noise_offset": ..., "viscous_ratio": ...}`` (joints
    1-based), and ``"text"``: one line for the report (empty when the three are zero).
    """
    from ..controllers import pd_gains

    kp, kd = pd_gains(arm, bandwidth)
    kp, kd = np.maximum(kp, 1e-300), np.maximum(kd, 1e-300)
    out = {}
    for key, value, gain in (("coulomb_offset", dist.friction_coulomb, kp), ("noise_offset", dist.torque_noise, kp),
                             ("viscous_ratio", dist.friction_viscous, kd)):
        x = value / gain
        j = int(np.argmax(x))
        out[key] = (float(x[j]), j + 1)
    big = dist.friction_coulomb or dist.torque_noise or dist.friction_viscous
    c, nz, v = out["coulomb_offset"], out["noise_offset"], out["viscous_ratio"]

    def unit(j):                                  # joint j (1-based): rad, or m for a prismatic joint
        return "m" if arm.joint_types[j - 1] == "prismatic" else "rad"

    parts = []
    if dist.friction_coulomb:
        parts.append(f"added Coulomb friction up to {dist.friction_coulomb:g} N m holds joint {c[1]} up to "
                     f"{c[0]:.3g} {unit(c[1])} off")
    if dist.torque_noise:
        parts.append(f"torque noise of {dist.torque_noise:g} N m pushes joint {nz[1]} {nz[0]:.3g} {unit(nz[1])} "
                     "per standard deviation")
    if dist.friction_viscous:
        parts.append(f"added viscous friction up to {dist.friction_viscous:g} N m s/rad is {v[0]:.3g} times joint "
                     f"{v[1]}'s damping 2 wn D_jj")
    out["text"] = "" if not big else (
        f"what these draws do to {arm.name or 'the arm'} (absolute, not scaled to it) at the demo gains "
        f"Kp = wn^2 D_jj of {kp.min():.3g} to {kp.max():.3g} N m/rad: {', '.join(parts)}; scale "
        "--friction-coulomb, --friction-viscous and --torque-noise to the arm where these are large")
    return out
