"""A step for plants too stiff for Runge-Kutta: the friction stepped implicitly, and the choice.

Layer 6 (control).

Why.  An identified model can put a link's inertia far below its friction's slope: the
smoothed Coulomb sign ``Fc tanh(v / v_s)`` has the slope ``Fc / v_s`` at ``v = 0``, so a wrist
of 1e-5 kg m^2 with ``Fc = 0.5 N m`` and ``v_s = 0.01 rad/s`` has a mode at
``lambda = -5e6 1/s``.  Classical RK4 is stable only while ``h |lambda| <= 2.785``: thousands
of steps per control period (:mod:`manipdyn.control.stiffness`), which ``simulate`` and
``replay`` refused past :data:`~manipdyn.control.stiffness.MAX_SUBSTEPS`.  The mode is real
(a joint that stops against its friction), but it lasts microseconds: what a simulator
needs is a step that stays stable across it and accurate on the rest.

The step: ROS2, the two-stage Rosenbrock-W method of Verwer, Spee, Blom and Hundsdorfer
("A second-order Rosenbrock method applied to photochemical dispersion problems", SIAM J.
Sci. Comput. 20(4), 1999), on ``y = (q, qd)``, ``y' = f(y) = (qd, FD(q, qd, tau))`` with the
torque held::

    W  = I - gamma h J,                gamma = 1 + 1/sqrt(2)
    W k1 = f(y_n)
    W k2 = f(y_n + h k1) - 2 k1
    y_{n+1} = y_n + 3/2 h k1 + 1/2 h k2

ROS2 is of order 2 for ANY matrix ``J`` (a W-method), and L-stable on the modes that ``J``
holds exactly.  Here ``J`` holds the friction and the kinematics, as MuJoCo's ``implicitfast``
integrator holds the damping: ``J = [[0, I], [0, -D^-1 F']]`` with ``D = D(q_n)`` the mass
matrix (rotor inertia included) and ``F' = dF/dqd (qd_n)`` the friction law's Jacobian
(:func:`manipdyn.model.friction_jacobian.friction_jacobian`: viscous plus the smoothed
sign's slope; a sharp sign has none), both at the step's start.  ``W`` is then block
triangular: ``k_v = (D + gamma h F')^-1 D r_v`` and ``k_q = r_q + gamma h k_v``, one ``n x n``
solve per stage, no Newton iteration.  The ``I`` in ``J`` matters: without it ``q`` advances with
the velocity from before the friction relaxed it (the stiff limit's order reduction), and on the
UR5 log of the tests the replay moved 4 times further from RK4's at one step per sample
(3.8e-4 against 9.9e-5 rad at 50 ms, measured).

What it costs, per step: two forward dynamics (ABA, as two of RK4's four), one mass matrix
(CRBA), one friction Jacobian and two ``n x n`` solves; measured on the 6-joint UR5, 0.75 (one
state) to 0.85 (a batch of 100 states) times one RK4 step (medians of 5 x 200 calls on a shared
machine; tests hold no wall clock).  On the stiff UR5 of tests/test_implicit_step.py, replayed at
100 Hz, RK4 needs 3978 steps per sample and the plan takes 16 Rosenbrock steps: 0.12 s for the
replay where RK4 at 4000 steps took 11 s.
What it gives up: order 2 instead of 4, so on a smooth plant it agrees with RK4 to
``O(h^2)``: the step count is chosen for that (below), and tests/test_implicit_step.py holds
the two within a stated tolerance on a plant RK4 handles.

The choice (:func:`integration_plan`).  RK4 with ``m`` steps per period (as before) while
``m <= RK4_LIMIT`` (100: the classical path, bit for bit what ran before, for every plant
that ran before at that cost); past it, the Rosenbrock step.  Its step count starts from what
the plant WITHOUT its friction's slope needs, ``h rho_rest <= ROSENBROCK_STEP`` (0.5), where
``rho_rest`` is the largest ``|lambda|`` of ``[[0, I], [dqdd/dq, dqdd/dqd + D^-1 F']]`` along
the reference (the friction's stiff part taken out: the step holds it), and is doubled until
one period from each reference state, with the torque that tracks it, moves by at most
:data:`ROSENBROCK_TOL` (1e-6 rad, in ``q`` and in ``dt qd``) when the steps are doubled again.
A plant stiff for another reason (``rho_rest`` over the cap too) is refused as before, with the
two rates named.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._support.errors import ModelError, SingularMassMatrixError, StateError

__all__ = ["rosenbrock_step", "integration_plan", "IntegrationPlan", "INTEGRATORS", "RK4_LIMIT",
           "ROSENBROCK_STEP", "ROSENBROCK_TOL", "GAMMA", "describe"]

#: the integrators a run can use: classical Runge-Kutta, or ROS2 with the friction implicit
INTEGRATORS = ("rk4", "rosenbrock")
#: RK4 steps per period beyond which the Rosenbrock step is chosen
RK4_LIMIT = 100
#: the largest ``h rho_rest`` of a Rosenbrock step (accuracy, not stability: Heun's bound is 2)
ROSENBROCK_STEP = 0.5
#: the largest change of one period's ``q`` (rad or m) and ``dt qd`` when the Rosenbrock steps are doubled
ROSENBROCK_TOL = 1e-6
#: ROS2's gamma, ``1 + 1/sqrt(2)`` (L-stable)
GAMMA = 1.0 + 1.0 / math.sqrt(2.0)


@dataclass(frozen=True)
class IntegrationPlan:
    """How a plant is stepped over one control period ``dt``.

    ``integrator``: ``"rk4"`` or ``"rosenbrock"`` (:data:`INTEGRATORS`); ``substeps``: steps per
    period; ``rho``: the largest ``|lambda|`` (1/s) of the plant's state Jacobian along the
    reference (None without analytical derivatives); ``rho_rest``: the same without the
    friction's slope, what sets the Rosenbrock step (None for RK4); ``rk4_substeps``: what RK4
    would have needed (may exceed the cap).
    """

    integrator: str = "rk4"
    substeps: int = 1
    rho: float | None = None
    rho_rest: float | None = None
    rk4_substeps: int = 1

    def describe(self) -> str:
        """One phrase: ``"RK4, 3 steps per period"`` or ``"Rosenbrock (ROS2, friction implicit), ..."``."""
        return describe(self.integrator, self.substeps)


def describe(integrator: str, substeps: int, per: str = "period") -> str:
    """``"RK4, m steps per <per>"`` or ``"Rosenbrock ROS2 (friction implicit), m steps per <per>"``."""
    name = "RK4" if integrator == "rk4" else "Rosenbrock ROS2 (friction implicit)"
    return f"{name}, {substeps} step{'s' if substeps != 1 else ''} per {per}"


def _call(plant, name: str):
    f = getattr(getattr(plant, "pinocchio", None), name, None)
    f = f if callable(f) else getattr(plant, name, None)
    return f if callable(f) else None


def stiff_parts(plant):
    """``(mass_matrix, friction_derivative)`` callables of ``plant`` (its Pinocchio engine's when it
    has one), or None when it lacks either: the Rosenbrock step's ``D`` and ``F'``."""
    D, F = _call(plant, "mass_matrix"), _call(plant, "friction_derivative")
    return None if D is None or F is None else (D, F)


def rosenbrock_step(fd, mass, fric, q, qd, tau, h):
    """One ROS2 step (module docstring) of ``qdd = fd(q, qd, tau)`` with ``tau`` held: ``(q, qd)``
    after ``h`` s.

    ``mass(q)`` gives ``D`` (n, n) or (B, n, n), ``fric(qd)`` ``dF/dqd`` likewise (N m s/rad);
    ``q, qd, tau`` (n,) or (B, n), rad (m), rad/s, N m.  Raises :class:`numpy.linalg.LinAlgError`
    when ``D + gamma h F'`` is singular (``D`` singular: the caller names it).
    """
    D = mass(q)
    G = D + (GAMMA * h) * fric(qd)
    gh = GAMMA * h
    a1 = fd(q, qd, tau)
    k1v = np.linalg.solve(G, (D @ a1[..., None]))[..., 0]
    k1q = qd + gh * k1v
    v1 = qd + h * k1v
    a2 = fd(q + h * k1q, v1, tau)
    k2v = np.linalg.solve(G, (D @ (a2 - 2.0 * k1v)[..., None]))[..., 0]
    k2q = (v1 - 2.0 * k1q) + gh * k2v
    return q + (1.5 * h) * k1q + (0.5 * h) * k2q, qd + (1.5 * h) * k1v + (0.5 * h) * k2v


def integration_plan(plant, q, qd, qdd, dt: float, integrator: str | None = None) -> IntegrationPlan:
    """The integrator and steps per period ``dt`` for ``plant`` along reference states (module
    docstring).  ``q, qd, qdd`` (S, n): the states (the torque at each is the plant's inverse
    dynamics).  ``integrator``: None chooses; ``"rk4"`` or ``"rosenbrock"`` insists (the steps are
    still the plant's).  Raises :class:`~manipdyn.ModelError` when the integrator would need more
    than :data:`~manipdyn.control.stiffness.MAX_SUBSTEPS` steps."""
    from .stiffness import MAX_SUBSTEPS, SAFE_STEP, state_jacobians

    got = state_jacobians(plant, q, qd, qdd)
    rho = None if got is None else _radius(got[0])
    if rho is None:
        return IntegrationPlan(integrator or "rk4")
    A, (q, qd) = got
    m = max(1, math.ceil(dt * rho / SAFE_STEP))
    if integrator != "rosenbrock" and (m <= RK4_LIMIT or integrator == "rk4"):
        if m <= MAX_SUBSTEPS:
            return IntegrationPlan("rk4", m, rho, None, m)
        return _refuse(rho, m, dt, None)
    rest = _rest_radius(plant, A, q, qd)
    if rest is not None:
        mr = max(1, math.ceil(dt * rest / ROSENBROCK_STEP))
        mr = _accurate_steps(plant, q, qd, qdd, dt, mr)
        if mr is not None and mr <= MAX_SUBSTEPS:
            return IntegrationPlan("rosenbrock", mr, rho, rest, m)
    if m <= MAX_SUBSTEPS and integrator is None:
        return IntegrationPlan("rk4", m, rho, rest, m)
    return _refuse(rho, m, dt, rest)


def _rest_radius(plant, A, q, qd):
    """The largest ``|lambda|`` of the state Jacobians ``A`` with the friction's slope taken out."""
    parts = stiff_parts(plant)
    if parts is None:
        return None
    n = q.shape[1]
    try:
        D, F = (np.asarray(x(y), dtype=np.float64).reshape(len(q), n, n) for x, y in zip(parts, (q, qd)))
        A = A.copy()
        A[:, n:, n:] += np.linalg.solve(D, F)               # dqdd/dqd holds -D^-1 F': take it out
    except (SingularMassMatrixError, StateError, np.linalg.LinAlgError):
        return None
    return _radius(A)


def _accurate_steps(plant, q, qd, qdd, dt, m):
    """The fewest Rosenbrock steps per period, from ``m`` doubling, whose one-period result moves by
    at most :data:`ROSENBROCK_TOL` (in ``q`` and ``dt qd``) when the steps are doubled, from the
    reference states with the torque that tracks them; None when none up to the cap does."""
    from .stiffness import MAX_SUBSTEPS

    fd, inv = _call(plant, "forward_dynamics"), _call(plant, "inverse_dynamics")
    mass, fric = stiff_parts(plant)
    qdd = np.atleast_2d(np.asarray(qdd, dtype=np.float64))
    try:
        tau = np.asarray(inv(q, qd, qdd), dtype=np.float64).reshape(q.shape)

        def period(k):
            x, v, h = q, qd, dt / k
            for _ in range(k):
                x, v = rosenbrock_step(fd, mass, fric, x, v, tau, h)
            return x, v
        now = period(m)
        while m <= MAX_SUBSTEPS:
            finer = period(2 * m)
            if max(np.abs(now[0] - finer[0]).max(), dt * np.abs(now[1] - finer[1]).max()) <= ROSENBROCK_TOL:
                return m
            m, now = 2 * m, finer
    except (SingularMassMatrixError, StateError, ValueError, np.linalg.LinAlgError):
        return None
    return None


def _refuse(rho, m, dt, rest):
    from .stiffness import MAX_SUBSTEPS

    extra = "" if rest is None else (f"; without its friction's slope it is still {rest:.4g} 1/s, too fast "
                                     "for the implicit friction step as well")
    raise ModelError(f"plant: its fastest mode (|lambda| = {rho:.4g} 1/s) needs {m} Runge-Kutta steps per "
                     f"control period dt = {dt:g} s, over {MAX_SUBSTEPS}{extra}; is a link's inertia tiny beside "
                     "its friction (a smoothed Coulomb sign is stiff near v = 0)? Lower the friction or the "
                     "period (montecarlo: --friction-viscous, --friction-coulomb, --dt), or give "
                     "simulate() substeps= to insist")


def _radius(A):
    rho = float(np.max(np.abs(np.linalg.eigvals(A))))
    return rho if math.isfinite(rho) else None
