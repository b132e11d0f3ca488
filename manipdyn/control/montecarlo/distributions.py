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

__all__ = ["Distributions", "RunDraw", "draw", "run_rng", "DISTRIBUTIONS_HELP", "effect_on_arm",
           "RELATIVE_DEFAULTS", "ABSOLUTE_DEFAULTS", "Bounds"]

#: the sized figures' defaults (fractions of each joint's torque scale, :mod:`.sizing`)
RELATIVE_DEFAULTS = {"payload_rel": 0.2, "friction_viscous_rel": 0.1, "friction_coulomb_rel": 0.1,
                     "torque_noise_rel": 0.01}
#: (absolute figure, its sized counterpart)
_PAIRS = (("payload_mass", "payload_rel"), ("friction_viscous", "friction_viscous_rel"),
          ("friction_coulomb", "friction_coulomb_rel"), ("torque_noise", "torque_noise_rel"))


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
    payload_rel, friction_viscous_rel, friction_coulomb_rel, torque_noise_rel : float
        The same draws sized to the arm, per joint (:mod:`.sizing`): the payload mass bound is
        ``payload_rel`` times the mass whose torque, at a corner of the payload box, reaches
        one joint's torque scale ``tau_j`` (the largest ``|tau_j|`` of the nominal arm on the path)
        first; Coulomb ``friction_coulomb_rel * tau_j``; viscous ``friction_viscous_rel * tau_j
        / qd_j`` (``qd_j`` the path's top speed of joint j: the added viscous torque at that speed
        is at most that fraction of ``tau_j``); noise standard deviation ``torque_noise_rel *
        tau_j``.  Each adds to its absolute figure.

    Notes
    -----
    The defaults (issue 46) are sized: link factors ``1 +- 0.2``, a payload whose torque is at
    most 20 % of every joint's torque scale (:data:`RELATIVE_DEFAULTS`), friction up to 10 % of it,
    noise of 1 % of it, and no absolute figure.  Absolute figures (N m, kg: the same for every
    arm) made the bundled UR5's wrist, whose torque on the path is 2e-3 N m, err by a radian
    for every controller.  An absolute figure given (``Distributions(friction_coulomb=0.5)``,
    ``--friction-coulomb 0.5``), even 0, means what it says, and its ``*_rel`` counterpart then
    defaults to 0: :data:`ABSOLUTE_DEFAULTS` is the study of the defaults before issue 46,
    plant for plant.
    """

    payload_mass: float | None = None
    payload_com: tuple = (0.05, 0.05, 0.15)
    link_scale: float = 0.2
    friction_viscous: float | None = None
    friction_coulomb: float | None = None
    q0_offset: float = 0.01
    torque_noise: float | None = None
    payload_rel: float | None = None
    friction_viscous_rel: float | None = None
    friction_coulomb_rel: float | None = None
    torque_noise_rel: float | None = None

    def __post_init__(self):
        # an absolute figure given (even 0) means what it says, and its sized counterpart then
        # defaults to 0; neither given: the sized default (RELATIVE_DEFAULTS), the absolute 0
        for absolute, rel in _PAIRS:
            a, r = getattr(self, absolute), getattr(self, rel)
            if r is None:
                object.__setattr__(self, rel, 0.0 if a is not None else RELATIVE_DEFAULTS[rel])
            if a is None:
                object.__setattr__(self, absolute, 0.0)
        for name in ("payload_mass", "link_scale", "friction_viscous", "friction_coulomb",
                     "q0_offset", "torque_noise", *RELATIVE_DEFAULTS):
            object.__setattr__(self, name, nonnegative(getattr(self, name), name))
        # beyond these no plant is an arm any more, and its numbers overflow float64
        for name, limit in (("payload_mass", "MAX_MASS"), ("q0_offset", "MAX_ANGLE"),
                            ("friction_viscous", "MAX_MAGNITUDE"), ("friction_coulomb", "MAX_MAGNITUDE"),
                            ("torque_noise", "MAX_MAGNITUDE"), *((r, "MAX_MAGNITUDE") for r in RELATIVE_DEFAULTS)):
            limits.check_count(getattr(self, name), name, f"{name}", limit)
        if self.link_scale >= 1.0:
            raise ValueError(f"link_scale: must be < 1 (a factor 1 - link_scale must stay > 0), "
                             f"got {self.link_scale}")
        com = tuple(self.payload_com) if np.ndim(self.payload_com) == 1 else ()
        if len(com) != 3:
            raise ValueError(f"payload_com: expected 3 numbers (cx, cy, cz) in m, got {self.payload_com!r}")
        object.__setattr__(self, "payload_com",
                           tuple(nonnegative(c, f"payload_com[{i}]") for i, c in enumerate(com)))

    @property
    def sized(self) -> bool:
        """True when a draw depends on the arm (some ``*_rel`` figure is not 0): :meth:`bounds` needs
        the arm's :class:`~.sizing.Sizes`."""
        return any(getattr(self, r) for r in RELATIVE_DEFAULTS)

    @property
    def noisy(self) -> bool:
        """True when the applied torque carries noise (``torque_noise`` or ``torque_noise_rel``)."""
        return bool(self.torque_noise or self.torque_noise_rel)

    def bounds(self, sizes=None) -> "Bounds":
        """The absolute bounds of the draws on an arm of :class:`~.sizing.Sizes` ``sizes`` (needed
        when :attr:`sized`): absolute figure plus relative figure times the joint's scale."""
        if sizes is None:
            if self.sized:
                raise ValueError("distributions: the *_rel figures are fractions of the arm's joint torques: "
                                 "give the arm's sizes (manipdyn.control.montecarlo.sizing.arm_sizes)")
            return Bounds(self.payload_mass, np.float64(self.friction_viscous), np.float64(self.friction_coulomb),
                          np.float64(self.torque_noise))
        tau, speed = sizes.torque, sizes.speed
        return Bounds(self.payload_mass + self.payload_rel * sizes.payload_kg,
                      self.friction_viscous + self.friction_viscous_rel * tau / speed,
                      self.friction_coulomb + self.friction_coulomb_rel * tau,
                      self.torque_noise + self.torque_noise_rel * tau)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["payload_com"] = list(self.payload_com)
        return d


