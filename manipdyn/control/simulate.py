"""Closed-loop simulation: a controller driving an arm, integrated by fixed-step RK4.

Layer 6 (control).

``simulate(arm, controller, trajectory, duration, dt=1e-3, plant=None)``.

Time stepping.  At each step ``t_k = k dt`` the controller is called once,
``tau_k = controller(t_k, q_k, qd_k)``, and that torque is held constant over
``[t_k, t_k + dt)`` (zero-order hold, as a digital controller sampling at
``1/dt`` does).  The plant's forward dynamics ``qdd = FD(q, qd, tau_k)`` (the
fast path, Pinocchio's ABA, friction included) is integrated over the step by
the classical 4th-order Runge-Kutta method, in ``m`` equal steps when the
plant is too stiff for one (:mod:`manipdyn.control.stiffness`: a light link
with friction; ``m = 1`` otherwise, and ``SimulationLog.substeps`` says which).
A plant too stiff for RK4 (over 100 steps per period) is stepped by a Rosenbrock
step with its friction implicit instead (:mod:`manipdyn.control.implicit`;
``SimulationLog.integrator`` says which).
So the integration error is O((dt/m)^4) for the given torque sequence; the
sampling itself (the hold) is part of the simulated system, not an error of
the integrator.

Divergence.  The run stops with :class:`SimulationDiverged` (a
``RuntimeError``) when a joint position leaves ``|q_i| <= max_position``
(default 100 rad, about 16 turns; or 100 m), a joint speed leaves
``|qd_i| <= max_velocity`` (default 1000 rad/s or m/s, far beyond any real
arm), or a torque or state is not finite.  The message says when (t, step)
and where (joint, quantity, value); the exception carries the log up to the
last good sample.  No NaN ever reaches the returned log.

Cost.  Inputs are validated once per run (the initial state, the reference at
every sample, the plant); the loop then calls the plant's unchecked forward
dynamics (``plant.pinocchio.unchecked``, Pinocchio's ABA with nothing around
it) and, for a :class:`manipdyn.control.Controller` bound to the simulated
trajectory, :meth:`Controller.step` with the precomputed reference, so no state
is re-validated and no trajectory re-evaluated per step.  What still comes
from outside each step, the controller's torque, is checked every step
(shape, dtype, finiteness); a non-finite state is caught at the end of every
step by the divergence bounds.  Any other callable controller, or a plant
without an unchecked Pinocchio engine, goes through its checked calls.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from .._support.state import as_state
from .._support.errors import StateError
from .controllers import Controller

__all__ = ["simulate", "SimulationLog", "SimulationDiverged",
           "DEFAULT_MAX_POSITION", "DEFAULT_MAX_VELOCITY"]

DEFAULT_MAX_POSITION = 100.0   # rad or m
DEFAULT_MAX_VELOCITY = 1000.0  # rad/s or m/s


class SimulationDiverged(RuntimeError):
    """The simulated arm ran away (unstable control or plant).

    Attributes: ``t`` (s) and ``step`` where it was detected, ``joint``
    (1-based, or None), ``quantity`` (``"q"``, ``"qd"``, ``"tau"`` or
    ``"state"``), ``value``, and ``log`` (a :class:`SimulationLog` up to the last
    finite, in-bounds sample).
    """

    def __init__(self, message, t, step, joint, quantity, value, log=None):
        super().__init__(message)
        self.t, self.step, self.joint = t, step, joint
        self.quantity, self.value, self.log = quantity, value, log


@dataclass
class SimulationLog:
    """The record of one run; arrays have one row per sample ``t_k = k dt``, k = 0..N.

    Attributes
    ----------
    t : (N+1,) s
    q, qd : (N+1, n)
        Plant state (rad or m, per second).
    q_d, qd_d, qdd_d : (N+1, n)
        The reference at the same times.
    tau : (N+1, n)
        Torque the controller commanded at ``t_k`` (after saturation), held
        over the following step; N m or N.
    dt : float
    controller, plant : str
        Names, for reports.
    joint_types : tuple of str
    wall_time : float
        Seconds the run took.
    substeps : int
        Integrator steps per control period (:mod:`manipdyn.control.stiffness`).
    integrator : str
        ``"rk4"``, or ``"rosenbrock"`` for a plant too stiff for RK4 (the friction stepped
        implicitly, :mod:`manipdyn.control.implicit`).
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    q_d: np.ndarray
    qd_d: np.ndarray
    qdd_d: np.ndarray
    tau: np.ndarray
    dt: float
    controller: str = ""
    plant: str = ""
    joint_types: tuple = ()
    wall_time: float = 0.0
    substeps: int = 1
    integrator: str = "rk4"

    @property
    def e(self) -> np.ndarray:
        """Tracking error ``q_d - q`` (N+1, n)."""
        return self.q_d - self.q

    @property
    def e_dot(self) -> np.ndarray:
        """Velocity error ``qd_d - qd`` (N+1, n)."""
        return self.qd_d - self.qd

    def _window(self, since):
        return slice(None) if since is None else self.t >= since - 1e-9 * max(1.0, abs(since))

    def rms_error(self, since=None) -> np.ndarray:
        """RMS of e per joint (n,), over samples with ``t >= since`` (all by default)."""
        e = self.e[self._window(since)]
        return np.sqrt(np.mean(e**2, axis=0))

    def max_error(self, since=None) -> np.ndarray:
        """``max |e|`` per joint (n,), over samples with ``t >= since``."""
        return np.max(np.abs(self.e[self._window(since)]), axis=0)

    def peak_torque(self, since=None) -> np.ndarray:
        """``max |tau|`` per joint (n,), over samples with ``t >= since``."""
        return np.max(np.abs(self.tau[self._window(since)]), axis=0)

    def summary(self, since=None) -> str:
        """A table: RMS and max error and peak torque per joint (units by joint type)."""
        rms, mx, pk = self.rms_error(since), self.max_error(since), self.peak_torque(since)
        head = f"{self.controller or 'controller'} on {self.plant or 'plant'}: " \
               f"{self.t[-1]:g} s at {1 / self.dt:g} Hz (" + self._stepper() + \
               f", zero-order hold), {self.wall_time:.2f} s wall"
        if since is not None:
            head += f"; errors over t >= {since:g} s"
        rows = [head, f"  {'joint':<6} {'RMS error':>12} {'max error':>12} {'peak torque':>14}"]
        for i in range(len(rms)):
            pr = self.joint_types[i] == "prismatic" if self.joint_types else False
            eu, tu = ("m", "N") if pr else ("rad", "N m")
            rows.append(f"  {i + 1:<6} {rms[i]:9.3e} {eu:<3}{'':1}{mx[i]:9.3e} {eu:<3}"
                        f"{'':1}{pk[i]:10.4g} {tu}")     # 4 significant digits: a wrist's 3e-4 N m too
        return "\n".join(rows)

    def _stepper(self) -> str:
        if self.integrator == "rk4":
            return "RK4" + (f", {self.substeps} steps per period" if self.substeps > 1 else "")
        from .implicit import describe

        if self.plant.endswith("(MuJoCo)"):              # simulate() names a MuJoCo run's plant so
            return f"MuJoCo's implicitfast (the friction's slope as damping), {self.substeps} steps per period"
        return describe(self.integrator, self.substeps)

    def truncated(self, k: int) -> "SimulationLog":
        """The first ``k`` samples."""
        return SimulationLog(self.t[:k], self.q[:k], self.qd[:k], self.q_d[:k], self.qd_d[:k],
                             self.qdd_d[:k], self.tau[:k], self.dt, self.controller, self.plant,
                             self.joint_types, self.wall_time, self.substeps, self.integrator)


