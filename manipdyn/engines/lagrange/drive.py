"""The trace-form engine's own coding of the drive: coupled rotors and the friction law.

Layer 3 (engines: lagrange), beside :mod:`manipdyn.engines.lagrange.engine`, which alone uses it.  The
Pinocchio engine gets the same quantities from the model
(:meth:`manipdyn.model.drive.Transmission.rotor_inertia`,
:meth:`manipdyn.model.drive.Friction.torque`); this module writes them out again from
their definitions, so that the cross-check compares two codings of each.
"""

from __future__ import annotations

import numpy as np

__all__ = ["coupled_rotor_inertia", "friction_torque"]


def coupled_rotor_inertia(R, motor_inertia) -> np.ndarray:
    """The rotors' share of D, (n, n), kg m^2.

    The chapter's remark on actuator kinetic energy with motor k turning at
    ``qd_m,k = sum_i R_ki qd_i``: ``K_rotors = 1/2 sum_k Jm_k qd_m,k^2``, so
    ``D_ij`` gets ``sum_k Jm_k R_ki R_kj``: off-diagonal entries where a motor
    moves several joints.
    """
    R = np.asarray(R, dtype=np.float64)
    Jm = np.asarray(motor_inertia, dtype=np.float64)
    return sum(Jm[k] * np.outer(R[k], R[k]) for k in range(len(Jm)))


def friction_torque(law, R, qd) -> np.ndarray:
    """The friction law ``law`` (a :class:`manipdyn.model.drive.Friction`) at joint velocities
    ``qd`` (n,) or (B, n), written out term by term (:mod:`manipdyn.model.friction`'s table).

    Motor side: the law acts on ``v_k = sum_j R_kj qd_j`` and reaches joint j as
    ``sum_k R_kj tau_k``.  The constant offset is a joint torque.
    """
    motor = law.side == "motor"
    v = np.einsum("kj,...j->...k", R, qd) if motor else qd
    s = np.tanh(v / law.smoothing) if law.smoothing > 0 else np.sign(v)     # the (smoothed) sign
    if law.deadband > 0:
        s = np.where(np.abs(v) <= law.deadband, 0.0, s)
    t = np.zeros(np.shape(v))
    if law.viscous is not None:
        t += law.viscous * v
    if law.coulomb_pos is not None:                                         # Fc+ for v > 0, Fc- for v < 0
        t += np.where(s > 0, law.coulomb_pos, law.coulomb_neg) * s
    if law.stribeck_level is not None:
        t += law.stribeck_level * np.exp(-(np.abs(v) / law.stribeck_velocity) ** law.stribeck_exponent) * s
    if law.sigmoid_A is not None:                                           # 1/(1+e^-x) = (1 + tanh(x/2))/2
        a, p3 = law.sigmoid_alpha, law.sigmoid_p3
        t += law.sigmoid_A * 0.5 * (np.tanh(0.5 * a * (v + p3)) - np.tanh(0.5 * a * p3))
    if motor:
        t = np.einsum("kj,...k->...j", R, t)
    return t + law.offset if law.offset is not None else t
