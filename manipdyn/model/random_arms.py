"""Seeded random arms that real rigid bodies could be: for property tests and benchmarks.

Layer 1 (model) (a tool for users' own property tests, and for manipdyn's
tests and benchmarks, which share it).

* :func:`random_rotation`, :func:`random_physical_inertia`: a rigid body that
  exists (principal moments positive and obeying the triangle inequalities,
  CONVENTIONS.md "Physical consistency"), in randomly rotated axes.
* :func:`random_arm`: a seeded random DH arm, standard or modified, mixed
  revolute/prismatic, with physical inertias and optional rotors.
* :func:`random_state`: joint positions/velocities/accelerations for an arm.

Everything takes a ``numpy.random.Generator`` or a seed, so a failing example
is reproduced by its seed alone.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from .arm import Manipulator
from .._support.errors import PhysicalConsistencyWarning
from .links import DHLink

__all__ = ["random_rotation", "random_principal_moments", "random_physical_inertia", "random_dh_link",
           "random_arm", "random_state", "as_generator", "LENGTH", "COM", "MASS", "MOMENT"]

# Ranges of the random arms.  They are chosen to look like real arms (links up
# to half a metre, a few kilograms) so that every quantity is O(1) to O(100)
# in SI units; the tolerances of the tests are stated relative to these scales.
LENGTH = 0.5       # |a|, |d| <= LENGTH  [m]
COM = 0.3          # |com_x|, |com_y|, |com_z| <= COM  [m]
MASS = (0.2, 5.0)  # [kg]
MOMENT = (1e-3, 0.2)  # range of the two free principal moments  [kg m^2]


def as_generator(rng_or_seed) -> np.random.Generator:
    """A numpy Generator from a Generator (returned as is) or a seed."""
    if isinstance(rng_or_seed, np.random.Generator):
        return rng_or_seed
    return np.random.default_rng(rng_or_seed)


def random_rotation(rng) -> np.ndarray:
    """A rotation matrix (3, 3), det +1, uniform on SO(3) (QR of a Gaussian)."""
    rng = as_generator(rng)
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
    rng = as_generator(rng)
    p1, p2 = rng.uniform(lo, hi, size=2)
    low, high = abs(p1 - p2), p1 + p2
    p3 = rng.uniform(low + margin * (high - low), high - margin * (high - low))
    return rng.permutation(np.array([p1, p2, p3]))


def random_physical_inertia(rng) -> np.ndarray:
    """A physical inertia tensor about the COM (3, 3, tensor sign): ``R diag(p) R^T``."""
    rng = as_generator(rng)
    R = random_rotation(rng)
    I = R @ np.diag(random_principal_moments(rng)) @ R.T
    return 0.5 * (I + I.T)


def random_dh_link(rng, joint: str, rotor: bool = False, name: str = "") -> DHLink:
    """One random DH link with a physical body (and, if asked, a rotor)."""
    rng = as_generator(rng)
    kw = {}
    if rotor:
        kw = dict(motor_inertia=float(rng.uniform(1e-5, 1e-3)),
                  gear_ratio=float(rng.choice([-1.0, 1.0]) * rng.uniform(1.0, 100.0)))
    return DHLink(
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
               gravity=None, joints: str | None = None, name: str | None = None) -> Manipulator:
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
    joints : str, optional
        The joint types as letters (``"RRPRRR"``); overrides ``n`` and
        ``prismatic_fraction``.
    name : str, optional
        Default ``random<n><s|m>``.
    """
    rng = as_generator(seed)
    if joints is not None:
        if not joints or set(joints) - {"R", "P"}:
            raise ValueError(f"joints: expected letters R and P, e.g. 'RRPRRR', got {joints!r}")
        n = len(joints)
    if n is None:
        n = int(rng.integers(1, 9))
    if convention is None:
        convention = str(rng.choice(["standard", "modified"]))
    if rotors is None:
        rotors = bool(rng.random() < 0.5)
    if gravity is None:
        g = rng.standard_normal(3)
        gravity = 9.81 * g / np.linalg.norm(g)
    if joints is None:
        kinds = ["prismatic" if rng.random() < prismatic_fraction else "revolute" for _ in range(n)]
    else:
        kinds = ["prismatic" if j == "P" else "revolute" for j in joints]
    links = [random_dh_link(rng, kind, rotor=rotors, name=f"L{i + 1}") for i, kind in enumerate(kinds)]
    with warnings.catch_warnings():
        # a random arm is physical by construction: any consistency warning is a bug
        warnings.simplefilter("error", PhysicalConsistencyWarning)
        return Manipulator(links, convention=convention, gravity=gravity,
                              name=name or f"random{n}{convention[0]}", strict=True)


def random_state(rng, arm, size: int | None = None, speed: float = 2.0):
    """``(q, qd, qdd)``, each (n,) or (size, n), for ``arm``.

    Revolute q in [-pi, pi] rad, prismatic q in [-2 LENGTH, 2 LENGTH] m, qd and
    qdd in [-speed, speed] (rad/s or m/s, and per second squared).
    """
    rng = as_generator(rng)
    n = arm.n
    shape = (n,) if size is None else (size, n)
    span = np.array([math.pi if t == "revolute" else 2 * LENGTH for t in arm.joint_types])
    q = rng.uniform(-1.0, 1.0, shape) * span
    qd = rng.uniform(-speed, speed, shape)
    qdd = rng.uniform(-speed, speed, shape)
    return q, qd, qdd