def _reference(trajectory, t: np.ndarray, n: int):
    """The reference at all sample times: one vectorised call if the trajectory takes arrays."""
    try:
        ref = trajectory(t)
        if all(np.shape(r) == (len(t), n) for r in ref):
            return tuple(np.asarray(r, dtype=np.float64) for r in ref)
    except (TypeError, ValueError):
        pass
    rows = [trajectory(float(tk)) for tk in t]
    return tuple(np.array([r[i] for r in rows], dtype=np.float64).reshape(len(t), n) for i in range(3))



def _name(x) -> str:
    return getattr(x, "name", "") or getattr(x, "__name__", "") or type(x).__name__


def simulate(arm, controller, trajectory=None, duration=None, dt: float = 1e-3, plant=None,
             q0=None, qd0=None, max_position: float = DEFAULT_MAX_POSITION,
             max_velocity: float = DEFAULT_MAX_VELOCITY, progress=None, substeps=None,
             simulator: str = "manipdyn", mujoco_plant: str = "file", integrator=None) -> SimulationLog:
    """Simulate ``controller`` tracking ``trajectory`` on ``plant`` (default ``arm``).

    Parameters
    ----------
    arm : manipdyn.Arm
        The nominal arm (the plant unless ``plant`` is given).
    controller : callable
        ``tau = controller(t, q, qd)``.  If it has ``reset(trajectory)`` (every
        :class:`manipdyn.control.Controller` does) it is called first, binding
        the trajectory and clearing internal state.
    trajectory : callable, optional
        ``trajectory(t) -> (q_d, qd_d, qdd_d)``; default ``controller.trajectory``.
    duration : float, optional
        Simulated time, s; default the trajectory's ``t_end``.  The run has
        ``N = round(duration / dt)`` steps from t = 0.
    dt : float
        Step (and controller sampling period), s.
    plant : manipdyn.Arm, optional
        The arm actually simulated, e.g. ``arm.with_payload(...)`` (:meth:`manipdyn.model.arm.Arm.with_payload`).
    q0, qd0 : (n,), optional
        Initial state; default the reference at t = 0 (zero initial error).
    max_position, max_velocity : float
        Divergence bounds (module docstring).
    progress : callable, optional
        Called as ``progress(steps_done, steps_total)`` about a hundred times
        over the run, and once at its end.
    substeps : int, optional
        Integrator steps per control period; default as many as the plant needs
        along the reference (:func:`manipdyn.control.implicit.integration_plan`).
    integrator : None | "rk4" | "rosenbrock"
        Default (None): RK4, or for a plant too stiff for it (a light link with a steep
        friction) the Rosenbrock step with the friction implicit
        (:mod:`manipdyn.control.implicit`); the log's ``integrator`` says which ran.  With
        ``substeps`` given and no integrator, RK4.  With MuJoCo, ``"rosenbrock"`` steps MuJoCo's
        ``implicitfast`` integrator with the friction's slope as the joints' damping
        (:mod:`manipdyn.control.mjsim`).
    simulator : "manipdyn" | "mujoco"
        Who steps the plant: manipdyn's RK4 on the plant's forward dynamics (default), or
        MuJoCo's RK4 on the plant's MJCF with the torque as the actuators' control
        (:mod:`manipdyn.control.mjsim`; the ``mujoco`` extra).
    mujoco_plant : "file" | "model"
        With MuJoCo: the MJCF as MuJoCo loads it (limits and frictionloss as constraints), or
        the same plant as manipdyn's own run (constraints off, the whole friction law applied).

    Returns
    -------
    SimulationLog

    Raises
    ------
    SimulationDiverged
        When the state leaves the bounds or anything becomes non-finite.
    """
    t_wall = time.perf_counter()
    if simulator not in ("manipdyn", "mujoco"):
        raise ValueError(f"simulator: expected 'manipdyn' or 'mujoco', got {simulator!r:.40}")
    plant = arm if plant is None else plant
    trajectory, duration, dt, N = _check_arguments(arm, controller, trajectory, duration, dt, plant)
    n = arm.n
    t = np.arange(N + 1) * dt
    q_d, qd_d, qdd_d = _finite_reference(trajectory, t, n)
    q, qd = _initial_state(q_d, qd_d, q0, qd0, n)
    # once, checked: a model problem (a singular D) is named here, not met as a NaN in the loop
    plant.forward_dynamics(q, qd, np.zeros(n))
    integrator, substeps = _plan(plant, integrator, substeps, q_d, qd_d, qdd_d, dt, N)
    log = SimulationLog(t, np.empty((N + 1, n)), np.empty((N + 1, n)), q_d, qd_d, qdd_d,
                        np.empty((N + 1, n)), dt, _name(controller), plant.name or "plant",
                        tuple(plant.joint_types), substeps=int(substeps), integrator=integrator)
    watch = _Divergence(log, plant, N, dt, max_position, max_velocity)
    if simulator == "mujoco":
        from .mjsim import integrate_mujoco

        log.plant += " (MuJoCo)"
        integrate_mujoco(log, watch, plant, controller, trajectory, q, qd, progress, mujoco_plant)
    else:
        _integrate(log, watch, plant, controller, trajectory, q, qd, progress)
    log.wall_time = time.perf_counter() - t_wall
    return log


