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

__all__ = ["cause", "CAUSES", "runaway", "RUNAWAY_TORQUE", "explain", "OFF_PATH"]

#: rad (m): an error this large is off the path, where no linearisation along it holds
OFF_PATH = 0.5

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


#: what a controller's gains are, where a runaway needs it said
_GAINS = {"lqr": "the LQR's gains are the nominal arm's linearisation along the path, which does not hold that far "
                 "off it"}


def explain(study, setup, key: str, log, diverged: bool, ran_away: bool, loop: float):
    """What happened to one diverged run (module docstring), or None for a run that did not diverge.

    Returns ``{"criterion": "bounds" | "range" | "torque", "joint", "t", "value", "limit",
    "off_path_t", "off_path_joint", "heavier", "heavier_joint", "payload_mass", "sampled_loop",
    "substeps", "integrator", "text"}``: joints 1-based; times in s; ``value``/``limit`` in rad (m) or N m (N);
    ``heavier`` the largest ratio of the plant's ``D_jj`` to the model's at the path's start;
    ``text`` one sentence of it all."""
    if not (diverged or ran_away):
        return None
    from ..demo import CONTROLLERS

    arm = study.arm
    t = np.asarray(log.t, dtype=np.float64)
    e = np.abs(np.asarray(log.e, dtype=np.float64)).reshape(len(t), arm.n)
    tau = np.abs(np.asarray(log.tau, dtype=np.float64)).reshape(len(t), arm.n)
    span = np.diff(arm.qlim, axis=1)[:, 0]
    unit = ["m" if jt == "prismatic" else "rad" for jt in arm.joint_types]
    out = {"criterion": None, "joint": None, "t": None, "value": None, "limit": None}
    if diverged:
        out.update(criterion="bounds", t=float(t[-1]) if len(t) else 0.0)
        what = (f"the simulator stopped it after t = {out['t']:.3g} s (a joint past 100 rad or 1000 rad/s, or a "
                "non-finite torque)")
    else:
        past = ~(e <= span)
        limit = RUNAWAY_TORQUE * max(study.torque_scale(), 1e-9)
        if past.any():
            k, j = np.argwhere(past)[0]
            jj = int(np.argmax(e.max(axis=0) / span))
            out.update(criterion="range", joint=int(j) + 1, t=float(t[k]), value=float(e[:, j].max()),
                       limit=float(span[j]))
            what = (f"joint {j + 1}'s error passed its range {span[j]:.3g} {unit[j]} at t = {t[k]:.3g} s "
                    f"(largest {e[:, jj].max():.3g} {unit[jj]} on joint {jj + 1})")
        else:
            k, j = np.argwhere(~(tau <= limit))[0]
            out.update(criterion="torque", joint=int(j) + 1, t=float(t[k]), value=float(tau.max()), limit=float(limit))
            what = f"joint {j + 1}'s torque passed {limit:.3g} N m at t = {t[k]:.3g} s"
        what += f", peak torque {tau.max():.3g} N m"
    off = np.argwhere(e > OFF_PATH)
    out["off_path_t"] = float(t[off[0][0]]) if len(off) else None
    out["off_path_joint"] = int(off[0][1]) + 1 if len(off) else None
    q0 = np.asarray(setup.trajectory(0.0)[0], dtype=np.float64)
    ratio = np.diag(setup.plant.pinocchio.mass_matrix(q0)) / np.maximum(np.diag(arm.mass_matrix(q0)), 1e-300)
    h = int(np.argmax(ratio))
    draw = setup.plant.draw
    out.update(heavier=float(ratio[h]), heavier_joint=h + 1, payload_mass=float(draw.payload_mass),
               sampled_loop=float(loop), substeps=int(setup.substeps),
               integrator=str(getattr(setup, "integrator", "rk4")))
    parts = [what]
    if out["off_path_t"] is not None:
        parts.append(f"{OFF_PATH:g} {unit[out['off_path_joint'] - 1]} off the path first at t = "
                     f"{out['off_path_t']:.3g} s on joint {out['off_path_joint']}")
    parts.append(f"its plant's joint {h + 1} is {ratio[h]:.3g} x the model's inertia D_jj"
                 + (f" (payload {draw.payload_mass:.3g} kg, undeclared)" if draw.payload_mass else ""))
    from ..stiffness import SAMPLED_LIMIT

    stepper = "Rosenbrock" if getattr(setup, "integrator", "rk4") == "rosenbrock" else "RK4"
    parts.append(f"sampled loop {loop:.3g} " + ("> " if loop > SAMPLED_LIMIT else "<= ") + f"{SAMPLED_LIMIT:g}, "
                 f"{setup.substeps} {stepper} step(s) per period" + ("" if loop > SAMPLED_LIMIT
                                                                    else ": not the period, not the integrator"))
    if key in _GAINS and out["off_path_t"] is not None:
        parts.append(_GAINS[key])
    label = CONTROLLERS.get(key, key)
    out["text"] = f"{label} run {int(draw.run)}: {cause(loop, diverged, ran_away)}: " + "; ".join(parts)
    return out
