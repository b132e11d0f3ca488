"""What the log decides for the friction law when the user does not: its side and its Coulomb smoothing.

Layer 5 (identification).

Friction side (:func:`friction_side`)
-------------------------------------
Friction lives in the motors and the gears.  With a diagonal transmission a
motor-side law is a joint-side law with rescaled coefficients, so the side does
not matter.  With a **coupled** drive (a wrist whose motor 6 turns joints 5 and
6) it does: motor k's Coulomb torque ``sign(qd_m,k)`` reaches the joints as
``R^T tau_f,m``, on both coupled joints, switching where the *motor* velocity
``(R qd)_k`` changes sign, which no joint-side law (one sign per joint) can
express.  On a Staubli TX40 log (motor side, coupled wrist) the joint-side fit
predicted the wrist joints 5x worse than the motor-side one (issue 24).

So: when the torques were logged at the motors (``taum*`` or currents ``i*``,
read through the model's ``[transmission]``) and the transmission couples
joints, the law goes on the **motor side** unless the user names a side.  The
data are then what the motor sees, the side where the law is physics.  With
link-side torques (a torque sensor after the gear) the default stays the joint
side, and when the drive couples joints a note says that the motor side
(``--friction-side motor``) is the physical one.  A side the user names is
kept; when it is the joint side on a coupled motor-side log, a note says what
it costs.  The decision is always stated (it is a modelling choice, never a
silent one).

Coulomb smoothing (:func:`coulomb_smoothing`)
---------------------------------------------
The smoothed sign ``tanh(v / v_s)`` stands for what a log cannot resolve: at
speeds within the velocity's own noise the sign of the motion is not known
sample by sample, and the joint dithers there (the controller and the encoder
work at that scale).  A ``v_s`` far above that noise blurs a Coulomb step the
data resolves (an arm whose controller logs qd to 1e-4 rad/s lost a wrist joint
to its published model at the old fixed 0.01 rad/s, and won every joint at
1e-4); far below it, the model switches the full Coulomb torque on noise.  So
``v_s`` is the velocity's noise level, measured on the log
(:attr:`Measurements.qd_noise`, per joint: the RMS of what the low-pass filter
removed from a measured qd, or ``2 pi cutoff`` times the RMS of what it removed
from q when qd is derived: the speed of a sine at the cut-off with q's noise as
amplitude), taken to the law's side (``sqrt(R^2 sigma^2)`` per motor,
independent joints) and summarised by the median over the actuators (one
noisy joint does not set everyone's).  On the Panda log (measured qd, 1 kHz)
it is 0.0078 rad/s, where the fixed default was 0.01.  Nothing filtered (qd and
qdd both measured): the noise is not known and the default stays, with a note.
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError

__all__ = ["friction_side", "coulomb_smoothing", "motor_side_torques", "choose_friction_options"]

#: the signals that mean torques measured at the motor
_MOTOR_TORQUES = ("taum", "i")


def motor_side_torques(data) -> bool:
    """True when ``data`` (:class:`~manipdyn.identification.Measurements`) has its torques from motor-side
    columns (``taum*`` or currents ``i*``)."""
    return any(s in _MOTOR_TORQUES for s in getattr(data, "motor_signals", ()))


def friction_side(transmission, data, given: str | None = None) -> tuple[str, str | None]:
    """``(side, note)``: the side of the friction law (module docstring).

    ``transmission``: the model's :class:`manipdyn.Transmission` (or None);
    ``data``: the :class:`~manipdyn.identification.Measurements` fitted;
    ``given``: ``"joint"``, ``"motor"`` or None (not given).  ``note`` is a
    sentence for the fit's notes, or None when there is nothing to say (a
    diagonal drive and no side given).
    """
    if given not in (None, "joint", "motor"):
        raise ModelError(f"friction side: expected 'joint', 'motor' or None, got {given!r}")
    coupled = transmission is not None and not transmission.is_diagonal
    motor_data = motor_side_torques(data)
    if not coupled:
        return given or "joint", None
    R = np.asarray(transmission.R, dtype=np.float64)
    drives = [f"motor {k + 1} drives joints {' and '.join(str(j + 1) for j in np.flatnonzero(R[k]))}"
              for k in range(len(R)) if np.count_nonzero(R[k]) > 1]
    what = f"the [transmission] couples joints ({'; '.join(drives)})"
    if given == "motor":
        return "motor", f"friction on the motor side (as given): {what}"
    if given == "joint":
        if motor_data:
            return "joint", (f"friction on the JOINT side, as given, although {what} and the torques were logged "
                             "at the motors: a joint-side law cannot switch where a coupled motor's velocity "
                             "changes sign (a coupled wrist came out 5x worse so); --friction-side motor is "
                             "the physical side")
        return "joint", f"friction on the joint side (as given); {what}: --friction-side motor is the physical side"
    if motor_data:
        return "motor", (f"friction on the MOTOR side (chosen): {what} and the torques were logged at the motors, "
                         "so the law acts on qd_m = R qd where the motors' friction is; --friction-side joint "
                         "to override")
    return "joint", (f"friction on the joint side (the default for link-side torques), although {what}: the "
                     "coupled motors' friction is motor-side physics, --friction-side motor to fit it there")


def coulomb_smoothing(data, side: str = "joint", transmission=None) -> tuple[float, str]:
    """``(v_s, note)``: the Coulomb smoothing chosen from the log (module docstring), rad/s on the law's side.

    ``data``: :class:`~manipdyn.identification.Measurements` with ``qd_noise`` (n,) rad/s or
    None; ``side``: ``"joint"`` or ``"motor"``; ``transmission``: needed on the motor side.
    """
    from ...model.friction import DEFAULT_SMOOTHING

    noise = getattr(data, "qd_noise", None)
    if noise is None:
        return DEFAULT_SMOOTHING, (f"Coulomb smoothing {DEFAULT_SMOOTHING:g} rad/s (the default: qd and qdd were "
                                   "measured and not filtered, so the velocity's noise is not known; --smoothing "
                                   "to set it)")
    noise = np.asarray(noise, dtype=np.float64)
    unit = "rad/s at the joints"
    if side == "motor":
        if transmission is None:
            raise ModelError("friction: a motor-side law needs the transmission (qd_m = R qd)")
        R = np.asarray(transmission.R, dtype=np.float64)
        noise = np.sqrt((R**2) @ noise**2)
        unit = "rad/s at the motors"
    v = float(np.median(noise))
    if not v > 0:
        return DEFAULT_SMOOTHING, (f"Coulomb smoothing {DEFAULT_SMOOTHING:g} rad/s (the default: the velocity shows "
                                   "no noise to measure, a noiseless log?; --smoothing to set it)")
    how = ("the RMS of what the filter removed from the measured qd" if getattr(data, "measured_qd", False)
           else "2 pi cutoff x the RMS of what the filter removed from q")
    per = " ".join(f"{x:.2g}" for x in noise)
    return v, (f"Coulomb smoothing tanh(v / {v:.3g}) chosen from the log: the velocity's noise level ({how}; "
               f"median over the actuators of {per} {unit}); --smoothing to override")


def choose_friction_options(transmission, data, side: str | None = None, smoothing: float | None = None,
                            smoothed: bool = True) -> tuple[str, float | None, list[str]]:
    """``(side, smoothing, notes)`` of the friction law to fit on ``data``: what was given, the rest chosen.

    ``side`` (``"joint"``, ``"motor"`` or None) by :func:`friction_side`; ``smoothing`` (rad/s on the
    law's side, or None) by :func:`coulomb_smoothing` when the law has a smoothed sign (``smoothed``;
    ``--friction`` is viscous plus a sharp sign, and its smoothing stays None).  ``notes``: the
    sentences saying what was chosen and why.
    """
    side, note = friction_side(transmission, data, side)
    notes = [note] if note else []
    if smoothed and smoothing is None:
        smoothing, why = coulomb_smoothing(data, side, transmission)
        notes.append(why)
    return side, smoothing, notes
