"""Path-tracking control on top of manipdyn's dynamics (the thesis' subject).

Layer 6 (control).  Holds ``montecarlo/`` (robustness studies of these controllers, whose
plants may come from an identification), ``track`` (the demo run) and ``mjsim`` (MuJoCo stepping
the plant instead of manipdyn's RK4: ``simulate(..., simulator="mujoco")``).  May import: everything below it
(``identification``, ``check``, ``engines``, ``formats``, ``model``, ``_support``).

* trajectories (:mod:`.trajectory`): :class:`Quintic`, :class:`ViaPoints`,
  :class:`Sampled`, each ``trajectory(t) -> (q_d, qd_d, qdd_d)``;
* controllers (:mod:`.controllers`), one interface ``tau = controller(t, q, qd)``:
  :class:`PD`, :class:`PDGravity`, :class:`ComputedTorque`, :class:`SlotineLi`,
  :class:`LQR` (time-varying LQR along the reference, :mod:`.lqr`);
* :class:`Regressor`: the dynamics linear in the inertial parameters;
* :func:`simulate`: fixed-step RK4 with the torque held over each step, on the
  arm or on a different plant (``arm.with_payload(...)``, :func:`with_scaled_inertia`);
* :func:`replay` (``md.replay``): models simulated forward from states of a real log with
  the logged torque, q and qd at each horizon against the log (:mod:`.replay`).

Example::

    import numpy as np, manipdyn as md
    from manipdyn.control import Quintic, ComputedTorque
    arm = md.load("puma560")
    path = Quintic(np.zeros(6), np.full(6, 0.5), duration=2.0)
    log = md.simulate(arm, ComputedTorque(arm, kp=400, kd=40), path, duration=2.5)
    print(log.summary())
"""

from .controllers import (PD, ComputedTorque, Controller, PDGravity, SlotineLi,
                          adaptation_gains, model_torque_limits, pd_gains)
from .lqr import LQR, lqr_weights, solve_dare
from ..model.variants import with_payload as _with_payload, with_scaled_inertia
from .regressor import Regressor, parameters_from_pseudo_inertia, pseudo_inertia_from_parameters
from .simulate import SimulationDiverged, SimulationLog, simulate
from .replay import ReplayResult, replay
from .trajectory import PiecewisePolynomial, Quintic, Sampled, Trajectory, ViaPoints

__all__ = [
    "Trajectory", "PiecewisePolynomial", "Quintic", "ViaPoints", "Sampled",
    "Controller", "PD", "PDGravity", "ComputedTorque", "SlotineLi", "LQR", "pd_gains", "adaptation_gains",
    "lqr_weights", "solve_dare",
    "model_torque_limits", "Regressor", "parameters_from_pseudo_inertia",
    "pseudo_inertia_from_parameters", "simulate", "SimulationLog", "SimulationDiverged",
    "with_payload", "with_scaled_inertia", "replay", "ReplayResult",
]


def with_payload(arm, mass: float, com=(0.0, 0.0, 0.0), inertia=None, name=None):
    """Deprecated: ``arm.with_payload(mass, com, inertia)``, which takes every kind of arm
    (:func:`manipdyn.model.variants.with_payload`); this name still works, for every arm, and warns."""
    import warnings

    warnings.warn("manipdyn.control.with_payload(arm, ...) is deprecated; use arm.with_payload(mass, com, "
                  "inertia), which takes every kind of arm", DeprecationWarning, stacklevel=2)
    return _with_payload(arm, mass, com, inertia, name)
