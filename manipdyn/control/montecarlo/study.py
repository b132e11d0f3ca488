"""A study: what to simulate, as a small value that travels to any worker.

Layer 6 (control: montecarlo).

A :class:`Study` holds the arm as *model text* (its TOML model file, or its
URDF text and tip), the controllers, the path, the distributions and the
seed.  :func:`run_chunk` is a pure function of ``(study, run indices)``: any
worker that receives the two computes the same numbers, bit for bit, so a
chunk lost with its worker is simply computed again, and the result does not
depend on how the runs were chunked or where they ran.

Replaying one run (e.g. the worst of a study) alone, with
:func:`manipdyn.simulate`::

    setup = study.setup(run=17, controller="ct")
    log = md.simulate(**setup.simulate_kwargs())      # what the study ran
    # or simply: log = study.replay(17, "ct")

A study in MuJoCo (``simulator="mujoco"``) draws the same plants from the same seeds; each
becomes an arm with an MJCF (:func:`.plant.plant_arm`) and every run is stepped by MuJoCo
(:mod:`manipdyn.control.mjsim`), one run at a time: ``mujoco_plant="model"`` (the default here)
is the plant manipdyn simulates, constraints off and the whole friction law applied, so the two
simulators' runs differ by how each evaluates the dynamics only; ``"file"`` is the MJCF as
MuJoCo loads it (Coulomb friction as ``frictionloss``, MuJoCo's soft constraint).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from ..controllers import Controller
from ..mjsim import MUJOCO_PLANTS, SIMULATORS      # who steps a study's plants, and which plant
from ...check.scale import arm_from_text, model_text
from .distributions import Distributions, draw
from .diverged import cause, explain, runaway
from .plant import Plant, make_plant, plant_arm

__all__ = ["Study", "RunSetup", "TorqueNoise", "run_chunk", "CONTROLLER_KEYS", "model_text"]

#: controller keys of a study, in report order (those of ``manipdyn track``)
CONTROLLER_KEYS = ("pd", "pdg", "ct", "adaptive", "lqr")


class TorqueNoise(Controller):
    """A controller whose torque reaches the joints with additive noise.

    ``tau_applied(t_k) = controller(t_k, q, qd) + noise[k]``, ``k = round(t / dt)``,
    held over the step like the commanded torque.  A
    :class:`manipdyn.control.Controller` itself (``step``, ``reset``,
    ``trajectory``), so :func:`manipdyn.simulate` keeps its fast loop.
    """

    def __init__(self, controller, noise: np.ndarray, dt: float):  # noqa: D107 (no super: wraps)
        self.inner = controller
        self.noise = np.asarray(noise, dtype=np.float64)
        self.dt = float(dt)
        self.name = controller.name
        self.n = controller.n
        self.arm = controller.arm
        self.tau_max = controller.tau_max

    @property
    def trajectory(self):
        return self.inner.trajectory

    def reset(self, trajectory=None) -> None:
        self.inner.reset(trajectory)

    def _row(self, t) -> np.ndarray:
        return self.noise[min(int(round(t / self.dt)), len(self.noise) - 1)]

    def step(self, t, q, qd, q_d, qd_d, qdd_d):
        return self.inner.step(t, q, qd, q_d, qd_d, qdd_d) + self._row(t)

    def __call__(self, t, q, qd):
        return self.inner(t, q, qd) + self._row(t)


@dataclass(frozen=True)
class RunSetup:
    """Everything :func:`manipdyn.simulate` needs to replay one run of a study."""

    arm: object
    controller: object
    trajectory: object
    plant: Plant
    q0: np.ndarray
    duration: float
    dt: float
    substeps: int = 1
    #: ``"rk4"``, or ``"rosenbrock"`` for a plant too stiff for RK4 (:mod:`manipdyn.control.implicit`)
    integrator: str = "rk4"
    #: who steps the plant, and with MuJoCo which plant and the plant as an arm (:func:`.plant.plant_arm`)
    simulator: str = "manipdyn"
    mujoco_plant: str = "model"
    mujoco_arm: object = None

    def simulate_kwargs(self) -> dict:
        """The keyword arguments of :func:`manipdyn.simulate` that replay this run as the study ran it."""
        kw = {"arm": self.arm, "controller": self.controller, "trajectory": self.trajectory,
              "duration": self.duration, "dt": self.dt, "plant": self.plant, "q0": self.q0,
              "substeps": self.substeps, "integrator": self.integrator}
        if self.simulator == "mujoco":
            kw.update(plant=self.mujoco_arm, simulator="mujoco", mujoco_plant=self.mujoco_plant)
        return kw


@dataclass(frozen=True)
class Study:
    """One seeded Monte-Carlo study (build it with :func:`manipdyn.control.montecarlo.study`).

    Attributes
    ----------
    model : tuple
        :func:`model_text` of the nominal arm.
    runs, seed : int
    controllers : tuple of str
        Keys among :data:`CONTROLLER_KEYS`.
    duration, dt : float
        s; each run simulates the ``track`` demo path over ``duration`` at ``1/dt`` Hz.
    distributions : Distributions
    tau_max : tuple of float or None
        Torque limits of every controller (N m or N, ``inf`` for none); None:
        the model's own limits (URDF ``effort``), or none.
    bandwidth, gamma : float
        The demo controllers' tuning (``manipdyn track``).
    plants : IdentifiedPlants or None
        Draw every run's plant from an identification (:mod:`.identified`) instead of
        the link scale, payload and friction of :attr:`distributions` (which must then
        be 0; the start offset and torque noise still apply).  None: the distributions.
    simulator : "manipdyn" | "mujoco"
        Who steps the plants (module docstring): manipdyn's RK4 (default) or MuJoCo's, on each
        plant's MJCF.  The draws are the same either way.
    mujoco_plant : "model" | "file"
        With MuJoCo: the plant manipdyn simulates (default) or the MJCF as MuJoCo loads it.
    """

    model: tuple
    runs: int
    seed: int = 0
    controllers: tuple = CONTROLLER_KEYS
    duration: float = 2.0
    dt: float = 1e-3
    distributions: Distributions = field(default_factory=Distributions)
    tau_max: tuple | None = None
    bandwidth: float = 10.0
    gamma: float = 10.0
    plants: object = None
    simulator: str = "manipdyn"
    mujoco_plant: str = "model"

    def __post_init__(self):
        if self.simulator not in SIMULATORS:
            raise ValueError(f"simulator: expected 'manipdyn' or 'mujoco', got {self.simulator!r:.40}")
        if self.mujoco_plant not in MUJOCO_PLANTS:
            raise ValueError(f"mujoco_plant: expected 'model' or 'file', got {self.mujoco_plant!r:.40}")
        if isinstance(self.runs, bool) or not isinstance(self.runs, (int, np.integer)) or self.runs < 1:
            raise ValueError(f"runs: expected a positive integer, got {self.runs!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ValueError(f"seed: expected an integer >= 0, got {self.seed!r}")
        object.__setattr__(self, "runs", int(self.runs))
        object.__setattr__(self, "seed", int(self.seed))
        ctrl = tuple(self.controllers)
        bad = [c for c in ctrl if c not in CONTROLLER_KEYS]
        if not ctrl or bad or len(set(ctrl)) != len(ctrl):
            raise ValueError(f"controllers: expected distinct keys among {', '.join(CONTROLLER_KEYS)}, "
                             f"got {list(ctrl)}")
        object.__setattr__(self, "controllers", ctrl)
        for name in ("duration", "dt", "bandwidth"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: must be a positive number, got {v!r}")
        if not (math.isfinite(self.gamma) and self.gamma >= 0):
            raise ValueError(f"gamma: must be >= 0, got {self.gamma!r}")
        if self.dt > self.duration:
            raise ValueError(f"dt: must be at most duration ({self.duration:g} s), got {self.dt:g}")
        if self.plants is not None:
            d = self.distributions
            if d.payload_mass or d.link_scale or d.friction_viscous or d.friction_coulomb:
                raise ValueError("distributions: with plants from an identification, payload_mass, "
                                 "link_scale, friction_viscous and friction_coulomb must be 0 (the "
                                 "identification's distribution replaces them)")

    # -- the arm and the run's pieces (cached per process) ---------------------------
    @property
    def arm(self):
        """The nominal arm, rebuilt from ``model`` (once per process)."""
        return arm_from_text(*self.model)

    @property
    def steps(self) -> int:
        """Steps per run, ``round(duration / dt)``, as :func:`manipdyn.simulate` takes them."""
        return max(1, int(round(self.duration / self.dt)))

    def path(self):
        """The reference: the ``track`` demo path over :attr:`duration`."""
        return _path(self.model, self.duration)

    def controller(self, key: str):
        """A new demo controller ``key`` on the nominal arm (as ``manipdyn track`` builds it).

        The LQR's gains are computed here, from the nominal arm, the path and
        ``dt`` only (never a plant): the same numbers in every process.
        """
        from ..demo import make_controller

        arm = self.arm
        lim = None if self.tau_max is None else np.array(self.tau_max, dtype=np.float64)
        return make_controller(key, arm, self.bandwidth, self.gamma, tau_max=lim, path=self.path(),
                               dt=self.dt)

    def draw(self, run: int):
        """Run ``run``'s variations (:class:`RunDraw`)."""
        self._check_run(run)
        d = self.distributions
        return draw(d, self.seed, run, self.arm.joint_types, self.steps + 1, self.sizes() if d.sized else None)

    def sizes(self):
        """The nominal arm's scales on the path (:class:`.sizing.Sizes`), to which the sized draws of
        :attr:`distributions` are fractions (computed once per process)."""
        return _sizes(self.model, float(self.duration), float(self.dt), tuple(self.distributions.payload_com))

    def bounds(self):
        """The absolute bounds of this study's draws on its arm (:meth:`.Distributions.bounds`)."""
        d = self.distributions
        return d.bounds(self.sizes() if d.sized else None)

    def plant(self, run: int) -> Plant:
        """Run ``run``'s plant."""
        if self.plants is not None:
            return self.plants.plant(self.arm, self.draw(run), self.seed)
        return make_plant(self.arm, self.draw(run))

    def setup(self, run: int, controller: str, _cache: dict | None = None) -> RunSetup:
        """What :func:`manipdyn.simulate` needs to replay run ``run`` of ``controller``."""
        if controller not in self.controllers:
            raise ValueError(f"controller: expected one of {', '.join(self.controllers)}, got {controller!r}")
        plant = self.plant(run)
        path = self.path()
        ctrl = _cache[controller] if _cache is not None else self.controller(controller)
        if self.distributions.noisy:
            ctrl = TorqueNoise(ctrl, plant.draw.torque_noise, self.dt)
        q0 = path(0.0)[0] + plant.draw.q0_offset
        key = ("substeps", int(run))              # one run's plant, whichever controller drives it
        if _cache is None or key not in _cache:
            plan = self.integration(plant)
            if _cache is not None:
                _cache[key] = plan
        else:
            plan = _cache[key]
        arm = None
        if self.simulator == "mujoco":
            key = ("mujoco_arm", int(run))      # one plant arm (one compiled MJCF) per run
            arm = _cache.get(key) if _cache is not None else None
            if arm is None:
                arm = plant_arm(self.arm, plant)
                if _cache is not None:
                    _cache[key] = arm
        return RunSetup(self.arm, ctrl, path, plant, q0, float(self.duration), float(self.dt), plan.substeps,
                        plan.integrator, self.simulator, self.mujoco_plant, arm)

    def integration(self, plant):
        """The :class:`~manipdyn.control.implicit.IntegrationPlan` of ``plant`` along the path, as
        :func:`manipdyn.simulate` chooses it: RK4, or the Rosenbrock step for a plant too stiff for it."""
        from ..implicit import integration_plan

        return integration_plan(plant, *_reference_samples(self.model, float(self.duration), float(self.dt)),
                                self.dt)

    def substeps(self, plant) -> int:
        """Runge-Kutta steps per period for ``plant`` along the path, as :func:`manipdyn.simulate`
        chooses them (:func:`manipdyn.control.stiffness.rk4_substeps`): a run's own plant decides."""
        from ..stiffness import rk4_substeps

        return rk4_substeps(plant, *_reference_samples(self.model, float(self.duration), float(self.dt)),
                            self.dt)[0]

    def sampled_loop(self, setup: RunSetup) -> float:
        """``dt |eig(D_plant^-1 K_d)|``, largest over the reference samples the stiffness check
        reads, for ``setup``'s plant and controller (:func:`manipdyn.control.stiffness.sampled_loop_rate`):
        over 2, the controller's damping is too fast for the period on this plant (:mod:`.diverged`)."""
        from ..stiffness import reference_samples, sampled_loop_rate

        q, qd, qdd = _reference_samples(self.model, float(self.duration), float(self.dt))
        t = reference_samples(self.steps) * float(self.dt)
        return float(self.dt) * sampled_loop_rate(setup.plant, setup.controller, t, q, qd, qdd)

    def torque_scale(self) -> float:
        """N m (N): the largest torque of the nominal arm's inverse dynamics on the reference samples
        (what :func:`.diverged.runaway` measures a run's torques against)."""
        return _torque_scale(self.model, float(self.duration), float(self.dt))

    def replay(self, run: int, controller: str):
        """Simulate run ``run`` of ``controller`` alone: the study's :class:`SimulationLog`
        (stepped by the study's simulator).

        Raises :class:`manipdyn.control.SimulationDiverged` if that run diverged.
        """
        from ..simulate import simulate

        return simulate(**self.setup(run, controller).simulate_kwargs())

    def _check_run(self, run) -> None:
        if isinstance(run, bool) or not isinstance(run, (int, np.integer)) or not 0 <= run < self.runs:
            raise ValueError(f"run: expected an integer in [0, {self.runs}), got {run!r}")

    def to_dict(self) -> dict:
        """The study's definition, for reports (the model by name, not its text)."""
        return {"model": self.model[3], "runs": self.runs, "seed": self.seed,
                "controllers": list(self.controllers), "duration": self.duration, "dt": self.dt,
                "distributions": self.distributions.to_dict(),
                **({"sizes": self.sizes().to_dict(), "bounds": _bounds_dict(self.bounds())}
                   if self.distributions.sized else {}),
                "tau_max": None if self.tau_max is None else list(self.tau_max),
                "bandwidth": self.bandwidth, "gamma": self.gamma, "simulator": self.simulator,
                **({"mujoco_plant": self.mujoco_plant} if self.simulator == "mujoco" else {}),
                **({} if self.plants is None else {"plants": self.plants.to_dict(self.seed, self.runs)})}


