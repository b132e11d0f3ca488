"""Monte-Carlo robustness studies of the tracking controllers, locally or on Dask.

Layer 6 (control: montecarlo).

A study answers: over all the arms this could really be (an undeclared
payload, inertias off by 20 %, friction, a start off the path, torque noise),
how large does each controller's tracking error get, and how often does it
fail?  Each run draws its plant from a seed derived from (study seed, run
index) only, so a study is reproducible bit for bit wherever it runs, and any
run can be replayed alone with :func:`manipdyn.simulate`.

Example::

    import manipdyn as md
    from manipdyn.control import montecarlo as mc

    study = mc.study(md.load("puma560"), runs=200, seed=1)
    report = mc.run(study)                       # every core of this machine
    # report = mc.run(study, scheduler="tcp://10.0.0.5:8786")   # a Dask cluster
    print(report)
    log = study.replay(report.worst("ct")[0], "ct")    # the worst run, alone

The distributions are :class:`Distributions` (defaults documented there and
in ``manipdyn montecarlo --help``), or the plants are drawn from an
identification's uncertainty: ``study(arm, runs, plants="F.json")``
(:mod:`.identified`).
"""

from __future__ import annotations

from .distributions import ABSOLUTE_DEFAULTS, DISTRIBUTIONS_HELP, RELATIVE_DEFAULTS, Distributions, RunDraw
from .execute import MissingExtraError, run
from .identified import IdentifiedPlants, load_identified
from .plant import Plant, make_plant
from .plot import plot_report
from .report import StudyReport
from .study import CONTROLLER_KEYS, RunSetup, Study, TorqueNoise, model_text
from ...check.scale import arm_from_text

__all__ = ["study", "run", "Study", "StudyReport", "Distributions", "RunDraw", "RunSetup", "Plant",
           "make_plant", "plot_report", "TorqueNoise", "CONTROLLER_KEYS", "DISTRIBUTIONS_HELP", "MissingExtraError",
           "model_text", "check_study_size", "IdentifiedPlants", "load_identified", "ABSOLUTE_DEFAULTS",
           "RELATIVE_DEFAULTS"]


#: slowest controller bandwidth of a study, rad/s
MIN_BANDWIDTH = 1e-3


