"""How many Runge-Kutta steps a plant needs per control period: :func:`rk4_substeps`.

Layer 6 (control) (applications: control).

:func:`manipdyn.simulate` holds the controller's torque over each control period
``dt`` (a digital controller's zero-order hold: part of the simulated system) and
integrates the plant over it by the classical 4th-order Runge-Kutta method.  RK4
is only stable while ``h |lambda| <= 2.785`` on the negative real axis (2.828 on
the imaginary one) for every eigenvalue ``lambda`` of the plant's own dynamics
``x' = f(x, tau)``, ``x = (q, qd)``: a light link with viscous friction ``b`` has
``lambda = -b / J``.  Past that bound the integrator, not the arm, blows up, and a
run "diverges" for every controller alike (measured: the UR5's last link, J =
1.3e-4 kg m^2, with b = 0.4 N m s, lambda = -3000 1/s, at dt = 1 ms; eight of
twenty Monte-Carlo plants did, PD included, within 13 ms).

So the period is split into ``m`` equal Runge-Kutta steps, ``h = dt / m``, with
the torque still held over the whole period, and ``m`` is the smallest integer
with ``h rho <= SAFE_STEP`` (:data:`SAFE_STEP` = 2.0, margin below 2.785), where
``rho`` is the largest ``|lambda|`` of the state Jacobian

    A = [[0, I], [dqdd/dq, dqdd/dqd]]

(the plant's analytical forward-dynamics derivatives, friction included) over
the reference's states, at the torque that tracks them.  A plant that needs no
more than one step keeps exactly the arithmetic it always had (``m = 1``).
A sharp Coulomb sign has no derivative off ``v = 0`` and adds nothing (it
chatters at rest, boundedly); a smoothed sign ``tanh(v / v_s)`` is stiff near
``v = 0`` (``Fc / (v_s J)``) and is counted.  Plants without analytical
derivatives (a user's callable) keep ``m = 1`` unless ``substeps`` is given.
Past :data:`~manipdyn.control.implicit.RK4_LIMIT` steps, ``simulate``, ``replay`` and the
Monte-Carlo studies step the plant by a Rosenbrock step with the friction implicit instead
(:func:`manipdyn.control.implicit.integration_plan`); :func:`rk4_substeps` still counts RK4's.

What more steps cannot fix: the *loop*.  The torque is held over the whole period
whatever ``m``, so a controller whose damping ``K_d`` moves the plant at a rate
``|eig(D_plant^-1 K_d)| > 2 / dt`` diverges at any ``m``; only a shorter period (or
a softer controller, or a heavier plant) holds it.  :func:`sampled_loop_rate`
measures that rate for a plant and a controller along the reference; the
Monte-Carlo studies record it per run and name it as the cause of a divergence
(:mod:`manipdyn.montecarlo.diverged`).
"""

from __future__ import annotations

import math

import numpy as np

from .._support.errors import ModelError, SingularMassMatrixError, StateError

__all__ = ["rk4_substeps", "state_jacobians", "reference_samples", "sampled_loop_rate", "SAFE_STEP", "MAX_SUBSTEPS", "SAMPLES",
           "SAMPLED_LIMIT"]

#: the largest ``h |lambda|`` allowed (RK4 is stable to 2.785 on the negative real axis)
SAFE_STEP = 2.0
#: more steps than this per control period is refused (the plant is too stiff for the period)
MAX_SUBSTEPS = 1000
#: reference states the Jacobian is evaluated at (evenly spaced, both ends included)
SAMPLES = 9


def _call(plant, name: str):
    """The plant's Pinocchio engine's ``name`` (a Monte-Carlo plant or an arm), else its own, else None."""
    f = getattr(getattr(plant, "pinocchio", None), name, None)
    f = f if callable(f) else getattr(plant, name, None)
    return f if callable(f) else None


def rk4_substeps(plant, q, qd, qdd, dt: float):
    """``(m, rho)``: RK4 steps per control period ``dt`` for ``plant`` along states (module docstring).

    ``q, qd, qdd`` (S, n): reference states (the torque at each is the plant's inverse
    dynamics, the torque that tracks it); ``rho`` (1/s) the largest ``|lambda|`` found,
    None when the plant has no analytical derivatives (``m`` is then 1).  Raises
    :class:`~manipdyn.ModelError` (a ValueError) when ``m`` would exceed :data:`MAX_SUBSTEPS`.
    """
    got = state_jacobians(plant, q, qd, qdd)
    if got is None:
        return 1, None
    lam = np.linalg.eigvals(got[0])
    rho = float(np.max(np.abs(lam)))
    if not math.isfinite(rho):
        return 1, None
    m = max(1, math.ceil(dt * rho / SAFE_STEP))
    if m > MAX_SUBSTEPS:
        raise ModelError(f"plant: its fastest mode (|lambda| = {rho:.4g} 1/s) needs {m} Runge-Kutta steps per "
                         f"control period dt = {dt:g} s, over {MAX_SUBSTEPS}; is a link's inertia tiny beside its "
                         "friction (a smoothed Coulomb sign is stiff near v = 0)? Lower the friction or the "
                         "period (montecarlo: --friction-viscous, --friction-coulomb, --dt), or give "
                         "simulate() substeps= to insist")
    return m, rho