def _plan(plant, integrator, substeps, q_d, qd_d, qdd_d, dt, N):
    """``(integrator, substeps)`` of a run: as given, or as the plant needs along the reference."""
    from .implicit import INTEGRATORS, integration_plan, stiff_parts
    from .stiffness import MAX_SUBSTEPS, reference_samples

    if integrator is not None and integrator not in INTEGRATORS:
        raise ValueError(f"integrator: expected one of {', '.join(INTEGRATORS)}, got {integrator!r:.40}")
    if integrator == "rosenbrock" and stiff_parts(plant) is None:
        raise ValueError("integrator: 'rosenbrock' needs the plant's mass matrix and friction derivative")
    if substeps is None:
        i = reference_samples(N)
        plan = integration_plan(plant, q_d[i], qd_d[i], qdd_d[i], dt, integrator)
        return plan.integrator, plan.substeps
    if isinstance(substeps, bool) or not isinstance(substeps, (int, np.integer)) or substeps < 1:
        raise ValueError(f"substeps: expected an integer >= 1, got {substeps!r}")
    if substeps > MAX_SUBSTEPS:
        raise ValueError(f"substeps: at most {MAX_SUBSTEPS} Runge-Kutta steps per control period, got "
                         f"{substeps}; a shorter dt is the way to a finer integration")
    return integrator or "rk4", int(substeps)


