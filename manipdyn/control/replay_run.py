"""The stepping of :func:`manipdyn.control.replay.replay`: every start state's window, batched.

Layer 6 (control).  :func:`plan` picks each model's integrator and steps per log sample
(:func:`manipdyn.control.implicit.integration_plan`: RK4, or the Rosenbrock step for a model
too stiff for it); :func:`run_manipdyn` steps all windows of a log together (RK4 or Rosenbrock
on the model's forward dynamics), :func:`run_mujoco` one window after another in MuJoCo (RK4,
or ``implicitfast`` with the friction's slope as damping); the torque held over each log
interval is :func:`torques`.  A window that leaves the divergence bounds of
:func:`manipdyn.simulate`, or goes non-finite, is NaN from then on.
"""

from __future__ import annotations

import numpy as np

from .._support.errors import ModelError, StateError
from .simulate import DEFAULT_MAX_POSITION, DEFAULT_MAX_VELOCITY, rk4_step

__all__ = ["plan", "torques", "run_manipdyn", "run_mujoco", "rosenbrock_windows"]


def plan(arm, datas, dt, integrator):
    """``(integrator, steps per sample)`` that ``arm`` needs along every log (the most of them)."""
    from .implicit import integration_plan
    from .stiffness import reference_samples

    plans = []
    for m in datas:
        i = reference_samples(len(m.t) - 1)
        plans.append(integration_plan(arm, m.q[i], m.qd[i], m.qdd[i], dt, integrator))
    kind = "rosenbrock" if any(p.integrator == "rosenbrock" for p in plans) else "rk4"
    if kind == "rosenbrock" and integrator is None and not all(p.integrator == kind for p in plans):
        plans = [integration_plan(arm, m.q[i], m.qd[i], m.qdd[i], dt, kind) for m in datas
                 for i in [reference_samples(len(m.t) - 1)]]
    return kind, max(p.substeps for p in plans)


def torques(tau, starts, j):
    """The torque held over the log interval from sample ``starts + j`` to the next, (W, n): the
    mean of its two ends (the interval's mean for a torque linear in time)."""
    return 0.5 * (tau[starts + j] + tau[np.minimum(starts + j + 1, len(tau) - 1)])


def run_manipdyn(arm, m, starts, steps, dt, m_sub, kind="rk4"):
    """``(Q, V)`` (H, W, n): the states at the horizons of the windows starting at ``starts``,
    NaN for a window that diverged."""
    W, n = len(starts), arm.n
    q, qd = m.q[starts].copy(), m.qd[starts].copy()
    alive = np.ones(W, dtype=bool)
    Q, V = np.full((len(steps), W, n), np.nan), np.full((len(steps), W, n), np.nan)
    h = dt / m_sub
    h2, h6 = 0.5 * h, h / 6.0
    fd = arm.forward_dynamics
    want = {k: i for i, k in enumerate(steps)}

    def f(x, v, u):
        try:
            return fd(x, v, u)
        except (StateError, ValueError):       # one window went non-finite: the others go on
            out = np.empty_like(x)
            for w in range(len(x)):
                try:
                    out[w] = fd(x[w], v[w], u[w])
                except (StateError, ValueError):
                    out[w] = np.nan
            return out

    with np.errstate(over="ignore", invalid="ignore"):
        for j in range(steps[-1]):
            idx = np.flatnonzero(alive)
            if len(idx) == 0:
                break
            x, v = q[idx], qd[idx]
            u = torques(m.tau, starts[idx], j)
            for _ in range(m_sub):
                if kind == "rosenbrock":
                    x, v = rosenbrock_windows(arm, f, x, v, u, h)
                else:
                    x, v = rk4_step(f, x, v, u, h, h2, h6)
                bad = ~(np.isfinite(x).all(axis=1) & np.isfinite(v).all(axis=1))
                x[bad], v[bad] = 0.0, 0.0
                bad |= (np.abs(x) > DEFAULT_MAX_POSITION).any(axis=1) | (np.abs(v) > DEFAULT_MAX_VELOCITY).any(axis=1)
                alive[idx[bad]] = False
            q[idx], qd[idx] = x, v
            q[~alive] = qd[~alive] = np.nan
            if j + 1 in want:
                Q[want[j + 1]], V[want[j + 1]] = q, qd
    return Q, V


def rosenbrock_windows(arm, f, x, v, u, h):
    """One Rosenbrock step of the windows ``(x, v)``; a window whose ``D + gamma h F'`` is singular goes NaN."""
    from .implicit import rosenbrock_step, stiff_parts

    parts = stiff_parts(arm)
    if parts is None:
        raise ModelError("integrator: 'rosenbrock' needs the model's mass matrix and friction derivative")
    mass, fric = parts
    try:
        return rosenbrock_step(f, mass, fric, x, v, u, h)
    except (StateError, ValueError, np.linalg.LinAlgError):
        out = np.full_like(x, np.nan), np.full_like(v, np.nan)
        for w in range(len(x)):
            try:
                out[0][w], out[1][w] = rosenbrock_step(f, mass, fric, x[w], v[w], u[w], h)
            except (StateError, ValueError, np.linalg.LinAlgError):
                pass
        return out


def run_mujoco(arm, m, starts, steps, dt, m_sub, mujoco_plant, kind="rk4"):
    """As :func:`_run_manipdyn`, MuJoCo stepping the arm's MJCF (module docstring)."""
    from .mjsim import bad_warnings, mujoco_plant_model

    W, n = len(starts), arm.n
    Q, V = np.full((len(steps), W, n), np.nan), np.full((len(steps), W, n), np.nan)
    want = {k: i for i, k in enumerate(steps)}
    from .mjsim import INTEGRATOR, STIFF_INTEGRATOR, step_hook

    with mujoco_plant_model(arm, dt / m_sub, mujoco_plant,
                            STIFF_INTEGRATOR if kind == "rosenbrock" else INTEGRATOR) as (mj, model):
        hook = step_hook(model)
        bad = bad_warnings(mj)      # BADCTRL never fires here: the torque goes in as qfrc_applied, d.ctrl stays 0
        d = mj.MjData(model)
        for w, k0 in enumerate(starts):
            mj.mj_resetData(model, d)
            d.qpos[:], d.qvel[:] = m.q[k0], m.qd[k0]
            for j in range(steps[-1]):
                d.qfrc_applied[:] = torques(m.tau, k0, j)
                for _ in range(m_sub):
                    if hook is not None:
                        hook(d)
                    mj.mj_step(model, d)
                if any(d.warning[b].number for b in bad) or not (
                        np.abs(d.qpos).max() <= DEFAULT_MAX_POSITION and np.abs(d.qvel).max() <= DEFAULT_MAX_VELOCITY):
                    break                   # diverged: MuJoCo reset its data, or it left the bounds
                if j + 1 in want:
                    Q[want[j + 1], w], V[want[j + 1], w] = d.qpos, d.qvel
    return Q, V
