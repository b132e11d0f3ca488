"""Reusable arm builders for the tests and the benchmark.

* :func:`random_rotation`, :func:`random_physical_inertia`: a rigid body that
  exists (principal moments positive and obeying the triangle inequalities,
  CONVENTIONS.md "Physical consistency"), in randomly rotated axes.
* :func:`random_arm`: a seeded random DH arm, standard or modified, mixed
  revolute/prismatic, with physical inertias and optional rotors.
* :func:`random_state`: joint positions/velocities/accelerations for an arm.
* :func:`puma560`: Corke's standard-DH Puma 560 (the classic data set, with its
  massless link 1 carrying Iyy = 0.35 kg m^2).

Everything takes a ``numpy.random.Generator`` or a seed, so a failing example
is reproduced by its seed alone.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

import manipdyn as md

# Ranges of the random arms.  They are chosen to look like real arms (links up
# to half a metre, a few kilograms) so that every quantity is O(1) to O(100)
# in SI units; the tolerances of the tests are stated relative to these scales.
LENGTH = 0.5       # |a|, |d| <= LENGTH  [m]
COM = 0.3          # |com_x|, |com_y|, |com_z| <= COM  [m]
MASS = (0.2, 5.0)  # [kg]
MOMENT = (1e-3, 0.2)  # range of the two free principal moments  [kg m^2]


def _rng(rng_or_seed) -> np.random.Generator:
    if isinstance(rng_or_seed, np.random.Generator):
        return rng_or_seed
    return np.random.default_rng(rng_or_seed)


def random_rotation(rng) -> np.ndarray:
    """A rotation matrix (3, 3), det +1, uniform on SO(3) (QR of a Gaussian)."""
    rng = _rng(rng)
    Q, R = np.linalg.qr(rng.standard_normal((3, 3)))
    Q = Q * np.sign(np.diag(R))  # make the factorisation unique -> Haar measure
    if np.linalg.det(Q) < 0:
        Q[:, 0] = -Q[:, 0]
    return Q


def random_principal_moments(rng, lo=MOMENT[0], hi=MOMENT[1], margin=0.05) -> np.ndarray:
    """Three principal moments (kg m^2) that a solid body can have.

    ``p1, p2`` are drawn in ``[lo, hi]``; ``p3`` strictly inside
    ``(|p1 - p2|, p1 + p2)`` (``margin`` of that interval kept free at each
    end), so every triangle inequality ``pi + pj > pk`` holds with room to
    spare and the body has volume (J positive definite).
    """
    rng = _rng(rng)
    p1, p2 = rng.uniform(lo, hi, size=2)
    low, high = abs(p1 - p2), p1 + p2
    p3 = rng.uniform(low + margin * (high - low), high - margin * (high - low))
    return rng.permutation(np.array([p1, p2, p3]))


def random_physical_inertia(rng) -> np.ndarray:
    """A physical inertia tensor about the COM (3, 3, tensor sign): ``R diag(p) R^T``."""
    rng = _rng(rng)
    R = random_rotation(rng)
    I = R @ np.diag(random_principal_moments(rng)) @ R.T
    return 0.5 * (I + I.T)


def random_dh_link(rng, joint: str, rotor: bool = False, name: str = "") -> md.DHLink:
    """One random DH link with a physical body (and, if asked, a rotor)."""
    rng = _rng(rng)
    kw = {}
    if rotor:
        kw = dict(motor_inertia=float(rng.uniform(1e-5, 1e-3)),
                  gear_ratio=float(rng.choice([-1.0, 1.0]) * rng.uniform(1.0, 100.0)))
    return md.DHLink(
        joint=joint,
        a=float(rng.uniform(-LENGTH, LENGTH)),
        alpha=float(rng.uniform(-math.pi, math.pi)),
        d=float(rng.uniform(-LENGTH, LENGTH)),
        theta=float(rng.uniform(-math.pi, math.pi)),
        mass=float(rng.uniform(*MASS)),
        com=rng.uniform(-COM, COM, size=3),
        inertia=random_physical_inertia(rng),
        name=name,
        **kw,
    )


def random_arm(seed, n: int | None = None, convention: str | None = None,
               prismatic_fraction: float = 0.3, rotors: bool | None = None,
               gravity=None) -> md.Manipulator:
    """A seeded random DH arm with physical inertias.

    Parameters
    ----------
    seed : int or numpy Generator
    n : 1..8 joints (random if None)
    convention : "standard" | "modified" (random if None)
    prismatic_fraction : probability that a joint is prismatic
    rotors : add motor inertia and gear ratio to every joint (random if None)
    gravity : (3,) base-frame gravity; default a random direction of norm 9.81,
        so that no base axis is privileged
    """
    rng = _rng(seed)
    if n is None:
        n = int(rng.integers(1, 9))
    if convention is None:
        convention = str(rng.choice(["standard", "modified"]))
    if rotors is None:
        rotors = bool(rng.random() < 0.5)
    if gravity is None:
        g = rng.standard_normal(3)
        gravity = 9.81 * g / np.linalg.norm(g)
    links = [
        random_dh_link(rng, "prismatic" if rng.random() < prismatic_fraction else "revolute",
                       rotor=rotors, name=f"L{i + 1}")
        for i in range(n)
    ]
    with warnings.catch_warnings():
        # a random arm is physical by construction: any consistency warning is a bug
        warnings.simplefilter("error", md.PhysicalConsistencyWarning)
        return md.Manipulator(links, convention=convention, gravity=gravity,
                              name=f"random{n}{convention[0]}", strict=True)


def random_state(rng, arm, size: int | None = None, speed: float = 2.0):
    """``(q, qd, qdd)``, each (n,) or (size, n), for ``arm``.

    Revolute q in [-pi, pi] rad, prismatic q in [-2 LENGTH, 2 LENGTH] m, qd and
    qdd in [-speed, speed] (rad/s or m/s, and per second squared).
    """
    rng = _rng(rng)
    n = arm.n
    shape = (n,) if size is None else (size, n)
    span = np.array([math.pi if t == "revolute" else 2 * LENGTH for t in arm.joint_types])
    q = rng.uniform(-1.0, 1.0, shape) * span
    qd = rng.uniform(-speed, speed, shape)
    qdd = rng.uniform(-speed, speed, shape)
    return q, qd, qdd


# ---------------------------------------------------------------------------
# Puma 560 (Corke's Robotics Toolbox, standard DH, "mdl_puma560")
# ---------------------------------------------------------------------------
PUMA560 = dict(
    a=[0.0, 0.4318, 0.0203, 0.0, 0.0, 0.0],
    d=[0.0, 0.0, 0.15005, 0.4318, 0.0, 0.0],
    alpha=[math.pi / 2, 0.0, -math.pi / 2, math.pi / 2, -math.pi / 2, 0.0],
    m=[0.0, 17.4, 4.8, 0.82, 0.34, 0.09],
    r=[[0, 0, 0], [-0.3638, 0.006, 0.2275], [-0.0203, -0.0141, 0.070],
       [0, 0.019, 0], [0, 0, 0], [0, 0, 0.032]],
    I=[[0, 0.35, 0], [0.13, 0.524, 0.539], [0.066, 0.086, 0.0125],
       [1.8e-3, 1.3e-3, 1.8e-3], [0.3e-3, 0.4e-3, 0.3e-3], [0.15e-3, 0.15e-3, 0.04e-3]],
)


def puma560_links(link1_inertia=None) -> list[md.DHLink]:
    """The six DH links of Corke's Puma 560 (no rotors, no friction).

    ``link1_inertia`` replaces link 1's diagonal inertia (the published data
    puts Iyy = 0.35 kg m^2 on a massless link).
    """
    p = PUMA560
    I = [list(v) for v in p["I"]]
    if link1_inertia is not None:
        I[0] = list(link1_inertia)
    return [
        md.DHLink("revolute", a=p["a"][i], alpha=p["alpha"][i], d=p["d"][i],
                  mass=p["m"][i], com=p["r"][i], inertia=I[i], name=f"link{i + 1}")
        for i in range(6)
    ]


def puma560(link1_inertia=None, **kw) -> md.Manipulator:
    """Corke's Puma 560, standard DH.

    Warns (PhysicalConsistencyWarning) about link 1 (massless, Iyy = 0.35) and
    link 3 (Ixx + Izz = 0.0785 < Iyy = 0.086): the published data are not
    those of real rigid bodies.

    Call under ``pytest.warns`` or ``warnings.catch_warnings`` if the warning matters.
    """
    return md.Manipulator(puma560_links(link1_inertia), convention="standard",
                          name="puma560", **kw)
