"""MuJoCo stepping the plant of a closed-loop run: ``simulate(..., simulator="mujoco")``.

Layer 6 (control).  The plant is the arm's own MJCF (``md.to_mjcf``, compiled by the
``"mujoco"`` engine, :meth:`manipdyn.engines.mujoco.MujocoEngine.simulation_model`) as a
MuJoCo user has it: joint limits and ``frictionloss`` are MuJoCo's constraints.  Each
control period the controller's torque goes in as the actuators' control (``d.ctrl``: one
``motor`` per joint, gear 1, clamped to ``ctrlrange`` where the model has an effort limit)
and is held while MuJoCo takes ``substeps`` steps of ``dt / substeps``: the same zero-order
hold, the same sub-steps and, with the default ``integrator="RK4"``, the same classical
Runge-Kutta scheme as manipdyn's own loop (:mod:`manipdyn.control.simulate`), so that the two
runs differ only by how each evaluates the dynamics (``mj_forward`` against Pinocchio's ABA,
equal to about 1e-13: ``manipdyn check ARM --engines pinocchio,mujoco``) and, with the default
plant, by what MJCF does not hold (:func:`manipdyn.formats.losses.format_losses`).

Two plants (``mujoco_plant``):

* ``"file"`` (default): the MJCF as MuJoCo loads it: joint limits and ``frictionloss`` are
  MuJoCo's soft constraints, and the friction terms MJCF cannot hold are absent;
* ``"model"``: the same plant as manipdyn's own simulation: constraints off, and the arm's
  friction law beyond MuJoCo's damping (:meth:`MujocoEngine.friction_beyond_damping`) applied at
  every evaluation of the dynamics, Runge-Kutta stages included, through MuJoCo's passive-force
  callback (``mjcb_passive``).  That callback is global to the process, so such runs take a
  lock: one at a time per process.

How close the ``"model"`` plant's run stays to manipdyn's depends on the law.  A smooth law
(viscous, a smoothed Coulomb, Gaz's sigmoid) gives runs equal to about 1e-15 rad, under RK4's own
error.  A sharp Coulomb sign (``smoothing = 0``: an identified model's links, a URDF's
``<dynamics friction>``) makes the equations jump at ``qd = 0``; where a joint stops, the last
bits of the velocity decide the sign, and manipdyn's own run started 1e-15 rad off departs as far
as MuJoCo's does (3.9e-2 rad over 1 s of computed torque on an identified UR5): the two agree to
that sensitivity to rounding, not to 1e-15 (tests/test_mujoco_track.py).

A plant too stiff for RK4 (:mod:`manipdyn.control.implicit`: a light link with a steep
friction; ``log.integrator == "rosenbrock"``) is stepped by MuJoCo's ``implicitfast`` integrator,
which takes the joints' damping implicitly (semi-implicit Euler with ``D - h dqfrc/dqd``).  For
the ``"model"`` plant, the friction's slope at the step's start velocity is put into the
joints' damping (``dof_damping``, the diagonal of ``dF/dqd``, at least the MJCF's own) before
each step, and the passive-force callback takes that damping back out of the law it adds, so
the force is the law's and its stiff part is implicit, as manipdyn's own Rosenbrock step holds
it (a coupled transmission's off-diagonal slope stays explicit).  The ``"file"`` plant needs
nothing more: its damping is MuJoCo's, its Coulomb a constraint.  That step is of first order:
it agrees with manipdyn's to the step's own error, not to RK4's.

MuJoCo resets its data (to the model's reference pose) when it meets a non-finite or huge
acceleration, position or velocity (``mjWARN_BADQACC``, ``BADQPOS``, ``BADQVEL``), and sets a
non-finite or huge control (over 1e10) to zero (``mjWARN_BADCTRL``), so such a run would go on
from another state or with another torque; the loop reads those warnings after every period and
ends the run there with :class:`~manipdyn.control.simulate.SimulationDiverged`, as manipdyn's own loop ends it
on a non-finite state.
"""

from __future__ import annotations

import contextlib
import math
import threading

import numpy as np

from .controllers import Controller

__all__ = ["integrate_mujoco", "mujoco_plant_model", "SIMULATORS", "INTEGRATOR", "MUJOCO_PLANTS"]

#: the MuJoCo plants (module docstring)
MUJOCO_PLANTS = ("file", "model")
#: MuJoCo's passive-force callback is one per process
_CALLBACK = threading.Lock()
#: id(model) -> the hook called before each step of that model (under _CALLBACK)
_HOOKS = {}

#: the simulators a closed-loop run can use
SIMULATORS = ("manipdyn", "mujoco")
#: MuJoCo's integrator in these runs (the scheme of manipdyn's own loop)
INTEGRATOR = "RK4"
#: MuJoCo's integrator for a plant too stiff for RK4 (module docstring)
STIFF_INTEGRATOR = "IMPLICITFAST"


def integrate_mujoco(log, watch, plant, controller, trajectory, q, qd, progress, mujoco_plant: str = "file",
                     integrator: str = INTEGRATOR) -> None:
    """The loop of :func:`manipdyn.control.simulate.simulate` with MuJoCo stepping ``plant``
    (``mujoco_plant``: module docstring); fills ``log`` in place (``log.substeps`` MuJoCo steps
    per control period)."""
    if getattr(log, "integrator", "rk4") == "rosenbrock":
        integrator = STIFF_INTEGRATOR
    with mujoco_plant_model(plant, log.dt / log.substeps, mujoco_plant, integrator) as (mj, model):
        _loop(mj, model, log, watch, controller, trajectory, q, qd, progress)


