"""The least-squares data of a fit, reduced: the known torque, each joint's factors, its noise.

Layer 5 (identification).  Used by :mod:`.fitting` (``fit``, which re-exports these names),
:mod:`.selection` and the smoothing choice (the folds' factors), the payload fit (noise).

Every least-squares problem :func:`.fitting.fit` solves (each joint's own, the stacked one, the
weighted one) is a small problem on per-joint triangular factors of ``[Y_b | y]``: one QR per
joint over the samples (:func:`joint_factors`), none over all joints' rows stacked; factors of
blocks of samples stack into the factors of their union (:func:`stack_factors`), which is how
cross-validation builds each fold's data without a QR over its samples.
"""

from __future__ import annotations

import numpy as np

__all__ = ["known_torque", "nonnegative_extras", "joint_factors", "joint_noise", "stack_factors", "stacked",
           "noise_from_factors", "reduce_problem", "still_rows", "moving_mean_square"]


def still_rows(qd, rest):
    """``(qd, keep)`` of a fit with the rest threshold ``rest`` ((n,) or a scalar, rad/s; None: no rest):
    ``qd`` (N, n) with each joint at rest set to 0 (:func:`manipdyn.model.friction_rest.at_rest_velocity`),
    and ``keep`` (N, n) bool, the rows each joint fits (False at rest: the torque there holds an unknown
    static friction), or None without ``rest``.  The refits of a fit with ``rest`` (the band's, the smoothing's,
    the friction shapes', the bootstrap's) build their rows from this, as :func:`.fitting.fit` does."""
    from ...model.friction_rest import rest_mask

    qd = np.asarray(qd, dtype=np.float64)
    if rest is None:
        return qd, None
    keep = ~rest_mask(qd, rest)
    return np.where(keep, qd, 0.0), keep


def moving_mean_square(err, keep) -> np.ndarray:
    """Per joint, the mean of ``err**2`` (N, n) over the rows ``keep`` (N, n) bool, or over every row (``keep``
    None); 0 where a joint kept no row.  The held-out score of a fit with a rest threshold: the joints at rest
    hold a static friction no candidate models."""
    e2 = np.asarray(err, dtype=np.float64) ** 2
    if keep is None:
        return np.mean(e2, axis=0)
    count = np.sum(keep, axis=0)
    return np.where(count > 0, np.sum(np.where(keep, e2, 0.0), axis=0) / np.maximum(count, 1), 0.0)


def known_torque(prior, qd, qdd, armature, friction):
    """Prior torques outside the fitted parameters (rotor inertia, friction), (..., n).

    Shared by :meth:`.fitting.FitResult.predict`, :func:`.fitting.fit` (subtracted from the measurements) and
    :meth:`manipdyn.identification.results.basemodel.BaseModel.inverse_dynamics`."""
    out = np.zeros(np.shape(qd))
    if not armature:
        out = out + np.asarray(qdd) @ np.asarray(prior.rotor_inertia)   # R^T diag(Jm) R, symmetric
    if (friction is False or friction is None) and prior.friction_model is not None:
        out = out + prior.lagrange.friction_torque(qd)
    return out


def nonnegative_extras(names, n: int):
    """Which extra parameters (after the 10 n link ones) are constrained >= 0: all but offsets."""
    return np.array([not nm.endswith(".offset") for nm in names[10 * n:]], dtype=bool)


def reduce_problem(A, y):
    """``(R, c, rho0)`` with ``||A b - y||^2 = ||R b - c||^2 + rho0^2`` for every b.

    One QR of ``[A | y]`` (R only, no Q): R (r, r), c (r,), rho0 the part of y
    outside A's column space.  Cheaper than lstsq or SVD on the tall A.
    """
    r = A.shape[1]
    Ra = np.linalg.qr(np.column_stack([A, y]), mode="r")
    rho0 = abs(float(Ra[r, r])) if Ra.shape[0] > r else 0.0
    return Ra[:r, :r], Ra[:r, r], rho0


