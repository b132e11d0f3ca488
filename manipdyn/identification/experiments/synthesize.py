"""A measurement log synthesised from a model: identification without a robot.

Layer 5 (identification).

``manipdyn excite`` writes a trajectory ``t,q1..qn,qd1..qdn,qdd1..qddn``; a
robot run along it logs its joint torques.  Without a robot,
:func:`synthesize` computes them from a model (inverse dynamics, the fast
path, friction included) and adds seeded Gaussian noise of ``noise`` times
each joint's peak torque, the way :mod:`manipdyn.identification.experiments.demo` does::

    traj = read_trajectory("traj.csv", arm.n)      # manipdyn.formats.logs.trajectory
    tau = synthesize(arm, traj.q, traj.qd, traj.qdd, noise=0.01, seed=0)

:func:`manipdyn.identification.experiments.demo.true_arm` gives an arm around a prior
(masses +-20 %, centres of mass moved by up to 2 cm, friction added), for a
log that the prior does not fit exactly (``manipdyn synthesize --perturb``).

Contacts (:func:`parse_contact`, :func:`contact_torques`; ``manipdyn synthesize --contact
T0:T1:FX,FY,FZ[@LINK]``): a force ``f`` in newtons, in the base (world) frame, that the environment
applies to the arm from ``T0`` to ``T1`` s at the tool's origin, or at link LINK's frame origin.  The
arm still follows the trajectory, so its drives give ``J^T f`` less: the logged torque is
``tau_model - J^T f``, and ``J^T f`` is the external joint torque a collision detector estimates
(:mod:`manipdyn.control.collision`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError
from ...formats.logs.trajectory import Trajectory, read_trajectory

__all__ = ["Trajectory", "read_trajectory", "synthesize", "Contact", "parse_contact", "check_contacts_act", "contact_torques"]


def synthesize(arm, q, qd, qdd, noise: float = 0.01, seed: int = 0, static_friction: bool = False) -> np.ndarray:
    """Joint torques of ``arm`` along ``(q, qd, qdd)`` (N, n) with noise, N m (N), shape (N, n).

    ``tau = arm.inverse_dynamics(q, qd, qdd) + noise * peak_j * e``, with
    ``peak_j = max |tau_j|`` over the samples and ``e`` standard normal from
    ``numpy.random.default_rng(seed)``.  ``noise = 0`` gives the exact torques.
    ``static_friction=True``: at rest (``qd_j == 0``) each joint also holds a friction torque within its
    law's static band, of the last motion's sign (:func:`manipdyn.identification.experiments.static_friction.rest_torque`, seeded by ``seed``;
    :func:`manipdyn.identification.experiments.static_friction.with_static_friction` gives the arm a breakaway level and a Stribeck decay).
    """
    noise = limits.nonnegative(noise, "noise")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ModelError(f"seed: expected an integer >= 0, got {seed!r}")
    tau = np.asarray(arm.inverse_dynamics(q, qd, qdd), dtype=np.float64).reshape(len(q), arm.n)
    if static_friction:
        from .static_friction import rest_torque, static_levels

        tau = tau + rest_torque(np.asarray(qd, dtype=np.float64).reshape(len(q), arm.n), static_levels(arm), seed)
    peak = float(np.max(np.abs(tau))) if tau.size else 0.0
    if not peak <= limits.MAX_SIGNAL:      # inf, nan, or more than a log's readers take (1e307 N m)
        raise ModelError(f"synthesize: the torques along this trajectory reach {peak:.3g} N m, over "
                         f"{limits.MAX_SIGNAL:g} (manipdyn.limits.MAX_SIGNAL, what a log's readers take); "
                         "check the model's units and the trajectory's")
    peak = np.abs(tau).max(axis=0)
    return tau + noise * peak * np.random.default_rng(seed).standard_normal(tau.shape)


@dataclass(frozen=True)
class Contact:
    """A force ``force`` (3,) N in the base frame, applied to the arm for ``t0 <= t < t1`` s at the tool's
    origin (``link`` None) or at link ``link``'s frame origin (1..n)."""

    t0: float
    t1: float
    force: tuple
    link: int | None = None

    def to_dict(self) -> dict:
        return {"t0": self.t0, "t1": self.t1, "force": list(self.force), "frame": "world",
                "at": "tool" if self.link is None else f"link {self.link}"}


def parse_contact(text: str, arm, where: str = "--contact") -> Contact:
    """``"T0:T1:FX,FY,FZ[@LINK]"`` as a :class:`Contact`; LINK is 1..n or one of ``arm.link_names``."""
    body, _, link = str(text).partition("@")
    parts = body.split(":")
    form = "T0:T1:FX,FY,FZ[@LINK] (seconds, newtons in the base frame; LINK a number 1..n or a link name)"
    try:
        t0, t1 = float(parts[0]), float(parts[1])
        f = tuple(float(x) for x in parts[2].split(","))
    except (IndexError, ValueError):
        raise ModelError(f"{where}: expected {form}, got {text!r}") from None
    if len(parts) != 3 or len(f) != 3 or not all(math.isfinite(x) for x in (t0, t1) + f) or not t1 > t0:
        raise ModelError(f"{where}: expected {form} with T0 < T1, got {text!r}")
    k = None
    if link:
        names = getattr(arm, "link_names", None)
        names = list((names() if callable(names) else names) or [])
        if re.fullmatch(r"[0-9]{1,6}", link.strip()):      # ASCII digits only ('²' is a digit to str.isdigit)
            k = int(link)
        elif link in names:
            k = names.index(link) + 1
        if k is None or not 1 <= k <= arm.n:
            raise ModelError(f"{where}: LINK: expected 1..{arm.n} or a link name, got {link!r}")
    return Contact(t0, t1, f, k)


def check_contacts_act(contacts, t, where: str = "--contact") -> None:
    """Refuse a :class:`Contact` that holds at no sample of the times ``t`` (N,), s: a contact after the
    trajectory's end (5 to 6 s on a 4 s one) never acts, and its truth would record one that did."""
    t = np.asarray(t, dtype=np.float64)
    for c in contacts:
        if not np.any((t >= c.t0) & (t < c.t1)):
            raise ModelError(f"{where} {c.t0:g}:{c.t1:g}: acts at no sample of the trajectory (t = {t[0]:g} to "
                             f"{t[-1]:g} s): give T0:T1 within it")


def contact_torques(arm, t, q, contacts) -> np.ndarray:
    """``sum J_c(q)^T f_c`` (N, n), N m, over the contacts held at each time ``t`` (N,): the external joint
    torque of the :class:`Contact` list ``contacts`` along ``q`` (N, n)."""
    t = np.asarray(t, dtype=np.float64)
    out = np.zeros((len(t), arm.n))
    for c in contacts:
        on = (t >= c.t0) & (t < c.t1)
        if not np.any(on):
            continue
        J = arm.jacobian(q[on]) if c.link is None else arm.jacobian(q[on], link=c.link)
        out[on] += np.einsum("kij,i->kj", J[:, :3, :], np.asarray(c.force, dtype=np.float64))
    return out