def _bounds_dict(b) -> dict:
    return {"payload_mass": float(b.payload_mass), **{k: np.asarray(getattr(b, k), dtype=float).tolist()
                                                      for k in ("viscous", "coulomb", "noise")}}


@functools.lru_cache(maxsize=8)
def _path(model: tuple, duration: float):
    from ..demo import demo_path

    return demo_path(arm_from_text(*model), duration)


@functools.lru_cache(maxsize=8)
def _reference_samples(model: tuple, duration: float, dt: float):
    """``(q_d, qd_d, qdd_d)`` at the samples :func:`~manipdyn.control.stiffness.rk4_substeps`
    reads, taken from the reference as :func:`manipdyn.simulate` evaluates it (all N + 1 times)."""
    from ..stiffness import reference_samples

    N = max(1, int(round(duration / dt)))
    i = reference_samples(N)
    ref = _path(model, duration)(np.arange(N + 1) * dt)
    out = tuple(np.asarray(r, dtype=np.float64)[i] for r in ref)
    for a in out:
        a.setflags(write=False)
    return out


@functools.lru_cache(maxsize=8)
def _sizes(model: tuple, duration: float, dt: float, payload_com: tuple):
    from .sizing import arm_sizes

    return arm_sizes(arm_from_text(*model), *_reference_samples(model, duration, dt), payload_com)