def state_jacobians(plant, q, qd, qdd):
    """``(A, (q, qd))``: the state Jacobians ``A = [[0, I], [dqdd/dq, dqdd/dqd]]`` (S, 2n, 2n) of
    ``plant`` at reference states ``q, qd, qdd`` (S, n), at the torque that tracks them, with the
    states as float arrays; None without analytical derivatives or where ``D`` is singular."""
    fdd, inv = _call(plant, "forward_dynamics_derivatives"), _call(plant, "inverse_dynamics")
    if fdd is None or inv is None:
        return None
    q, qd, qdd = (np.atleast_2d(np.asarray(x, dtype=np.float64)) for x in (q, qd, qdd))
    try:
        tau = np.asarray(inv(q, qd, qdd), dtype=np.float64).reshape(q.shape)
        dq, dv, _ = fdd(q, qd, tau)
    except (SingularMassMatrixError, StateError, np.linalg.LinAlgError):
        # a singular D somewhere on the path: the simulation meets it and says so (a run that
        # diverges); the step count cannot be read there
        return None
    S, n = q.shape
    A = np.zeros((S, 2 * n, 2 * n))
    A[:, :n, n:] = np.eye(n)
    A[:, n:, :n] = np.asarray(dq).reshape(S, n, n)
    A[:, n:, n:] = np.asarray(dv).reshape(S, n, n)
    return A, (q, qd)


def reference_samples(N: int) -> np.ndarray:
    """Indices of the :data:`SAMPLES` reference samples (of N + 1) :func:`rk4_substeps` reads."""
    return np.unique(np.linspace(0, N, SAMPLES).round().astype(int))


#: ``dt |lambda|`` beyond which a damping loop closed through a zero-order hold is unstable:
#: ``v_{k+1} = (1 - dt a) v_k`` grows once ``dt a > 2``
SAMPLED_LIMIT = 2.0


def sampled_loop_rate(plant, controller, t, q, qd, qdd) -> float:
    """The largest ``|lambda|`` (1/s) of ``D_plant(q)^-1 K_d`` over reference states, where
    ``K_d = -d tau / d qd`` is the controller's damping gain there (N m s/rad, by central
    differences): the rate at which the controller's damping moves the plant.

    A digital controller holds its torque over the period ``dt``; its damping loop is then
    unstable once ``dt * rate > SAMPLED_LIMIT`` (2), however many Runge-Kutta steps integrate
    the plant (:func:`rk4_substeps` cannot help: only a shorter period, a softer controller or
    a heavier plant can).  A controller tuned to a nominal arm meets this on a plant that is
    much lighter in some direction (e.g. a link's inertia about an axis that two aligned
    joints share).

    ``t`` (S,), ``q, qd, qdd`` (S, n): reference samples; the controller is evaluated at
    ``q = q_d``, ``qd = qd_d`` on a reset shallow copy of itself (the original keeps its
    state; a wrapper's ``inner`` controller is used: additive noise has no gain).  Returns
    0.0 when the controller or the plant's mass matrix cannot be evaluated.
    """
    import copy

    base = getattr(controller, "inner", controller)
    D = _call(plant, "mass_matrix")
    if not callable(getattr(base, "step", None)) or D is None:
        return 0.0
    q, qd, qdd = (np.atleast_2d(np.asarray(x, dtype=np.float64)) for x in (q, qd, qdd))
    n = q.shape[1]
    rate = 0.0
    for ti, qi, vi, ai in zip(np.atleast_1d(np.asarray(t, dtype=np.float64)), q, qd, qdd):
        c = copy.copy(base)
        try:
            c.reset()
            K = np.empty((n, n))
            for j in range(n):
                h = 1e-6 * max(1.0, abs(vi[j]))
                up, down = vi.copy(), vi.copy()
                up[j] += h
                down[j] -= h
                K[:, j] = -(c.step(float(ti), qi, up, qi, vi, ai) - c.step(float(ti), qi, down, qi, vi, ai)) / (2 * h)
            lam = np.linalg.eigvals(np.linalg.solve(np.asarray(D(qi), dtype=np.float64), K))
        except (SingularMassMatrixError, StateError, ValueError, np.linalg.LinAlgError):
            continue
        if np.all(np.isfinite(lam)):
            rate = max(rate, float(np.max(np.abs(lam))))
    return rate
