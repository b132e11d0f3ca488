"""Friction through rest: a joint at rest holds any torque within its static band.

Layer 1 (model).

A friction law of :mod:`manipdyn.model.friction_law` is a function of the velocity: the
Coulomb term ``Fc sigma(v)`` and the Stribeck term ``(Fs - Fc) exp(-|v / vs|^delta) sigma(v)``
together rise to the breakaway (static) level ``Fs`` as ``|v|`` falls to 0, with the sign of
``v``.  A joint that has stopped has no sign to give: the velocity a log measures there is
noise (the encoder's dither, the filter's ripple), and ``sigma(noise)`` would predict a
torque of either sign, sample by sample.  The real joint at rest holds **any** torque within
``[-Fs, Fs]`` (the static band), usually near the level left by its last motion, and breaks
away only beyond it.  So:

* a joint is **at rest** on a sample when its measured velocity is within a rest threshold,
  ``|qd_j| <= threshold_j`` (:func:`rest_mask`); the threshold comes from the log's velocity
  noise (``manipdyn.identification.inputs.rest``), as the Coulomb smoothing does;
* at rest the joint's velocity is 0 (:func:`at_rest_velocity`): a model then predicts its
  rigid part (gravity, inertia) and the constant offset, and no Coulomb or Stribeck torque;
* the torque there is that prediction plus a static friction anywhere within
  ``[-Fs_j, Fs_j]``: :class:`StaticFriction` holds the threshold and ``Fs`` per joint, and
  the half-width of a band at rest is the moving band's plus ``Fs_j``
  (:meth:`StaticFriction.widths`);
* :func:`held_static_torque` is the static friction of a simulated joint that holds the level
  of its last motion: what a synthetic log with true static friction needs.

Joint side: the rest is the joints' (a coupled motor-side law sees a motor at rest when the
joints it turns are).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._support.errors import ModelError, StateError

__all__ = ["rest_mask", "at_rest_velocity", "last_motion_sign", "held_static_torque", "StaticFriction",
           "breakaway_level"]


def _threshold(threshold, n: int) -> np.ndarray:
    t = np.asarray(threshold, dtype=np.float64)
    if t.ndim == 0:
        t = np.full(n, float(t))
    if t.shape != (n,) or not np.all(np.isfinite(t)) or np.any(t < 0):
        raise ModelError(f"rest threshold: expected {n} finite speeds >= 0 (rad/s or m/s), got {t.tolist()}")
    return t


def _velocities(qd) -> np.ndarray:
    qd = np.asarray(qd, dtype=np.float64)
    if qd.ndim not in (1, 2):
        raise StateError(f"qd: expected shape (n,) or (N, n), got {qd.shape}")
    return qd


def rest_mask(qd, threshold) -> np.ndarray:
    """(N, n) or (n,) bool: joint j is at rest on the sample, ``|qd_j| <= threshold_j``.

    ``qd`` (N, n) or (n,), rad/s (m/s); ``threshold`` (n,) or a scalar, same units (0: only an exact
    zero is rest).
    """
    qd = _velocities(qd)
    return np.abs(qd) <= _threshold(threshold, qd.shape[-1])


def at_rest_velocity(qd, threshold) -> np.ndarray:
    """``qd`` (N, n) with the joints at rest (:func:`rest_mask`) set to 0: the velocity a model should
    see there (the measured one is noise; module docstring)."""
    qd = _velocities(qd)
    return np.where(rest_mask(qd, threshold), 0.0, qd)


def last_motion_sign(qd, threshold) -> np.ndarray:
    """(N, n) in {-1, 0, 1}: per sample the sign of the joint's last velocity beyond ``threshold`` (the
    current one while moving; 0 before the first motion).  ``qd`` (N, n) in time order."""
    qd = np.atleast_2d(_velocities(qd))
    moving = ~rest_mask(qd, threshold)
    s = np.where(moving, np.sign(qd), 0.0)
    idx = np.where(moving, np.arange(len(qd))[:, None], 0)
    np.maximum.accumulate(idx, axis=0, out=idx)
    out = np.take_along_axis(s, idx, axis=0)
    return np.where(np.cumsum(moving, axis=0) > 0, out, 0.0)


def held_static_torque(qd, threshold, level, hold=1.0) -> np.ndarray:
    """Static friction torque (N, n), N m, of joints that hold the level of their last motion at rest.

    ``qd`` (N, n) in time order; ``threshold`` (n,) the rest speed; ``level`` (n,) ``Fs``; ``hold``: the
    fraction of ``Fs`` held, a scalar, (n,) or (N, n) (e.g. one draw per rest, in [0, 1]).  The torque is
    ``hold Fs sign(last motion)`` on the rest samples and 0 while the joint moves (the moving law's
    friction is the law's own); a joint that never moved holds 0.
    """
    qd = np.atleast_2d(_velocities(qd))
    level = _threshold(level, qd.shape[1])
    hold = np.broadcast_to(np.asarray(hold, dtype=np.float64), qd.shape)
    if not np.all((hold >= 0) & (hold <= 1)):
        raise ModelError("hold: expected fractions of the static level in [0, 1]")
    rest = rest_mask(qd, threshold)
    return np.where(rest, hold * level * last_motion_sign(qd, threshold), 0.0)


def breakaway_level(law, n: int) -> np.ndarray:
    """``Fs`` (n,) of a joint-side friction law (a :class:`~manipdyn.model.friction_law.Friction`, or None:
    zeros): its Coulomb level (the larger of an asymmetric law's two) plus its Stribeck level, N m.  A
    motor-side law's levels are motor torques: zeros here (say so where it matters)."""
    out = np.zeros(n)
    if law is None or getattr(law, "side", "joint") != "joint":
        return out
    if law.coulomb_pos is not None:
        out = out + np.maximum(law.coulomb_pos, law.coulomb_neg)
    if law.stribeck_level is not None:
        out = out + np.maximum(law.stribeck_level, 0.0)
    return out


@dataclass(frozen=True, eq=False)
class StaticFriction:
    """The static band of each joint at rest (module docstring).

    ``threshold`` (n,) rad/s (m/s): the rest speed; ``level`` (n,) N m (N): ``Fs``, the half-width of the
    static band; ``measured`` (n,) bool: ``level`` measured on the fit data's rest samples (else the
    law's breakaway level stands in, a lower bound, and the fit never rested there); ``rest_fraction``
    (n,): the fraction of the fit samples at rest per joint; ``slow`` (n,) rad/s or None: the speed under
    which the fit data ran too rarely to have checked the law (a joint slower than that, at rest or
    breaking away, gets the static band too, and where the fit never rested, a flag).
    """

    threshold: np.ndarray
    level: np.ndarray
    measured: np.ndarray
    rest_fraction: np.ndarray
    slow: np.ndarray | None = None

    def __post_init__(self):
        n = len(np.atleast_1d(self.threshold))
        for k in ("threshold", "level", "rest_fraction", "slow"):
            if getattr(self, k) is None:
                continue
            a = np.asarray(getattr(self, k), dtype=np.float64).reshape(-1)
            if a.shape != (n,) or not np.all(np.isfinite(a)) or np.any(a < 0):
                raise ModelError(f"static friction: {k}: expected {n} finite numbers >= 0, got {a.tolist()}")
            a.setflags(write=False)
            object.__setattr__(self, k, a)
        m = np.asarray(self.measured).reshape(-1)
        if m.shape != (n,) or m.dtype != bool:
            raise ModelError(f"static friction: measured: expected {n} true/false, got {m.tolist()}")
        m.setflags(write=False)
        object.__setattr__(self, "measured", m)

    @property
    def n(self) -> int:
        return len(self.threshold)

    @property
    def rested(self) -> np.ndarray:
        """(n,) bool: the fit data rested on the joint (its level is measured)."""
        return self.measured

    def rest(self, qd) -> np.ndarray:
        """(N, n) bool: the joints at rest (:func:`rest_mask` at ``threshold``)."""
        return rest_mask(np.atleast_2d(qd), self.threshold)

    def velocity(self, qd) -> np.ndarray:
        """:func:`at_rest_velocity` at ``threshold``: the velocities a model predicts with."""
        return at_rest_velocity(qd, self.threshold)

    def static(self, qd) -> np.ndarray:
        """(N, n) bool: the joint at rest, or slower than ``slow``: where the static band applies."""
        qd = np.atleast_2d(np.asarray(qd, dtype=np.float64))
        out = self.rest(qd)
        return out if self.slow is None else out | (np.abs(qd) < self.slow)

    def widths(self, qd, moving) -> np.ndarray:
        """Half-widths (N, n): ``moving`` (N, n) or (n,), the moving band's, plus ``Fs_j`` where the joint is
        at rest or slower than the fit data ran (:meth:`static`)."""
        static = self.static(qd)
        return np.broadcast_to(moving, static.shape) + np.where(static, self.level, 0.0)

    def flags(self, qd) -> np.ndarray:
        """(N, n) bool: at rest, or slower than the fit data ran, on a joint where the fit data never rested
        (its static level a stand-in, the break-away never seen)."""
        return self.static(qd) & ~self.measured

    def to_dict(self) -> dict:
        return {"threshold": [float(x) for x in self.threshold], "static_level": [float(x) for x in self.level],
                "measured": [bool(x) for x in self.measured],
                "rest_fraction": [float(x) for x in self.rest_fraction],
                **({} if self.slow is None else {"slow": [float(x) for x in self.slow]})}

    @classmethod
    def from_dict(cls, value, n: int, where: str) -> "StaticFriction":
        if not isinstance(value, dict):
            raise ModelError(f"{where}: expected an object with threshold, static_level, measured, rest_fraction")
        try:
            measured = value["measured"]
            if not isinstance(measured, list) or not all(isinstance(x, bool) for x in measured):
                raise ValueError("measured: expected true or false per joint")
            out = cls(threshold=np.array(value["threshold"], dtype=np.float64),
                      level=np.array(value["static_level"], dtype=np.float64),
                      measured=np.array(measured, dtype=bool),
                      rest_fraction=np.array(value["rest_fraction"], dtype=np.float64),
                      slow=None if value.get("slow") is None else np.array(value["slow"], dtype=np.float64))
        except (KeyError, TypeError, ValueError) as exc:
            raise ModelError(f"{where}: malformed static friction record ({exc})") from None
        if out.n != n:
            raise ModelError(f"{where}: threshold: expected {n} numbers, got {out.n}")
        return out

    def describe(self) -> str:
        """One line: the threshold and the levels, measured or stood in."""
        lv = ", ".join(f"j{j + 1} {x:.3g}" + ("" if m else "*") for j, (x, m) in enumerate(zip(self.level,
                                                                                            self.measured)))
        th = ", ".join(f"{x:.2g}" for x in self.threshold)
        star = ("; * the fit never rested there: the law's breakaway level stands in (a lower bound), and rest "
                "samples there are flagged") if not np.all(self.measured) else ""
        slow = "" if self.slow is None else (" (and slower than the fit data ran, "
                                             + ", ".join(f"{x:.2g}" for x in self.slow) + " rad/s)")
        return (f"at rest (|qd| within {th} rad/s) the prediction is the rigid part, and there{slow} the band widens "
                f"by the static friction level {lv} N m{star}")