@contextlib.contextmanager
def mujoco_plant_model(plant, timestep: float, mujoco_plant: str = "file", integrator: str = INTEGRATOR):
    """``with mujoco_plant_model(arm, h, "model") as (mujoco, model):``: a fresh copy of ``arm``'s
    compiled MJCF stepping ``h`` s with ``integrator``, as the plant ``mujoco_plant`` (module
    docstring); for ``"model"`` with a friction law, the passive-force callback that applies the
    law beyond damping is installed (and the process's callback lock held) inside the block."""
    if mujoco_plant not in MUJOCO_PLANTS:
        raise ValueError(f"mujoco_plant: expected 'file' or 'model', got {mujoco_plant!r:.40}")
    engine = plant.engine("mujoco")
    mj, model = engine.simulation_model(timestep, integrator)
    if mujoco_plant == "model":
        model.opt.disableflags |= int(mj.mjtDisableBit.mjDSBL_CONSTRAINT)
    if mujoco_plant == "file" or plant.friction_model is None:
        yield mj, model
        return
    beyond = engine.friction_beyond_damping
    base = np.array(model.dof_damping, dtype=np.float64)
    if str(integrator).upper() == STIFF_INTEGRATOR:
        slope = _slope_beyond_damping(engine)

        def passive(m, d):                # the law beyond the damping set for this step
            d.qfrc_passive[:] -= beyond(d.qvel) + (base - m.dof_damping) * d.qvel

        def before_step(d):               # the friction's slope at the step's start, taken implicitly
            model.dof_damping[:] = base + np.maximum(slope(d.qvel), 0.0)
        _HOOKS[id(model)] = before_step
    else:
        def passive(m, d):                # the law beyond damping, at every evaluation
            d.qfrc_passive[:] -= beyond(d.qvel)
    with _CALLBACK:
        mj.set_mjcb_passive(passive)
        try:
            yield mj, model
        finally:
            mj.set_mjcb_passive(None)
            _HOOKS.pop(id(model), None)


def _slope_beyond_damping(engine):
    """``qd -> (n,)``: the diagonal of the friction law's ``dF/dqd`` beyond the MJCF's damping."""
    base = np.array(engine.simulation_model(1.0)[1].dof_damping, dtype=np.float64)

    def slope(qd):
        return np.diagonal(engine.friction_derivative(np.array(qd, dtype=np.float64))) - base
    return slope


def step_hook(model):
    """What to call with the data before each ``mj_step`` of ``model`` (the implicit friction's
    damping, :func:`mujoco_plant_model`), or None."""
    return _HOOKS.get(id(model))


#: MuJoCo's warnings of a run that went wrong: it zeroed a control, or reset its data after a non-finite or
#: huge acceleration, position or velocity (over 1e10), so the run would carry on from another state
BAD_WARNINGS = ("mjWARN_BADQACC", "mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADCTRL")


def bad_warnings(mj) -> list:
    """Indices into ``MjData.warning`` of :data:`BAD_WARNINGS`."""
    return [int(getattr(mj.mjtWarning, w)) for w in BAD_WARNINGS]


def _loop(mj, model, log, watch, controller, trajectory, q, qd, progress) -> None:
    Q, V, TAU, dt, N, n = log.q, log.qd, log.tau, log.dt, watch.N, len(q)
    m_sub = log.substeps
    d = mj.MjData(model)
    d.qpos[:], d.qvel[:] = q, qd
    mj.mj_forward(model, d)
    every = max(1, N // 100)
    bad = bad_warnings(mj)
    warned = d.warning
    hook = step_hook(model)
    if isinstance(controller, Controller) and controller.trajectory is trajectory:
        step = controller.step
        rows = (list(log.q_d), list(log.qd_d), list(log.qdd_d))
    else:
        step = rows = None
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(N):
            q, qd = d.qpos.copy(), d.qvel.copy()
            Q[k], V[k] = q, qd
            if step is None:
                tau = np.asarray(controller(k * dt, q, qd), dtype=np.float64)
            else:
                tau = np.asarray(step(k * dt, q, qd, rows[0][k], rows[1][k], rows[2][k]), dtype=np.float64)
            if tau.shape != (n,):
                raise ValueError(f"controller: returned shape {tau.shape}, expected ({n},)")
            watch.check_torque(k, tau)
            TAU[k] = tau
            d.ctrl[:] = tau
            for _ in range(m_sub):
                if hook is not None:
                    hook(d)
                mj.mj_step(model, d)
            if warned[bad[0]].number or warned[bad[1]].number or warned[bad[2]].number or warned[bad[3]].number:
                watch.fail(k + 1, "state", d.qvel, math.inf, "MuJoCo met a non-finite or huge control, acceleration, "
                           "position or velocity (over 1e10) and zeroed the control or reset its data")
            watch.check_state(k + 1, d.qpos, d.qvel)
            if progress is not None and (k + 1) % every == 0:
                progress(k + 1, N)
        q, qd = d.qpos.copy(), d.qvel.copy()
        Q[N], V[N] = q, qd
        tau = np.asarray(controller(N * dt, q, qd), dtype=np.float64)
        watch.check_torque(N, tau)
        TAU[N] = tau
    if progress is not None:
        progress(N, N)
