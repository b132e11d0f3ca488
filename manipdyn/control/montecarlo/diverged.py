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
"""

from __future__ import annotations

import numpy as np

__all__ = ["cause", "CAUSES"]

#: the ``cause`` of a diverged run, with the report's wording
CAUSES = {
    "sampled loop": "the controller's damping over the plant's inertia exceeds what a torque held over "
                    "the period allows (dt |eig(D_plant^-1 K_d)| > 2 at the reference): a shorter --dt, "
                    "not more RK4 steps, holds it",
    "other": "neither the plant's modes (the stiffness check) nor the sampled loop exceed the period at "
             "the reference",
}


def cause(loop: float, diverged: bool):
    """A key of :data:`CAUSES` for a diverged run whose ``Study.sampled_loop`` is ``loop``, else None."""
    from ..stiffness import SAMPLED_LIMIT

    if not diverged:
        return None
    return "sampled loop" if np.isfinite(loop) and loop > SAMPLED_LIMIT else "other"