def _check_arguments(arm, controller, trajectory, duration, dt, plant):
    """Blame the argument that does not fit the arm, before anything uses it.

    Returns ``(trajectory, duration, dt, N)``, the trajectory and duration
    filled in from the controller and the trajectory when not given.
    """
    n = arm.n
    if plant.n != n:
        raise ValueError(f"plant: has {plant.n} joints, the arm {n}")
    if getattr(controller, "n", n) != n:
        raise ValueError(f"controller: built for an arm with {controller.n} joints, the arm has {n}")
    if trajectory is None:
        trajectory = getattr(controller, "trajectory", None)
        if trajectory is None:
            raise ValueError("trajectory: none given and the controller has none")
    if getattr(trajectory, "n", n) != n:
        raise ValueError(f"trajectory: has {trajectory.n} joints, the arm {n}")
    if hasattr(controller, "reset"):
        controller.reset(trajectory)
    if duration is None:
        duration = getattr(trajectory, "t_end", None)
        if duration is None:
            raise ValueError("duration: required for a trajectory without t_end")
    dt, duration = float(dt), float(duration)
    if not (dt > 0 and math.isfinite(dt)):
        raise ValueError(f"dt: must be a positive number of seconds, got {dt!r}")
    if not (duration > 0 and math.isfinite(duration)):
        raise ValueError(f"duration: must be a positive number of seconds, got {duration!r}")
    return trajectory, duration, dt, max(1, int(round(duration / dt)))


