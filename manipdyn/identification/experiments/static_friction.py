"""A synthetic truth with static friction: breakaway above Coulomb, Stribeck between, a band at rest.

Layer 5 (identification).

A real joint does not follow ``Fc sign(qd)`` through zero velocity.  Moving, its friction rises
from the Coulomb level ``Fc`` towards the static (breakaway) level ``Fs`` as it slows, the Stribeck
decay ``Fc + (Fs - Fc) exp(-(v / vs)^2)`` (:class:`manipdyn.model.friction.Friction`'s ``stribeck``
term, exponent 2).  At rest it holds whatever torque keeps it still, anywhere in the static band
``[-Fs, Fs]``; on a stopped arm that is, usually, the friction the last motion left: its sign, at a
level the controller settles to.

:func:`with_static_friction` gives an arm whose friction law is that, moving: its viscous and
Coulomb levels kept, ``Fs = ratio x Fc`` per joint, sharp sign (``smoothing = 0``, so the law is
the breakaway level ``Fs sign(v)`` as ``v -> 0``).  :func:`rest_torque` gives the torque at rest:
on each rest of each joint (a run of samples with ``|qd_j| <= rest_velocity``, by default exactly
0, as the rests of ``manipdyn excite --ptp`` and the ends of its Fourier ramps are), the joint
holds ``sign(last motion) x u x Fs_j``, with ``u`` drawn once per rest from U(0, 1)
(``numpy.random.default_rng((seed, 45))``, a stream apart from the noise's): within the band,
of the last motion's sign.  A rest at the start of the log, after no motion, holds ``(2 u - 1)
Fs_j``: anywhere in the band.  ``manipdyn synthesize --static-friction RATIO
[--stribeck-velocity V]`` logs such a truth.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError, PhysicalConsistencyWarning
from ...model.friction import Friction

__all__ = ["with_static_friction", "static_levels", "rest_torque", "DEFAULT_STRIBECK_VELOCITY", "MAX_RATIO"]

#: default Stribeck velocity ``vs``, rad/s (m/s): the decay from Fs to Fc is 98 % done at 2 vs
DEFAULT_STRIBECK_VELOCITY = 0.05
#: largest ``Fs / Fc``: real joints break away at 1 to 3 times their Coulomb level
MAX_RATIO = 100.0


def _law(arm) -> Friction | None:
    law = getattr(arm, "friction_model", None)
    if law is None and getattr(arm, "friction", None) is not None:
        fv, fc = np.asarray(arm.friction)
        law = Friction(viscous=fv, coulomb=fc, smoothing=0.0)
    return law


def with_static_friction(arm, ratio: float, stribeck_velocity: float = DEFAULT_STRIBECK_VELOCITY,
                         where: str = "static friction"):
    """``arm`` with the friction law of the module docstring: its viscous, Coulomb ``Fc`` (n,) and offset
    kept, a Stribeck term of level ``Fs - Fc = (ratio - 1) Fc`` and velocity ``stribeck_velocity`` added,
    the sharp sign.  ``ratio >= 1``; the arm's law must be joint-side with a symmetric Coulomb term
    above 0 on some joint (else a :class:`ModelError` naming ``where``).  A DH arm (:class:`Manipulator`)
    only; the links' own friction moves into the law."""
    from ...model.arm import Manipulator

    for name, v, low, high, form in (
            ("ratio", ratio, 1.0, MAX_RATIO, f"from 1 to {MAX_RATIO:g} (Fs / Fc)"),
            ("stribeck_velocity", stribeck_velocity, limits.MIN_SMOOTHING, 1e6,
             f"from {limits.MIN_SMOOTHING:g} to 1e6 (rad/s or m/s)")):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) or not low <= v <= high:
            raise ModelError(f"{where}: {name}: expected a number {form}, got {v!r}")
    if not isinstance(arm, Manipulator):
        raise ModelError(f"{where}: only for DH models (a bundled name or a .toml file), not {arm.name!r}")
    law = _law(arm)
    if law is None or law.side != "joint" or law.coulomb is None or not np.any(law.coulomb > 0) \
            or set(law.terms) - {"viscous", "coulomb", "offset", "stribeck"}:
        raise ModelError(f"{where}: the arm {arm.name!r} has no joint-side symmetric Coulomb friction to scale "
                         f"(its law: {law!r}); use a model with Coulomb friction, or perturb it (synthesize --perturb)")
    fc = np.asarray(law.coulomb, dtype=np.float64)
    new = Friction(viscous=law.viscous, coulomb=fc, offset=law.offset, smoothing=0.0,
                   stribeck_level=(float(ratio) - 1.0) * fc,
                   stribeck_velocity=np.full(arm.n, float(stribeck_velocity)))
    import dataclasses

    links = [dataclasses.replace(l, friction_viscous=0.0, friction_coulomb=0.0) for l in arm.links]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicalConsistencyWarning)
        return Manipulator(links, convention=arm.convention, gravity=arm.gravity, name=arm.name, source=arm.source,
                           sources=arm.sources, description=arm.description, transmission=arm.transmission,
                           friction=new)


def static_levels(arm) -> np.ndarray:
    """The breakaway level ``Fs`` (n,), N m (N), of the arm's joint-side friction law: its Coulomb level plus
    its Stribeck level (0 where the law has neither)."""
    law = _law(arm)
    if law is None:
        return np.zeros(arm.n)
    if law.side != "joint" or law.asymmetric:
        raise ModelError("static friction: only for a joint-side law with a symmetric Coulomb term, "
                         f"got {law!r}")
    fs = np.zeros(arm.n) if law.coulomb is None else np.array(law.coulomb, dtype=np.float64)
    return fs + (0.0 if law.stribeck_level is None else law.stribeck_level)


def rest_torque(qd, fs, seed: int = 0, rest_velocity: float = 0.0) -> np.ndarray:
    """The friction torque at rest (N, n), N m (N), 0 while moving (module docstring).

    ``qd`` (N, n) joint velocities, rad/s (m/s); ``fs`` (n,) the breakaway levels; a joint is at rest
    where ``|qd_j| <= rest_velocity``.  Seeded by ``seed``: the same velocities, the same torques."""
    qd = np.asarray(qd, dtype=np.float64)
    fs = np.broadcast_to(np.asarray(fs, dtype=np.float64), qd.shape[1:])
    N = len(qd)
    rest = np.abs(qd) <= rest_velocity
    k = np.arange(N)[:, None]
    first = rest & np.vstack([np.ones((1, qd.shape[1]), bool), ~rest[:-1]])          # a rest begins
    began = np.maximum.accumulate(np.where(first, k, -1), axis=0)                   # where this rest began
    moved = np.maximum.accumulate(np.where(~rest, k, -1), axis=0)                   # the last moving sample
    u = np.random.default_rng((int(seed), 45)).random(qd.shape)
    level = np.take_along_axis(u, np.maximum(began, 0), axis=0)                      # one draw per rest
    sign = np.sign(np.take_along_axis(qd, np.maximum(moved, 0), axis=0))
    held = np.where(moved >= 0, sign * level, 2.0 * level - 1.0) * fs
    return np.where(rest, held, 0.0)
