"""Point-to-point excitation: moves through postures, with rests between them.

Layer 5 (identification).

Robots at work move from point to point, stop, hold and start again; a log of that kind shows
what a Fourier excitation (:mod:`manipdyn.identification.experiments.trajectory`) never does: friction through zero velocity and
at rest (the static band), and gravity held at standstill.  :func:`point_to_point` designs such
a run for an arm, within the same limits the Fourier design keeps (``arm.qlim`` shrunk by
``margin``, ``vmax``, ``amax``: :data:`manipdyn.identification.experiments.motion_limits.DEFAULT_VMAX`, :data:`manipdyn.identification.experiments.motion_limits.DEFAULT_AMAX`
by default), and writes it in the same file format (``t,q1..qn,qd1..qdn,qdd1..qddn``), so
``manipdyn synthesize`` and ``track`` read it.

The run.  It starts at rest at the middle of the joint limits (the Fourier design's ``q0``),
holds it for ``rest`` seconds, then moves to each of the ``postures`` in turn and holds each for
``rest`` seconds: ``postures + 1`` rests, at rest at both ends.

The postures: a greedy maximin design, seeded.  ``CANDIDATES_PER_POSTURE x postures`` (at most
:data:`MAX_CANDIDATES`) candidates are drawn uniformly within the limits from
``numpy.random.default_rng(seed)``; each posture in turn is the candidate farthest from the
start and the postures chosen so far (distance in joint coordinates scaled by each joint's
range).  So the stops spread over the joint space: gravity is held in postures far apart
(its parameters are seen at rest, apart from the inertia's), and the moves between them are
long and fast (the inertia's).  The order is the order chosen, so consecutive moves are long.

The moves.  Every joint moves together, from posture ``p_a`` to ``p_b`` over ``T`` seconds, along
the septic smoothstep ``s(u) = 35 u^4 - 84 u^5 + 70 u^6 - 20 u^7`` (``u = t / T``), as the Fourier
design's ramps: ``q = p_a + s(u) (p_b - p_a)``, starting and ending at rest with zero velocity,
acceleration and jerk, so position, velocity, acceleration and jerk are continuous through the
stops.  ``T`` is the shortest that keeps both limits at every time (``max |s'| = 35/16``,
``max |s''| = 7.5132`` rounded up): ``T = max_j max(35/16 |d_j| / vmax_j, sqrt(7.5132 |d_j| /
amax_j))``, rounded up to whole samples, and at least :data:`MIN_MOVE_SAMPLES` samples; the
positions stay between the two postures.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError
from .motion_limits import motion_limits

__all__ = ["PointToPoint", "point_to_point", "choose_postures", "condition_number", "DEFAULT_REST", "MAX_POSTURES"]

#: default seconds of each rest
DEFAULT_REST = 1.0
#: most postures of one run (beyond it, a run of one-second rests is over
#: :data:`manipdyn.limits.MAX_EXCITATION_SAMPLES` samples at 100 Hz anyway)
MAX_POSTURES = 1000
#: random candidates drawn per posture for the maximin design
CANDIDATES_PER_POSTURE = 64
#: most candidates drawn in all
MAX_CANDIDATES = 20_000
#: fewest samples per move: with limits far beyond the move's needs, it still takes this many samples, so
#: the file resolves it (its velocity and acceleration then stay below the limits)
MIN_MOVE_SAMPLES = 10
#: suprema of |s'| and |s''| of the septic smoothstep on [0, 1] (35/16; 7.51319 at u = 0.2764, rounded up)
_S1, _S2 = 2.1875, 7.5132


def _smoothstep(u):
    """``s, s', s''`` (w.r.t. u) of the septic smoothstep at ``u`` in [0, 1]."""
    s = u**4 * (35 - 84 * u + 70 * u**2 - 20 * u**3)
    s1 = 140 * u**3 * (1 - u) ** 3
    s2 = 420 * u**2 * (1 - u) ** 2 * (1 - 2 * u)
    return s, s1, s2