@functools.lru_cache(maxsize=8)
def _torque_scale(model: tuple, duration: float, dt: float) -> float:
    q, qd, qdd = _reference_samples(model, duration, dt)
    return float(np.max(np.abs(arm_from_text(*model).inverse_dynamics(q, qd, qdd))))


# -- one run, and a chunk of runs ------------------------------------------------------
def _metrics(log, lim, noise) -> dict:
    """RMS over time of |e| (rad), max |e_i| (rad), max |tau_i| (N m), saturated."""
    if len(log.t) == 0:
        return {"rms_error": None, "max_error": None, "peak_torque": None, "saturated": False}
    e = log.e
    rms = float(np.sqrt(np.mean(np.einsum("ij,ij->i", e, e))))
    out = {"rms_error": rms, "max_error": float(np.max(np.abs(e))),
           "peak_torque": float(np.max(np.abs(log.tau)))}
    sat = False
    if lim is not None:
        commanded = log.tau
        if noise is not None:
            commanded = commanded - noise[:len(commanded)]
        # a saturated torque equals the limit; the noise was added and removed
        # again, which moves it by at most a few ulps of the torque
        sat = bool(np.any(np.abs(commanded) >= lim * (1.0 - 1e-9)))
    out["saturated"] = sat
    return out


def run_one(study: Study, run: int, key: str, cache: dict) -> dict:
    """Simulate run ``run`` of controller ``key``: one ``per_run`` record."""
    from ..simulate import SimulationDiverged, simulate

    setup = study.setup(run, key, cache)
    try:
        log = simulate(**setup.simulate_kwargs())
        diverged = False
    except SimulationDiverged as exc:
        log, diverged = exc.log, True
    return _record(study, setup, key, log, diverged)


