"""Linearised dynamics ``(A, B)`` of the state ``x = (q, qd)``: ``arm.linearize``.

Layer 3 (engines): uses any engine's forward-dynamics derivatives
(:meth:`manipdyn.engines.protocol.DynamicsEngine.forward_dynamics_derivatives`) and is
attached to the model as :meth:`manipdyn.Arm.linearize` through
:func:`manipdyn.model.arm.register_service`.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.arm import Arm, register_service
from .._support.errors import StateError

__all__ = ["linearize", "zero_order_hold"]

#: Taylor terms of the scaled exponential: with ||M|| <= 1/2 after scaling, the
#: first neglected term is below 0.5^19 / 19! ~ 2e-23, far below float64's rounding
_TAYLOR_TERMS = 18


def _expm(M: np.ndarray) -> np.ndarray:
    """``exp(M)`` of a (..., m, m) stack by scaling and squaring a Taylor series (NumPy only).

    ``M / 2^s`` has 1-norm <= 1/2 (one ``s`` for the whole stack: the largest
    needed), its series is summed to :data:`_TAYLOR_TERMS` terms (Horner), and
    the result is squared ``s`` times.
    """
    norm = float(np.abs(M).sum(axis=-2).max()) if M.size else 0.0
    s = max(0, math.ceil(math.log2(norm / 0.5))) if norm > 0.5 else 0
    X = M / (2.0 ** s)
    eye = np.broadcast_to(np.eye(M.shape[-1]), M.shape)
    E = eye + X / _TAYLOR_TERMS
    for k in range(_TAYLOR_TERMS - 1, 0, -1):
        E = eye + (X @ E) / k
    for _ in range(s):
        E = E @ E
    return E


def zero_order_hold(A: np.ndarray, B: np.ndarray, dt: float):
    """Discretise ``xdot = A x + B u`` with ``u`` held constant over ``dt`` seconds (zero-order hold).

    ``Ad = exp(A dt)``, ``Bd = int_0^dt exp(A s) ds B``, both read off the
    exponential of the block matrix ``[[A, B], [0, 0]] dt``.  ``A`` (..., m, m),
    ``B`` (..., m, k); returns ``(Ad, Bd)`` of the same shapes.  Raises
    ``StateError`` naming ``dt`` when the exponential overflows float64 (a step so long
    that an unstable mode grows beyond 1.8e308, or ``A dt`` itself overflows).
    """
    m, k = B.shape[-2:]
    lead = A.shape[:-2]
    M = np.zeros(lead + (m + k, m + k))
    with np.errstate(over="ignore", invalid="ignore"):
        M[..., :m, :m] = A * dt
        M[..., :m, m:] = B * dt
        E = _expm(M) if np.all(np.isfinite(M)) else None
        ok = E is not None and bool(np.all(np.isfinite(E)))
    if not ok:
        rate = float(np.abs(np.linalg.eigvals(A)).max()) if np.all(np.isfinite(A)) and A.size else float("nan")
        raise StateError(f"dt: {dt:g} s makes exp(A dt) overflow float64 (the fastest mode, |lambda| = "
                         f"{rate:.4g} 1/s, over {rate * dt:.4g} of its time constants); a sampling period is "
                         f"far shorter than that")
    return E[..., :m, :m].copy(), E[..., :m, m:].copy()


def linearize(arm, q, qd, tau, dt=None, engine: str = "pinocchio"):
    """Linearised dynamics of ``x = (q, qd)`` about ``(q, qd, tau)``: ``(A, B)``.

    Continuous (``dt`` None): ``d(dx)/dt = A dx + B dtau`` with ::

        A = [[0, I], [dqdd/dq, dqdd/dqd]],   B = [[0], [dqdd/dtau]] = [[0], [D^-1]],

    the forward-dynamics derivatives of ``engine`` (``"pinocchio"``, the fast
    path, or ``"lagrange"``, the trace form), friction and rotor inertias
    included.  Shapes: ``A`` (2n, 2n), ``B`` (2n, n); a batch of N states
    gives (N, 2n, 2n) and (N, 2n, n).  Units SI (rad, rad/s, N m; m, m/s, N
    for prismatic joints); A in 1/s and 1/s^2, B in 1/(kg m^2 s) per N m.

    Discrete (``dt`` > 0, seconds): ``x[k+1] - x* = Ad (x[k] - x*) + Bd (tau[k] - tau*)``
    by **zero-order hold** (``tau`` constant over each step): ``Ad = exp(A dt)``,
    ``Bd = int_0^dt exp(A s) ds B``, from the matrix exponential of
    ``[[A, B], [0, 0]] dt`` (:func:`zero_order_hold`, NumPy only).  This is
    exact for the linear model; it is not an integrator of the nonlinear one.
    A state away from equilibrium (``qdd != 0``) drifts: the pair describes
    deviations from the reference trajectory through that state.

    Raises :class:`~manipdyn.StateError` naming a bad argument (``dt`` must be
    a positive finite number) and :class:`~manipdyn.SingularMassMatrixError`
    when D(q) is singular.
    """
    if dt is not None:
        if isinstance(dt, bool) or not isinstance(dt, (int, float, np.integer, np.floating)) \
                or not math.isfinite(dt) or dt <= 0:
            raise StateError(f"dt: expected a positive finite time step in seconds, got {dt!r:.60}")
    E = arm.engine(engine)
    a, b, c = E.forward_dynamics_derivatives(q, qd, tau)
    n = arm.n
    lead = a.shape[:-2]
    A = np.zeros(lead + (2 * n, 2 * n))
    A[..., :n, n:] = np.eye(n)
    A[..., n:, :n] = a
    A[..., n:, n:] = b
    B = np.zeros(lead + (2 * n, n))
    B[..., n:, :] = c
    if dt is None:
        return A, B
    return zero_order_hold(A, B, float(dt))


register_service("linearize", linearize)
Arm.linearize.__doc__ = linearize.__doc__.replace("Linearised dynamics", "Linearised dynamics (fast path by default)", 1)