def choose_postures(lo, hi, count: int, rng, start=None) -> np.ndarray:
    """``count`` postures (count, n) within ``[lo, hi]`` (n,), greedy maximin over random candidates
    (module docstring), far from each other and from ``start`` (n,) (default: the middle)."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    span = np.where(hi > lo, hi - lo, 1.0)
    start = 0.5 * (lo + hi) if start is None else np.asarray(start, dtype=np.float64)
    m = min(MAX_CANDIDATES, max(CANDIDATES_PER_POSTURE * count, 2 * count))
    cand = lo + rng.random((m, lo.size)) * (hi - lo)
    z = (cand - lo) / span
    nearest = np.linalg.norm(z - (start - lo) / span, axis=1)       # distance to the nearest chosen
    out = np.empty((count, lo.size))
    for k in range(count):
        i = int(np.argmax(nearest))
        out[k] = cand[i]
        nearest = np.minimum(nearest, np.linalg.norm(z - z[i], axis=1))
    return out


@dataclass
class PointToPoint:
    """A point-to-point excitation (module docstring).

    Attributes
    ----------
    postures : (P + 1, n)
        The start (the middle of the limits) and the P postures, in the order visited; rad (m).
    t : (N,)
        Sample times, ``k / rate``, s.
    q, qd, qdd : (N, n)
        The samples, rad (m), rad/s (m/s), rad/s^2 (m/s^2); ``qd`` and ``qdd`` exactly 0 at rest.
    rests : (P + 1, 2)
        Start and end time of each rest, s (the last ends with the file).
    moves : (P, 2)
        Start and end time of each move, s.
    rest : float
        Seconds of each rest.
    rate : float
        Sample rate, Hz.
    seed : int
        Seed of the postures' design.
    """

    postures: np.ndarray
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    rests: np.ndarray
    moves: np.ndarray
    rest: float
    rate: float
    seed: int

    @property
    def duration(self) -> float:
        """Seconds from the first sample to the last."""
        return float(self.t[-1] - self.t[0])

    @property
    def at_rest(self) -> np.ndarray:
        """(N,) bool: the samples within a rest (every joint still)."""
        return np.any((self.t[:, None] >= self.rests[:, 0] - 1e-9 / self.rate)
                      & (self.t[:, None] <= self.rests[:, 1] + 1e-9 / self.rate), axis=1)

    def to_csv(self, path) -> None:
        """Write ``t,q1..qn,qd1..qdn,qdd1..qddn`` (SI units), atomically: the file ``manipdyn excite`` writes."""
        from ...formats.logs.data import write_trajectory_csv

        write_trajectory_csv(path, self.t, self.q, self.qd, self.qdd)


def _check(postures, rest, rate, seed, margin):
    if isinstance(postures, (bool, np.bool_)) or not isinstance(postures, (int, np.integer)) or postures < 1:
        raise ModelError(f"postures: expected an integer from 1 to {MAX_POSTURES}, got {postures!r}")
    if postures > MAX_POSTURES:
        raise ModelError(f"postures: {postures} is over the limit of {MAX_POSTURES} "
                         "(manipdyn.identification.experiments.ptp.MAX_POSTURES); expected 1 to that")
    for name, v, least in (("rest", rest, 0.0), ("rate", rate, None)):
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real) or not math.isfinite(float(v)) or (
                v < 0 if least == 0.0 else v <= 0):
            raise ModelError(f"{name}: expected a finite number {'>= 0 s' if least == 0.0 else '> 0 Hz'}, got {v!r}")
    if 0 < rest < 1.0 / rate:
        raise ModelError(f"rest: {float(rest):g} s is shorter than one sample (1 / rate = {1.0 / rate:g} s); "
                         "expected 0 (a stop of one sample) or at least one sample")
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ModelError(f"seed: expected an integer >= 0, got {seed!r}")
    if not isinstance(margin, numbers.Real) or not 0 <= margin < 0.5:
        raise ModelError(f"margin: expected a fraction in [0, 0.5), got {margin!r}")
    least = (postures + 1) * (round(rest * rate) + 1)                 # the rests alone
    if least > limits.MAX_EXCITATION_SAMPLES:
        raise limits.over_limit("postures", "the number of samples", f"over {least} (the rests alone: "
                                f"{postures + 1} rests of {float(rest):g} s at {float(rate):g} Hz)",
                                "MAX_EXCITATION_SAMPLES")


def point_to_point(arm, postures: int = 10, rest: float = DEFAULT_REST, rate: float = 100.0, seed: int = 0,
                   vmax=None, amax=None, margin: float = 0.05) -> PointToPoint:
    """A point-to-point run for ``arm`` through ``postures`` postures, with rests (module docstring).

    Parameters
    ----------
    arm : manipdyn.Arm
        Its joint limits (``arm.qlim``) and joint types (for the default limits).
    postures : int
        P, the postures visited after the start, 1 to :data:`MAX_POSTURES`.
    rest : float
        Seconds held at the start and at each posture (0: a stop of one sample).
    rate : float
        Sample rate, Hz.
    seed : int
        Seed of the postures' design: the same seed, the same run.
    vmax, amax : float or (n,), optional
        Velocity and acceleration limits per joint, as :func:`manipdyn.identification.experiments.trajectory.excitation`'s.
    margin : float
        Fraction of each joint's range kept free at both ends.

    Raises :class:`ModelError` naming the argument for a bad one, and when the run would be over
    :data:`manipdyn.limits.MAX_EXCITATION_SAMPLES` samples.
    """
    _check(postures, rest, rate, seed, margin)
    rest, rate = float(rest), float(rate)
    vmax, amax, lo, hi = motion_limits(arm, vmax, amax, margin)
    start = 0.5 * (lo + hi)
    P = np.vstack([start, choose_postures(lo, hi, int(postures), np.random.default_rng(seed), start)])
    hold = int(round(rest * rate))                              # samples after the stop's own
    d = np.diff(P, axis=0)                                      # (P, n)
    need = np.maximum(_S1 * np.abs(d) / vmax, np.sqrt(_S2 * np.abs(d) / amax)).max(axis=1)   # (P,) s
    steps = np.maximum(np.ceil(need * rate * (1 + 1e-12)), MIN_MOVE_SAMPLES)        # samples per move
    total = len(P) * (hold + 1) + float(steps.sum()) - len(steps)
    if not total <= limits.MAX_EXCITATION_SAMPLES:                 # inf from limits near 0, too
        raise limits.over_limit("postures", "the number of samples", f"{total:.6g} ({len(d)} moves of up to "
                                f"{steps.max() / rate:.3g} s within the velocity and acceleration limits, and "
                                f"{rest:g} s rests, at {rate:g} Hz)", "MAX_EXCITATION_SAMPLES")
    steps, total = steps.astype(np.int64), int(total)
    q = np.empty((total, arm.n))
    qd = np.zeros((total, arm.n))
    qdd = np.zeros((total, arm.n))
    rests, moves = np.empty((len(P), 2)), np.empty((len(d), 2))
    k = 0
    for i in range(len(P)):
        q[k:k + hold + 1] = P[i]                               # the stop and the hold
        rests[i] = k / rate, (k + hold) / rate
        k += hold + 1
        if i == len(d):
            break
        M = int(steps[i])
        u = np.arange(1, M) / M                                 # the move's inner samples
        s, s1, s2 = _smoothstep(u)
        T = M / rate
        q[k:k + M - 1] = P[i] + s[:, None] * d[i]
        qd[k:k + M - 1] = (s1 / T)[:, None] * d[i]
        qdd[k:k + M - 1] = (s2 / T**2)[:, None] * d[i]
        moves[i] = (k - 1) / rate, (k - 1 + M) / rate
        k += M - 1
    t = np.arange(total) / rate
    return PointToPoint(postures=P, t=t, q=q, qd=qd, qdd=qdd, rests=rests, moves=moves, rest=rest,
                        rate=rate, seed=int(seed))


#: most samples :func:`condition_number` stacks (more: every k-th sample)
COND_SAMPLES = 20_000


def condition_number(arm, run: PointToPoint) -> tuple[float, int]:
    """``(cond, n_base)``: the condition number of the base regressor (rigid body, no friction) stacked over
    the run's samples (every k-th beyond :data:`COND_SAMPLES`), the figure ``excite`` reports for the Fourier
    design, and the number of base parameters."""
    from ..estimation.base import base_parameters

    base = base_parameters(arm)
    k = max(1, -(-len(run.t) // COND_SAMPLES))
    Y = base.regressor(arm.lagrange.regressor(run.q[::k], run.qd[::k], run.qdd[::k]))
    sv = np.linalg.svd(Y.reshape(-1, base.count), compute_uv=False)
    return (float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf), int(base.count)