def _record(study: Study, setup: RunSetup, key: str, log, diverged: bool) -> dict:
    """One ``per_run`` record; a run that finished but ran away (:func:`.diverged.runaway`) is diverged."""
    ctrl = setup.controller
    m = _metrics(log, ctrl.tau_max, ctrl.noise if isinstance(ctrl, TorqueNoise) else None)
    ran_away = not diverged and runaway(log, np.diff(study.arm.qlim, axis=1)[:, 0], study.torque_scale())
    loop = study.sampled_loop(setup)
    return {"run": int(setup.plant.draw.run), "controller": key, "rms_error": m["rms_error"],
            "max_error": m["max_error"], "peak_torque": m["peak_torque"],
            "diverged": diverged or ran_away, "saturated": m["saturated"], "substeps": int(log.substeps),
            "integrator": log.integrator,
            "sampled_loop": loop, "cause": cause(loop, diverged, ran_away),
            "why": explain(study, setup, key, log, diverged, ran_away, loop)}


def run_many(study: Study, runs, key: str, cache: dict) -> list:
    """Runs ``runs`` of controller ``key`` stepped together (:func:`simulate_lockstep`): records;
    in MuJoCo, one run after another (:func:`run_one`)."""
    from .lockstep import simulate_lockstep

    if study.simulator == "mujoco":
        return [run_one(study, int(r), key, cache) for r in runs]
    setups = [study.setup(int(r), key, cache) for r in runs]
    rk4 = [i for i, s in enumerate(setups) if s.integrator == "rk4"]
    out = [run_one(study, int(r), key, cache) if s.integrator != "rk4" else None    # a stiff plant: alone
           for r, s in zip(runs, setups)]
    for i, (log, diverged) in zip(rk4, simulate_lockstep([setups[i] for i in rk4])):
        out[i] = _record(study, setups[i], key, log, diverged)
    return out


def run_chunk(study: Study, runs) -> dict:
    """Simulate runs ``runs`` (indices) of every controller: ``{run: [record per controller]}``.

    A pure function of its arguments (module docstring).  Also returns, under
    the key ``"timing"``, the seconds spent and the process that spent them.
    """
    import os
    import socket
    import time

    t0 = time.perf_counter()
    cache = {key: study.controller(key) for key in study.controllers}
    runs = [int(r) for r in runs]
    by_key = {key: run_many(study, runs, key, cache) for key in study.controllers}
    out = {r: [by_key[key][j] for key in study.controllers] for j, r in enumerate(runs)}
    out["timing"] = {"seconds": time.perf_counter() - t0, "host": socket.gethostname(), "pid": os.getpid()}
    return out