def joint_factors(Yb, y) -> np.ndarray:
    """Each joint's triangular factor of ``[Yb[:, j, :] | y[:, j]]``, (n, r + 1, r + 1).

    ``||Yb[:, j] b - y[:, j]||^2 = ||F_j [b; -1]||^2`` for every b, so every least-squares
    problem :func:`.fitting.fit` solves (each joint's own, the stacked one, the weighted one) is a small
    problem on these factors: one QR per joint over the samples, none over all joints' rows
    stacked.  Factors of consecutive blocks of samples stack (``joint_factors`` of the stacked
    blocks' factors), which is how :mod:`.selection` builds each fold's data.
    """
    Yb, y = np.asarray(Yb, dtype=np.float64), np.asarray(y, dtype=np.float64)
    N, n, r = Yb.shape
    out = np.zeros((n, r + 1, r + 1))
    for j in range(n):
        Ra = np.linalg.qr(np.column_stack([Yb[:, j, :], y[:, j]]), mode="r")
        out[j, :Ra.shape[0]] = Ra
    return out


def stack_factors(blocks) -> np.ndarray:
    """One factor per joint (n, r + 1, r + 1) of several blocks' factors stacked (one small QR each)."""
    rest, F = np.concatenate(blocks, axis=1), np.zeros_like(blocks[0])
    for j in range(F.shape[0]):
        Rj = np.linalg.qr(rest[j], mode="r")
        F[j, :Rj.shape[0]] = Rj
    return F


def stacked(F, w=None):
    """``(R, c, rho0)`` of :func:`reduce_problem` for the rows of every joint stacked (each weighted by ``w_j``),
    from the joints' factors ``F`` (n, r + 1, r + 1)."""
    r = F.shape[-1] - 1
    w = np.ones(F.shape[0]) if w is None else np.asarray(w, dtype=np.float64)
    Ra = np.linalg.qr((F * w[:, None, None]).reshape(-1, r + 1), mode="r")
    return Ra[:r, :r], Ra[:r, r], abs(float(Ra[r, r]))


def noise_from_factors(F, N: int) -> np.ndarray:
    """:func:`joint_noise` from the joints' factors ``F`` (:func:`joint_factors`) of ``N`` samples
    (an int, or (n,): each joint's rows, fewer where rows were left out)."""
    n, r = F.shape[0], F.shape[-1] - 1
    sigma = np.empty(n)
    counts = np.broadcast_to(np.asarray(N), (n,))       # per joint: its rows (rest rows left out)
    for j in range(n):
        A, b = F[j, :, :r], F[j, :, r]
        norms = np.linalg.norm(A, axis=0)                   # Q is orthogonal: the columns' norms
        A = A[:, norms > 1e-12 * max(norms.max(), 1e-300)]
        sol, _, rank, _ = np.linalg.lstsq(A, b, rcond=None)
        sigma[j] = np.sqrt(np.sum((A @ sol - b) ** 2) / max(1, int(counts[j]) - rank))
    return sigma


def joint_noise(Yb, y) -> np.ndarray:
    """Per-joint noise level ``sigma_j`` (n,) from each joint's own OLS fit (module docstring):
    ``Yb`` (N, n, p) the regressor, ``y`` (N, n) the torques it should explain."""
    N, n, _ = Yb.shape
    sigma = np.empty(n)
    for j in range(n):
        A = Yb[:, j, :]
        norms = np.linalg.norm(A, axis=0)
        A = A[:, norms > 1e-12 * max(norms.max(), 1e-300)]
        R, c, rho0 = reduce_problem(A, y[:, j])
        sol, _, rank, _ = np.linalg.lstsq(R, c, rcond=None)
        sigma[j] = np.sqrt((np.sum((R @ sol - c) ** 2) + rho0**2) / max(1, N - rank))
    return sigma