def check_study_size(runs, controllers: int, duration: float, dt: float, bandwidth: float,
                     cli: bool = False) -> None:
    """Refuse a study beyond :data:`manipdyn.limits.MAX_RUN_STEPS` (steps of one run),
    :data:`~manipdyn.limits.MAX_STUDY_STEPS` (runs x controllers x steps) or
    :data:`~manipdyn.limits.MAX_BANDWIDTH`; the ModelError (a ValueError) says how to
    raise the limit (``cli=True``: for one command-line run too)."""
    import math

    from ..._support import limits
    from ..._support.errors import ModelError

    for name, v in (("duration", duration), ("dt", dt), ("bandwidth", bandwidth)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ModelError(f"{name}: expected a positive finite number, got {v!r}")
    o = "--" if cli else ""
    limits.check_count(duration, f"{o}duration", "the demo path's duration (s)", "MAX_DEMO_DURATION", cli)
    steps = duration / dt
    if not math.isfinite(steps):
        raise ModelError(f"{o}duration / {o}dt: {duration!r} s at {dt!r} s is not a finite number of steps")
    steps = math.ceil(steps - 1e-9)
    limits.check_count(steps, f"{o}duration / {o}dt", "the number of steps of one run", "MAX_RUN_STEPS", cli)
    limits.check_count(runs * controllers * steps, f"{o}runs x {o}controllers x steps",
                       "the number of steps of the study", "MAX_STUDY_STEPS", cli)
    limits.check_count(bandwidth, f"{o}bandwidth", "the bandwidth (rad/s)", "MAX_BANDWIDTH", cli)
    if bandwidth < MIN_BANDWIDTH:   # the gains (bandwidth^2 D_ii) underflow: no controller at all
        raise ModelError(f"{o}bandwidth: expected at least {MIN_BANDWIDTH:g} rad/s (a loop slower than that "
                         f"tracks nothing over a demo path), got {bandwidth!r}")


def study(arm, runs: int, seed: int = 0, controllers=CONTROLLER_KEYS, duration: float = 2.0,
          dt: float = 1e-3, distributions: Distributions | None = None, tau_max=None,
          bandwidth: float = 10.0, gamma: float = 10.0, plants=None, simulator: str = "manipdyn",
          mujoco_plant: str = "model") -> Study:
    """Define a study of ``runs`` runs on ``arm`` (a DH or URDF arm).

    Parameters
    ----------
    arm : manipdyn.Arm or str
        The nominal arm: the controllers' model, and the plant before variation (a bundled
        model name or a file path is loaded with :func:`manipdyn.load`).
    runs, seed : int
        Number of runs; study seed (run k uses ``SeedSequence(seed, spawn_key=(k,))``).
    controllers : sequence of str
        Among ``"pd"``, ``"pdg"`` (PD + gravity), ``"ct"`` (computed torque),
        ``"adaptive"`` (Slotine-Li), ``"lqr"`` (time-varying LQR along the path,
        its gains from the nominal arm only), tuned as ``manipdyn track`` tunes them.
    duration, dt : float
        s; the ``track`` demo path over ``duration``, simulated at ``1/dt`` Hz.
    distributions : Distributions, optional
        Default ``Distributions()`` (:class:`Distributions`).
    tau_max : float or (n,), optional
        Torque limits of every controller, N m (N); default the model's own.
    bandwidth, gamma : float
        Controller bandwidth (rad/s) and adaptation gain.
    plants : str, os.PathLike or IdentifiedPlants, optional
        Draw the plants from an identification: a base model JSON file (``manipdyn identify
        --base-json``, as ``manipdyn montecarlo --plants-from`` takes it) or what
        :func:`load_identified` read from one (module
        :mod:`.identified`); the payload, link scale and added friction of
        ``distributions`` are then set to 0 (the start offset and torque noise stay).
    simulator : "manipdyn" | "mujoco"
        Who steps the plants: manipdyn's RK4 (default), or MuJoCo on each drawn plant's MJCF
        (:mod:`.study`; the ``mujoco`` extra).  The same seed gives the same plants in both.
    mujoco_plant : "model" | "file"
        With MuJoCo: the plant manipdyn simulates, constraints off and the whole friction law
        applied (default), or the MJCF as MuJoCo loads it (Coulomb as ``frictionloss``).
    """
    import os

    import numpy as np

    if isinstance(arm, (str, os.PathLike)):
        from ...formats.loading import load

        arm = load(arm)           # a bundled name, a model file or a URDF, as the command line takes
    check_study_size(runs, len(tuple(controllers)), duration, dt, bandwidth)
    if simulator == "mujoco":
        from ...engines.mujoco.deps import mujoco_module

        mujoco_module()              # a missing extra is named before a long study, not in a worker
    lim = None
    if tau_max is not None:
        try:
            arr = np.broadcast_to(np.asarray(tau_max, dtype=np.float64), (arm.n,))
        except (TypeError, ValueError):
            raise ValueError(f"tau_max: expected a number or {arm.n} numbers in N m, got {tau_max!r}") from None
        if not np.all(arr > 0):
            raise ValueError(f"tau_max: must be > 0 (inf for no limit), got {arr.tolist()}")
        lim = tuple(float(x) for x in arr)
    dist = distributions if distributions is not None else Distributions()
    if plants is not None:
        import dataclasses

        from ..._support.errors import ModelError

        if isinstance(plants, (str, os.PathLike)):
            plants = load_identified(plants)     # a base model file, as --plants-from takes it
        if not isinstance(plants, IdentifiedPlants):
            raise ModelError(f"plants: expected a base model JSON file name or IdentifiedPlants "
                             f"(load_identified), got {type(plants).__name__}")
        prior = arm_from_text(*plants.prior)
        if prior.n != arm.n or tuple(prior.joint_types) != tuple(arm.joint_types):
            raise ModelError(f"plants: the identification's prior {prior.name!r} has joints "
                             f"{list(prior.joint_types)}, the study's arm {arm.name!r} has "
                             f"{list(arm.joint_types)}")
        # the plants have the prior's kinematics, the controllers the study arm's: the same
        # arm, or the study compares controllers on another robot (tool poses at 20 seeded
        # states within 1e-6 m / rad, far above rounding, far below any real difference)
        q = prior.random_state(np.random.default_rng(0), 20)
        if not np.allclose(prior.fkine(q), arm.fkine(q), rtol=0, atol=1e-6):
            raise ModelError(f"plants: the identification's prior {prior.name!r} has other kinematics "
                             f"than the study's arm {arm.name!r} (tool poses differ); give the "
                             f"identified arm's model as MODEL")
        replaced = ("payload_mass", "link_scale", "friction_viscous", "friction_coulomb")
        sized = ("payload_rel", "friction_viscous_rel", "friction_coulomb_rel")
        # the sized figures at their defaults are not a choice: the identification replaces them quietly
        given = [f for f in replaced if distributions is not None and getattr(distributions, f)]
        given += [f for f in sized if distributions is not None
                  and getattr(distributions, f) not in (0.0, RELATIVE_DEFAULTS[f])]
        if given:
            raise ModelError(f"distributions: {', '.join(given)} must be 0 with plants= (the "
                             "identification's distribution replaces them)")
        dist = dataclasses.replace(dist, **{f: 0.0 for f in replaced + sized})
    return Study(model_text(arm), runs, seed, tuple(controllers), float(duration), float(dt),
                 dist, lim, float(bandwidth), float(gamma), plants, simulator, mujoco_plant)
