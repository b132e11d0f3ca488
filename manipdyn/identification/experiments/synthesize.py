"""A measurement log synthesised from a model: identification without a robot.

Layer 5 (identification).

``manipdyn excite`` writes a trajectory ``t,q1..qn,qd1..qdn,qdd1..qddn``; a
robot run along it logs its joint torques.  Without a robot,
:func:`synthesize` computes them from a model (inverse dynamics, the fast
path, friction included) and adds seeded Gaussian noise of ``noise`` times
each joint's peak torque, the way :mod:`manipdyn.identification.experiments.demo` does::

    traj = read_trajectory("traj.csv", arm.n)
    tau = synthesize(arm, traj.q, traj.qd, traj.qdd, noise=0.01, seed=0)

:func:`manipdyn.identification.experiments.demo.true_arm` gives an arm around a prior
(masses +-20 %, centres of mass moved by up to 2 cm, friction added), for a
log that the prior does not fit exactly (``manipdyn synthesize --perturb``).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError

__all__ = ["Trajectory", "read_trajectory", "synthesize"]


@dataclass(frozen=True)
class Trajectory:
    """Samples of a joint trajectory: ``t`` (N,) s; ``q``, ``qd``, ``qdd`` (N, n) in rad
    (m), rad/s (m/s), rad/s^2 (m/s^2)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray


def _columns(prefix: str, n: int) -> list[str]:
    return [f"{prefix}{i + 1}" for i in range(n)]


def read_trajectory(path, n: int) -> Trajectory:
    """Read the CSV ``manipdyn excite`` writes (header ``t,q1..qn,qd1..qdn,qdd1..qddn``).

    A regular file of at most :data:`manipdyn._support.limits.MAX_TRAJECTORY_BYTES`; a
    ModelError names the file and the row (1-based, the header is row 1) and
    column of the first problem.
    """
    where = os.fspath(path)
    raw = limits.read_regular(where, where, "MAX_TRAJECTORY_BYTES", "the trajectory file")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ModelError(f"{where}: a trajectory file is UTF-8 text; byte {exc.start} is not") from None
    lines = text.splitlines()
    expected = ["t"] + _columns("q", n) + _columns("qd", n) + _columns("qdd", n)
    if not lines or [h.strip() for h in lines[0].split(",")] != expected:
        got = lines[0][:200] if lines else "an empty file"
        raise ModelError(f"{where}: expected the header {','.join(expected)} (a trajectory of manipdyn "
                         f"excite for an arm of {n} joints), got {got!r}")
    rows = []
    for r, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cells = line.split(",")
        if len(cells) != len(expected):
            raise ModelError(f"{where}: row {r} has {len(cells)} values, expected {len(expected)}")
        row = []
        for c, cell in enumerate(cells):
            try:
                v = float(cell)
            except ValueError:
                raise ModelError(f"{where}: row {r}, column {expected[c]!r}: {cell.strip()[:40]!r} is not "
                                 "a number") from None
            if not math.isfinite(v):
                raise ModelError(f"{where}: row {r}, column {expected[c]!r} is not finite ({cell.strip()})")
            row.append(v)
        rows.append(row)
    if len(rows) < 2:
        raise ModelError(f"{where}: expected at least 2 rows of samples, got {len(rows)}")
    data = np.array(rows)
    if np.any(np.diff(data[:, 0]) <= 0):
        r = int(np.argmax(np.diff(data[:, 0]) <= 0)) + 3
        raise ModelError(f"{where}: column 't' must increase strictly (row {r})")
    return Trajectory(data[:, 0], data[:, 1:1 + n], data[:, 1 + n:1 + 2 * n], data[:, 1 + 2 * n:])


def synthesize(arm, q, qd, qdd, noise: float = 0.01, seed: int = 0) -> np.ndarray:
    """Joint torques of ``arm`` along ``(q, qd, qdd)`` (N, n) with noise, N m (N), shape (N, n).

    ``tau = arm.inverse_dynamics(q, qd, qdd) + noise * peak_j * e``, with
    ``peak_j = max |tau_j|`` over the samples and ``e`` standard normal from
    ``numpy.random.default_rng(seed)``.  ``noise = 0`` gives the exact torques.
    """
    noise = limits.nonnegative(noise, "noise")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ModelError(f"seed: expected an integer >= 0, got {seed!r}")
    tau = np.asarray(arm.inverse_dynamics(q, qd, qdd), dtype=np.float64).reshape(len(q), arm.n)
    if not np.all(np.isfinite(tau)):
        raise ModelError("synthesize: the torques along this trajectory overflow; check the model's units")
    peak = np.abs(tau).max(axis=0)
    return tau + noise * peak * np.random.default_rng(seed).standard_normal(tau.shape)
