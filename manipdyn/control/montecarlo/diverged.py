"""Why a run diverges: the sampled loop, checked before the run.

Layer 6 (control: montecarlo).

:func:`manipdyn.simulate` holds the controller's torque over each period ``dt`` (a
digital controller's zero-order hold) and integrates the plant over the period by
RK4, with as many steps as the plant's own fastest mode needs
(:mod:`manipdyn.control.stiffness`, :func:`~manipdyn.control.stiffness.rk4_substeps`).
That check looks at the plant alone.  A run can still blow up because the *loop*
is too fast for its period: a controller tuned to the nominal arm damps
(``K_d = -d tau / d qd``) a direction in which the plant is much lighter, and
``dt |eig(D_plant^-1 K_d)| > 2``.  More integration steps do not help (the torque is
held over the whole period); a shorter period does, as a softer controller would.

Measured on the README's Panda identification (``--t-range 0:10``, ``consistent``):
at the demo path's start joints 1 and 3 are coaxial, and ``q1 - q3`` turns link 2
about that axis alone.  The identification leaves link 2's axial inertia at a
fraction of the prior's (the fit sits on ``J_2 >= 0``), so PD's gains
(``K_d = 2 wn D_ii`` of the prior) give ``dt |lambda| = 4`` on the identified arm
itself at 1 kHz (1.3 on the prior): PD, PD + gravity and adaptive control diverge
on it within 0.5 s, and hold at 5 kHz.

:meth:`Study.sampled_loop <manipdyn.montecarlo.Study.sampled_loop>` computes ``dt |lambda|``
for a run's plant and controller at the reference samples the stiffness check reads (a few milliseconds per run and
controller); every per-run record carries it (``sampled_loop``), and a diverged
run's ``cause`` is ``"sampled loop"`` when it exceeds 2, ``"other"`` otherwise.  The
report says how many runs exceed it, and which period would hold them.

A run can also *run away* without tripping :func:`manipdyn.simulate`'s bounds (100 rad,
1000 rad/s): measured, ``manipdyn montecarlo ur5 --runs 20 --seed 1`` had LQR runs with a
21.4 rad error and a 2.5e4 N m torque that finished "not diverged".  :func:`runaway` counts
such a run as diverged (cause ``"runaway"``) when a joint's tracking error exceeds the whole
range of that joint (``arm.qlim``: the arm would have left its workspace), or a torque exceeds
:data:`RUNAWAY_TORQUE` times the largest torque the nominal arm needs on the reference (no
controller of that arm commands that on purpose).
"""

from __future__ import annotations

import numpy as np

__all__ = ["cause", "CAUSES", "runaway", "RUNAWAY_TORQUE"]

#: a torque this many times the nominal arm's largest on the reference is a runaway
RUNAWAY_TORQUE = 100.0

#: the ``cause`` of a diverged run, with the report's wording
CAUSES = {
    "sampled loop": "the controller's damping over the plant's inertia exceeds what a torque held over "
                    "the period allows (dt |eig(D_plant^-1 K_d)| > 2 at the reference): a shorter --dt, "
                    "not more RK4 steps, holds it",
    "runaway": "the run finished, but a joint's tracking error exceeded the joint's whole range, or a "
               f"torque {RUNAWAY_TORQUE:g} times the largest the nominal arm needs on the path: the controller "
               "lost the arm (a real one would have hit its limits)",
    "other": "neither the plant's modes (the stiffness check) nor the sampled loop exceed the period at "
             "the reference",
}


def cause(loop: float, diverged: bool, ran_away: bool = False):
    """A key of :data:`CAUSES` for a diverged (or ``ran_away``) run whose ``Study.sampled_loop`` is
    ``loop``, else None: the sampled loop first (it explains a runaway too), then the runaway."""
    from ..stiffness import SAMPLED_LIMIT

    if not (diverged or ran_away):
        return None
    if np.isfinite(loop) and loop > SAMPLED_LIMIT:
        return "sampled loop"
    return "other" if diverged else "runaway"


def runaway(log, span: np.ndarray, torque_scale: float) -> bool:
    """True when a finished run ran away (module docstring): ``|e_j| > span_j`` (the joint's range,
    ``qlim`` high minus low, rad or m) at some sample, or ``|tau| > RUNAWAY_TORQUE * torque_scale``
    (N m or N, the nominal arm's largest torque on the reference)."""
    if len(log.t) == 0:
        return False
    e = np.abs(log.e)
    return bool(np.any(~(e <= span)) or not np.max(np.abs(log.tau)) <= RUNAWAY_TORQUE * max(torque_scale, 1e-9))
