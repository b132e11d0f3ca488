"""Variants of an arm to use as the plant of a simulation: a payload, mis-estimated masses.

Layer 1 (model): an arm changed into another arm.  Used as simulation plants (control,
Monte-Carlo) and by payload identification.

Both return a new :class:`manipdyn.Manipulator` (the original is immutable and
unchanged), built by combining pseudo-inertias (eq. 2.20: the pseudo-inertias
of bodies described in one frame add) and ``dataclasses.replace`` on the DH
links.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from .._support.errors import ModelError, PhysicalConsistencyWarning
from .._support.limits import nonnegative
from .arm import Manipulator
from .inertia import LinkInertia

__all__ = ["with_payload", "with_scaled_inertia"]


def _rebuild(arm: Manipulator, links, name: str) -> Manipulator:
    # The unchanged links were checked (and warned about) when ``arm`` was built;
    # the changes below keep J positive semidefinite, so nothing new to report.
    # The drive and the poses go along: a friction law given apart from the links (the bundled
    # panda's sigmoid, an identified [friction]) and a coupled transmission are the plant's too.
    law = None if any(l.friction_viscous or l.friction_coulomb for l in links) else arm.friction_model
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicalConsistencyWarning)
        return Manipulator(links, convention=arm.convention, gravity=arm.gravity, name=name,
                           strict=arm.strict, source=arm.source, sources=arm.sources,
                           transmission=arm.transmission, friction=law, poses=dict(arm.poses))


def _dh_arm(arm, fn: str) -> Manipulator:
    if not isinstance(arm, Manipulator):
        raise ModelError(f"{fn}: needs a DH arm (manipdyn.Manipulator), got {type(arm).__name__}")
    return arm


def with_payload(arm, mass: float, com=(0.0, 0.0, 0.0), inertia=None, name=None) -> Manipulator:
    """The arm carrying a payload rigidly attached to its last link.

    Parameters
    ----------
    arm : manipdyn.Manipulator
    mass : float
        Payload mass, kg (>= 0).
    com : (3,)
        Payload centre of mass in the last link's DH frame n, m.
    inertia : (3, 3) or (3,), optional
        Payload inertia tensor about its own centre of mass (tensor sign,
        frame-n axes), kg m^2; default 0 (a point mass).
    name : str, optional
        Default ``"<arm>+<mass>kg"``.

    The last link's pseudo-inertia becomes ``J_n + J_payload`` (both in frame
    n), converted back by :meth:`LinkInertia.from_pseudo_inertia`.
    """
    arm = _dh_arm(arm, "with_payload")
    mass = nonnegative(mass, "with_payload: mass", "kg")
    payload = LinkInertia(mass, com, np.zeros((3, 3)) if inertia is None else inertia, name="payload")
    payload.check_physical(strict=True, where="with_payload: payload")
    last = arm.links[-1]
    body = LinkInertia.from_pseudo_inertia(last.body.J + payload.J, name=last.name or "last link")
    links = arm.links[:-1] + (dataclasses.replace(last, mass=body.mass, com=body.com, inertia=body.inertia),)
    return _rebuild(arm, links, name if name is not None else f"{arm.name or 'arm'}+{mass:g}kg")


def with_scaled_inertia(arm, factor, name=None) -> Manipulator:
    """The arm with each link's mass and inertia multiplied by ``factor``.

    ``factor``: a scalar or one value per link (>= 0).  Centres of mass stay
    where they are (the pseudo-inertia scales as a whole, so a physical link
    stays physical).  Models a mis-estimated arm: e.g. a controller built on
    ``with_scaled_inertia(arm, 0.8)`` underestimates every mass by 20 %.
    """
    arm = _dh_arm(arm, "with_scaled_inertia")
    f = np.array(factor, dtype=np.float64)
    if f.ndim == 0:
        f = np.full(arm.n, float(f))
    if f.shape != (arm.n,) or not np.all(np.isfinite(f)) or np.any(f < 0):
        raise ModelError(f"with_scaled_inertia: factor must be >= 0, a scalar or {arm.n} values, "
                         f"got {np.asarray(factor).tolist()!r}")
    links = tuple(dataclasses.replace(l, mass=l.mass * fi, inertia=l.inertia * fi)
                  for l, fi in zip(arm.links, f))
    default = f"{arm.name or 'arm'}x{f[0]:g}" if np.all(f == f[0]) else f"{arm.name or 'arm'}(scaled)"
    return _rebuild(arm, links, name if name is not None else default)