def _finite_reference(trajectory, t, n):
    """The reference ``(q_d, qd_d, qdd_d)``, each (N + 1, n), refused where not finite."""
    q_d, qd_d, qdd_d = _reference(trajectory, t, n)
    for name, ref in (("q_d", q_d), ("qd_d", qd_d), ("qdd_d", qdd_d)):
        if not np.all(np.isfinite(ref)):
            k = int(np.argwhere(~np.isfinite(ref))[0][0])
            raise ValueError(f"trajectory: {name} at t = {t[k]:.6g} s is not finite")
    return q_d, qd_d, qdd_d


def _initial_state(q_d, qd_d, q0, qd0, n):
    """``(q, qd)`` at t = 0: the given ones, or the reference's (zero initial error)."""
    q = (q_d[0] if q0 is None else as_state(q0, "q0", n)).astype(np.float64, copy=True)
    qd = (qd_d[0] if qd0 is None else as_state(qd0, "qd0", n)).astype(np.float64, copy=True)
    if q.shape != (n,) or qd.shape != (n,):
        raise ValueError(f"q0, qd0: expected shape ({n},)")
    return q, qd                     # native float64: as_state / astype made them so


class _Divergence:
    """The divergence bounds of a run, and the :class:`SimulationDiverged` that ends it."""

    def __init__(self, log, plant, N, dt, max_position, max_velocity):
        self.log, self.plant, self.N, self.dt = log, plant, N, dt
        self.max_position, self.max_velocity = max_position, max_velocity
        self.pmax2, self.vmax2 = max_position**2, max_velocity**2

    def fail(self, k, quantity, values, bound, why):
        """Raise :class:`SimulationDiverged` at step ``k``, naming the joint when one is at fault."""
        dt, log = self.dt, self.log
        bad = ~np.isfinite(values) if why == "not finite" else np.abs(values) > bound
        j = int(np.argmax(bad)) if bad.any() else None
        unit = {"q": ("rad", "m"), "qd": ("rad/s", "m/s"), "tau": ("N m", "N")}.get(quantity, ("", ""))
        if j is not None:
            u = unit[1] if self.plant.joint_types[j] == "prismatic" else unit[0]
            where = f": joint {j + 1} {quantity} = {values[j]:.6g} {u}"
            where += " is not finite" if why == "not finite" else f" beyond the bound {bound:g}"
        else:
            where = f": {why}"
        kept = f"the log up to t = {(k - 1) * dt:.6g} s is in .log" if k > 0 else "nothing was logged"
        msg = (f"simulation diverged at t = {k * dt:.6g} s (step {k} of {self.N}, {log.controller} on "
               f"{log.plant}){where}. The controller or the plant is unstable; {kept}")
        raise SimulationDiverged(msg, t=k * dt, step=k, joint=None if j is None else j + 1,
                                 quantity=quantity, value=None if j is None else float(values[j]),
                                 log=log.truncated(k))

    def check_state(self, k, q, qd):
        """Fail when q or qd left the bounds or is not finite (one dot product when fine)."""
        if q.dot(q) <= self.pmax2 and qd.dot(qd) <= self.vmax2:
            return
        for name, x, b in (("q", q, self.max_position), ("qd", qd, self.max_velocity)):
            if not np.all(np.isfinite(x)):
                self.fail(k, name, x, b, "not finite")
            if np.any(np.abs(x) > b):
                self.fail(k, name, x, b, "bound")

    def check_torque(self, k, tau):
        """Fail when the controller's torque is not finite."""
        if not math.isfinite(tau.dot(tau)) and not np.all(np.isfinite(tau)):
            self.fail(k, "tau", tau, math.inf, "not finite")