#: the defaults before issue 46, absolute (kg, N m: the same for every arm): the same plants,
#: bit for bit, as the studies of those versions (``--payload-mass 2 --friction-viscous 0.5
#: --friction-coulomb 0.5 --torque-noise 0.05`` on the command line)
ABSOLUTE_DEFAULTS = Distributions(payload_mass=2.0, friction_viscous=0.5, friction_coulomb=0.5, torque_noise=0.05)


@dataclass(frozen=True)
class Bounds:
    """The absolute bounds of a study's draws on one arm (:meth:`.Distributions.bounds`):
    ``payload_mass`` kg, and per joint (n,) or one number for every joint: ``viscous`` N m s/rad,
    ``coulomb`` N m, ``noise`` N m (standard deviation)."""

    payload_mass: float
    viscous: np.ndarray
    coulomb: np.ndarray
    noise: np.ndarray


#: the text of ``manipdyn montecarlo --help`` on the default distributions
DISTRIBUTIONS_HELP = """\
Default distributions (independent; every run draws its own plant from its seed,
and every controller meets the same plant in that run), sized to the arm: tau_j is
joint j's torque scale, the largest |tau_j| of the nominal arm on the path, and
qd_j the path's top speed of joint j:
  payload      a point mass uniform in [0, M] kg at a centre of mass uniform in
               [-0.05, 0.05] x [-0.05, 0.05] x [0, 0.15] m of the tool frame (DH
               frame n, or the tip link of a URDF arm), M the mass whose torque at a
               corner of that box is at most 0.2 tau_j on every joint (--payload-rel)
  links        each link's mass and inertia times 1 + U(-0.2, 0.2) (COM kept)
  friction     added per joint: viscous U(0, 0.1 tau_j / qd_j), Coulomb U(0, 0.1 tau_j)
               (--friction-viscous-rel, --friction-coulomb-rel)
  start        q(0) = q_d(0) + N(0, 0.01 rad) per joint (0.001 m prismatic), at rest
  torque noise applied torque = commanded + N(0, 0.01 tau_j) per joint and sample
               (--torque-noise-rel)
--payload-mass, --friction-viscous, --friction-coulomb and --torque-noise are
absolute (kg, N m s/rad, N m, N m: the same on every arm) and add to the sized
figure; giving one sets its sized counterpart's default to 0.  The defaults before
issue 46, absolute: --payload-mass 2 --friction-viscous 0.5 --friction-coulomb 0.5
--torque-noise 0.05 (on the bundled UR5 they hold the wrist a radian off).
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


def draw(dist: Distributions, seed: int, run: int, joint_types, samples: int, sizes=None) -> RunDraw:
    """Draw run ``run``'s variations; ``samples`` is the number of samples of the run (N+1);
    ``sizes`` the arm's :class:`~.sizing.Sizes` (needed when ``dist.sized``).  The same random
    numbers whatever the sizes: only the bounds they multiply change."""
    b = dist.bounds(sizes)
    rng = run_rng(seed, run)
    n = len(joint_types)
    prismatic = np.array([t == "prismatic" for t in joint_types])
    mass = b.payload_mass * rng.random()
    cx, cy, cz = dist.payload_com
    u = rng.uniform(-1.0, 1.0, 2)
    com = np.array([cx * u[0], cy * u[1], cz * rng.random()])
    scale = 1.0 + dist.link_scale * rng.uniform(-1.0, 1.0, n)
    bound = np.stack([np.broadcast_to(b.viscous, (n,)), np.broadcast_to(b.coulomb, (n,))])
    friction = bound * rng.random((2, n))           # elementwise: the products of a scalar bound, bit for bit
    q0 = dist.q0_offset * np.where(prismatic, 0.1, 1.0) * rng.standard_normal(n)
    noise = rng.standard_normal((int(samples), n)) * np.broadcast_to(b.noise, (n,))
    return RunDraw(int(run), float(mass), com, scale, friction, q0, noise)


def effect_on_arm(dist: Distributions, arm, bandwidth: float, sizes=None) -> dict:
    """What the added friction and the torque noise of ``dist`` do to ``arm`` under the demo gains.

    With ``Kp_j = wn^2 D_jj`` and ``Kd_j = 2 wn D_jj`` at mid-range
    (:func:`manipdyn.control.controllers.pd_gains`, ``wn = bandwidth``), the largest added
    Coulomb friction holds joint j ``Fc_j / Kp_j`` off (rad or m), one standard deviation of
    torque noise pushes it ``sigma_j / Kp_j``, and the largest added viscous friction is ``Fv_j /
    Kd_j`` times the controller's damping (``Fc_j``, ``sigma_j``, ``Fv_j`` the bounds of
    :meth:`Distributions.bounds` on ``sizes``, the arm's :class:`~.sizing.Sizes`, needed when
    ``dist.sized``).  Absolute figures (N m, the same for every arm) may dwarf the controllers on
    a light joint; sized ones stay in proportion.  Returns, for the joint where each is largest,
    ``{"coulomb_offset": (value, joint), "noise_offset": ..., "viscous_ratio": ...}`` (joints
    1-based), and ``"text"``: one line for the report (empty when the three are zero).
    """
    from ..controllers import pd_gains

    b = dist.bounds(sizes)
    kp, kd = pd_gains(arm, bandwidth)
    kp, kd = np.maximum(kp, 1e-300), np.maximum(kd, 1e-300)
    out = {}
    bounds = {"coulomb_offset": np.broadcast_to(b.coulomb, (arm.n,)), "noise_offset": np.broadcast_to(b.noise, (arm.n,)),
              "viscous_ratio": np.broadcast_to(b.viscous, (arm.n,))}
    for key, gain in (("coulomb_offset", kp), ("noise_offset", kp), ("viscous_ratio", kd)):
        x = bounds[key] / gain
        j = int(np.argmax(x))
        out[key] = (float(x[j]), j + 1)
    c, nz, v = out["coulomb_offset"], out["noise_offset"], out["viscous_ratio"]
    fc, sg, fv = (float(bounds[k][j - 1]) for k, (_, j) in zip(("coulomb_offset", "noise_offset", "viscous_ratio"),
                                                                (c, nz, v)))

    def unit(j):                                  # joint j (1-based): rad, or m for a prismatic joint
        return "m" if arm.joint_types[j - 1] == "prismatic" else "rad"

    absolute = not (dist.friction_coulomb_rel or dist.torque_noise_rel or dist.friction_viscous_rel)
    parts = []
    if np.any(bounds["coulomb_offset"]):
        parts.append(f"added Coulomb friction up to {fc:.3g} N m holds joint {c[1]} up to "
                     f"{c[0]:.3g} {unit(c[1])} off")
    if np.any(bounds["noise_offset"]):
        parts.append(f"torque noise of {sg:.3g} N m pushes joint {nz[1]} {nz[0]:.3g} {unit(nz[1])} "
                     "per standard deviation")
    if np.any(bounds["viscous_ratio"]):
        parts.append(f"added viscous friction up to {fv:.3g} N m s/rad is {v[0]:.3g} times joint "
                     f"{v[1]}'s damping 2 wn D_jj")
    how = ("absolute, not scaled to it" if absolute else "sized to its joints' torques" if not (
        dist.friction_coulomb or dist.torque_noise or dist.friction_viscous) else "partly absolute")
    out["text"] = "" if not parts else (
        f"what these draws do to {arm.name or 'the arm'} ({how}) at the demo gains "
        f"Kp = wn^2 D_jj of {kp.min():.3g} to {kp.max():.3g} N m/rad: {', '.join(parts)}"
        + ("; scale --friction-coulomb, --friction-viscous and --torque-noise to the arm where these are large, "
           "or leave them out for draws sized to the arm" if how != "sized to its joints' torques" else ""))
    return out
