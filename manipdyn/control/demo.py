"""The standard demo: a path every arm can follow and the five tuned controllers.

Layer 6 (control).  Used by ``manipdyn track``, the Monte-Carlo
studies and the benchmarks, so that all three run the same thing.
"""

from __future__ import annotations

import numpy as np

from .._support.errors import ModelError
from .controllers import PD, ComputedTorque, PDGravity, SlotineLi, adaptation_gains, pd_gains
from .lqr import LQR
from .trajectory import ViaPoints

__all__ = ["demo_path", "make_controller", "CONTROLLERS", "DEFAULT_BANDWIDTH", "DEFAULT_GAMMA",
           "DEFAULT_PAYLOAD_COM"]

#: controller keys, in the order of --compare
CONTROLLERS = {"pd": "PD", "pdg": "PD + gravity", "ct": "computed torque", "adaptive": "adaptive (Slotine-Li)",
               "lqr": "LQR"}

#: closed-loop bandwidth of every demo controller, rad/s (critically damped)
DEFAULT_BANDWIDTH = 10.0
#: adaptation gain of the demo: Gamma = adaptation_gains(arm, DEFAULT_GAMMA), each
#: parameter's gain scaled by the joint inertias it acts on.  Tuned on the
#: bundled arms with a 2 kg payload at 1 kHz (tests/test_control.py): 0 behaves
#: like computed torque with the wrong model; 3 to 30 cut the final-second error
#: 6x (Stanford) to 50x (UR10); 100 still runs; an unscaled Gamma = 1 I
#: diverges on the UR5 and UR10.
DEFAULT_GAMMA = 10.0
#: where --payload puts the mass: 0.1 m along z of the last link's frame
DEFAULT_PAYLOAD_COM = (0.0, 0.0, 0.1)


def demo_path(arm, duration: float, via_step: float = 0.5):
    """The standard demo path: a :class:`ViaPoints` spline over ``duration`` s.

    Around the middle of the joint limits ``qc``, each joint swings as
    ``A_i sin(2 pi t / P_i)`` with its own period ``P_i = 2 + 0.7 i`` s (so the
    joints move out of step: rich excitation for adaptation), amplitude
    ``A_i = min(0.6 rad, range/5)`` (``min(0.1 m, range/5)`` for prismatic
    joints), under an envelope rising over the first second and falling over
    the last, sampled every ``via_step`` s.  It starts and ends at rest at ``qc``.
    """
    lo, hi = arm.qlim[:, 0], arm.qlim[:, 1]
    qc = 0.5 * (lo + hi)
    prismatic = np.array([t == "prismatic" for t in arm.joint_types])
    A = np.minimum(np.where(prismatic, 0.1, 0.6), 0.2 * (hi - lo))
    K = max(2, int(round(duration / via_step)))
    t = np.linspace(0.0, duration, K + 1)
    ramp = min(1.0, duration / 3)
    env = np.clip(np.minimum(t, duration - t) / ramp, 0.0, 1.0)
    env = env * env * (3 - 2 * env)                          # smoothstep, 0 at both ends
    P = 2.0 + 0.7 * np.arange(arm.n)
    pts = qc + env[:, None] * A * np.sin(2 * np.pi * t[:, None] / P)
    return ViaPoints(pts, t)


def make_controller(kind: str, arm, wn: float = DEFAULT_BANDWIDTH, gamma: float = DEFAULT_GAMMA,
                    tau_max=None, path=None, dt: float = 1e-3):
    """The demo controllers, all tuned to the bandwidth ``wn`` (rad/s), critically damped.

    * ``pd``, ``pdg``: ``Kp = wn^2 D_ii``, ``Kd = 2 wn D_ii`` (:func:`pd_gains`);
    * ``ct``: ``Kp = wn^2``, ``Kd = 2 wn``;
    * ``adaptive``: ``Lambda = wn``, ``K_D = wn D_ii``, and
      ``Gamma = adaptation_gains(arm, gamma)``: the poles of
      ``(s + Lambda)(D_ii s + K_D)`` are those of the others;
    * ``lqr``: time-varying LQR along ``path`` (:class:`LQR`) with the weights
      :func:`lqr_weights` at ``wn`` (a joint alone would get ``Kp = wn^2 D_ii``,
      ``Kd = 2 wn D_ii``), its gains on the grid of the controller period ``dt``
      (s; the simulation's step).  Without ``path`` the gains are computed when
      a path is bound (``reset``, which :func:`manipdyn.simulate` calls).

    ``D_ii`` is the model's mass matrix at the middle of the joint limits.
    ``path`` and ``dt`` matter to ``lqr`` only.
    """
    kp, kd = pd_gains(arm, wn)
    if kind == "pd":
        return PD(arm, kp, kd, tau_max=tau_max)
    if kind == "pdg":
        return PDGravity(arm, kp, kd, tau_max=tau_max)
    if kind == "ct":
        return ComputedTorque(arm, wn**2, 2 * wn, tau_max=tau_max)
    if kind == "adaptive":
        return SlotineLi(arm, lam=wn, kd=kd / 2, gamma=adaptation_gains(arm, gamma), tau_max=tau_max)
    if kind == "lqr":
        return LQR(arm, wn=wn, dt=dt, trajectory=path, tau_max=tau_max)
    raise ModelError(f"--controller: expected one of {', '.join(CONTROLLERS)}, got {kind!r}")