def rk4_step(fd, q, qd, tau, h, h2, h6):
    """One classical Runge-Kutta step of ``qdd = fd(q, qd, tau)`` with ``tau`` held: ``(q, qd)`` after
    ``h`` s (``h2 = h / 2``, ``h6 = h / 6``); the arrays may carry a leading batch axis."""
    a1 = fd(q, qd, tau)
    v2 = qd + h2 * a1
    a2 = fd(q + h2 * qd, v2, tau)
    v3 = qd + h2 * a2
    a3 = fd(q + h2 * v2, v3, tau)
    v4 = qd + h * a3
    a4 = fd(q + h * v3, v4, tau)
    return q + h6 * (qd + 2.0 * (v2 + v3) + v4), qd + h6 * (a1 + 2.0 * (a2 + a3) + a4)


def _stepper(integrator, plant, fd, h, h2, h6):
    """``step(q, qd, tau) -> (q, qd)`` over ``h`` s: RK4, or the Rosenbrock step (friction implicit)."""
    if integrator == "rosenbrock":
        from .implicit import rosenbrock_step, stiff_parts

        mass, fric = stiff_parts(plant)
        return lambda q, qd, tau: rosenbrock_step(fd, mass, fric, q, qd, tau, h)
    return lambda q, qd, tau: rk4_step(fd, q, qd, tau, h, h2, h6)


def _integrate(log, watch, plant, controller, trajectory, q, qd, progress) -> None:
    """The fixed-step RK4 loop with the torque held over each step; fills ``log`` in place.

    States were validated once, before the loop; inside it the plant's
    unchecked forward dynamics and the controller's :meth:`Controller.step`
    (with the precomputed reference rows) are called when available.
    """
    Q, V, TAU, dt, N, n = log.q, log.qd, log.tau, log.dt, watch.N, len(q)
    every = max(1, N // 100)
    unchecked = getattr(getattr(plant, "pinocchio", None), "unchecked", None)
    fd = plant.forward_dynamics if unchecked is None else unchecked.forward_dynamics
    if isinstance(controller, Controller) and controller.trajectory is trajectory:
        step = controller.step              # the reference comes from the rows below
        rows = (list(log.q_d), list(log.qd_d), list(log.qdd_d))
    else:
        step = rows = None
    m = log.substeps
    h = dt / m                               # m == 1: exactly dt, the arithmetic it always had
    h2, h6 = 0.5 * h, h / 6.0
    stepper = _stepper(log.integrator, plant, fd, h, h2, h6)
    # Non-finite values are detected below and end the run with SimulationDiverged,
    # so numpy's overflow and invalid-value warnings would only repeat it.
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(N):
            Q[k] = q
            V[k] = qd
            if step is None:
                tau = np.asarray(controller(k * dt, q, qd), dtype=np.float64)
            else:
                tau = np.asarray(step(k * dt, q, qd, rows[0][k], rows[1][k], rows[2][k]),
                                 dtype=np.float64)
            if tau.shape != (n,):
                raise ValueError(f"controller: returned shape {tau.shape}, expected ({n},)")
            watch.check_torque(k, tau)
            TAU[k] = tau
            for _ in range(m):       # the torque is held over the whole period
                try:
                    q, qd = stepper(q, qd, tau)
                except (StateError, np.linalg.LinAlgError):   # a stage went non-finite, the step blew up
                    watch.fail(k + 1, "state", qd, math.inf, "an intermediate Runge-Kutta stage is not finite")
            watch.check_state(k + 1, q, qd)
            if progress is not None and (k + 1) % every == 0:
                progress(k + 1, N)
        Q[N] = q
        V[N] = qd
        tau = np.asarray(controller(N * dt, q, qd), dtype=np.float64)
        watch.check_torque(N, tau)
        TAU[N] = tau
    if progress is not None:
        progress(N, N)
