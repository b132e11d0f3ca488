"""Torque constants with no payload and no torque constant: the scale from the prior's gravity.

Layer 5 (identification), room ``payload``.

Currents ``i`` explain the torques only up to one factor shared by every ``k_t`` and every
inertial parameter (:mod:`.torque_constants`): ``(beta, k_t)`` and ``(c beta, c k_t)`` fit
alike.  A run with a known payload, or one motor's known ``k_t``, fixes ``c``; many arms
(a UR5's logs, say) have neither, but their vendor's masses and centres of mass are
published, and those fix the **gravity torque**.  So, in order:

1. per motor, the current regressed on the prior's rigid torque ``R^-T Y(q, qd, qdd) pi_prior``
   with an offset, a Coulomb sign and a viscous term (least squares over every sample): a
   first ``k_t`` per motor, only as good as the prior's whole model, which serves as the start
   of step 2 and as the value kept for a motor step 2 cannot determine;
2. the ``k_t`` of every motor relative to each other, fitted with the base parameters on all
   the runs (:func:`.torque_constants.identify_torque_constants`, the scale motors' mean ratio
   to step 1 held at 1);
3. the base parameters of that relative scale by least squares, and their gravity torque
   ``g_0(q)`` (the regressor at rest, friction columns left out) on the runs' postures; the
   factor ``c`` with ``c g_0 = g_prior`` in least squares, both about their means over the samples
   (a constant torque is the friction offset's as much as gravity's: over one run's postures the
   fit cannot tell them apart), on the **scale motors**: the motors
   whose prior gravity torque varies over the logs (default: each whose spread over the
   samples is at least :data:`GRAVITY_SHARE` of the largest; on a UR5, joints 2 and 3; a
   vertical first axis and the last wrist joint carry no gravity torque that varies).  Every
   ``k_t`` is ``c`` times step 2's.

What is trusted, then, is the prior's gravity torque on the scale motors: the masses and
centres of mass of the links beyond the first of them (joint j carries links j to n).  The
standard deviation of each ``k_t`` combines step 2's (the relative constants; infinite for a
motor the runs do not determine, whose value is then step 1's, in the same scale, and says so)
and the scale's, the larger of two spreads: ``c`` from the first and the second half of every
run (the data's own scatter), and ``c`` from each scale motor alone (how far the prior's gravity
is self-consistent), over the square root of their number.  Neither counts what the prior's
masses themselves get wrong: a prior 5 % heavy gives every ``k_t`` 5 % large.

What one run can fix depends on the postures it passes through and how it stops there.  A
point-to-point run between two postures has one gravity difference per joint, and at each rest the
joint holds a static friction anywhere in its band (:mod:`manipdyn.model.friction_rest`), which
neither the last motion's sign nor the load explains on the UR5's logs: a scale from such a run alone
is as uncertain as that friction is against the gravity difference (on the UR5's ``No4_Acc``, ``k2``
14.4 +- 2.2 against 12.4 from ``No6``, ``k3`` not determined; ``tests/test_ur5_currents_realdata.py``
says what was measured and tried).
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError
from .torque_constants import TorqueConstants, identify_torque_constants, one_line

__all__ = ["GRAVITY_SHARE", "FAR", "default_scale_motors", "constants_from_gravity", "torque_constants", "one_line",
           "check_scale_motors"]

#: a motor outside the scale whose k_t is further than this factor from the prior's torque's is said to be so
FAR = 1.3
#: a motor sets the scale when its prior gravity torque's spread over the samples is at least this share of the largest
GRAVITY_SHARE = 0.1


def _motor_side(arm, x):
    """Joint-side torques (..., n) as motor-side ones, ``R^-T x``."""
    RinvT = np.linalg.inv(np.asarray(arm.transmission.R, dtype=np.float64)).T
    return np.asarray(x) @ RinvT.T


def _prior_gravity(arm, runs) -> np.ndarray:
    """The prior's gravity torque at the motors on every run's samples, stacked (N, n)."""
    return np.concatenate([_motor_side(arm, arm.gravity_torque(data.q)) for data, _ in runs])


def check_scale_motors(motors, n: int) -> tuple:
    """``motors`` as a tuple of 1-based motor numbers, or a :class:`ModelError` naming ``scale_from_gravity``."""
    try:
        if isinstance(motors, (str, bytes)) or not all(
                isinstance(k, (int, np.integer)) and not isinstance(k, bool) for k in motors):
            raise TypeError
        out = tuple(sorted({int(k) for k in motors}))
    except TypeError:
        raise ModelError(f"scale_from_gravity: expected motor numbers 1 to {n}, got {motors!r:.60}") from None
    if not out or any(not 1 <= k <= n for k in out):
        raise ModelError(f"scale_from_gravity: expected motor numbers 1 to {n}, got {list(out)}")
    return out


def default_scale_motors(arm, runs) -> tuple:
    """The 1-based motors whose prior gravity torque varies over the runs (module docstring, step 3)."""
    spread = np.std(_prior_gravity(arm, runs), axis=0)
    top = float(np.max(spread))
    if not top > 0:
        raise ModelError("scale from the prior's gravity: the prior's gravity torque does not vary over these logs "
                         "on any motor (a horizontal arm, or a prior without masses?): give a run with a known "
                         "payload (RUNS.toml: payload = {mass, com}) or the model's [transmission] torque_constant")
    return tuple(int(j) + 1 for j in np.flatnonzero(spread >= GRAVITY_SHARE * top))


def _regression_constants(arm, runs):
    """Step 1: ``(k (n,), r2 (n,))``, each motor's current regressed on the prior's rigid torque."""
    pi = arm.parameters()
    cols, ys = [], []
    for data, _ in runs:
        tp = _motor_side(arm, arm.lagrange.regressor(data.q, data.qd, data.qdd) @ pi)
        qdm = data.qd @ np.asarray(arm.transmission.R, dtype=np.float64).T
        cols.append((tp, qdm))
        ys.append(_motor_side(arm, data.tau))
    tp = np.concatenate([c[0] for c in cols])
    qdm = np.concatenate([c[1] for c in cols])
    cur = np.concatenate(ys)
    n = arm.n
    k, r2 = np.full(n, np.nan), np.zeros(n)
    for m in range(n):
        A = np.column_stack([tp[:, m], np.ones(len(tp)), np.tanh(qdm[:, m] / 0.01), qdm[:, m]])
        coef = np.linalg.lstsq(A, cur[:, m], rcond=None)[0]
        res = cur[:, m] - A @ coef
        ss = float(np.sum((cur[:, m] - cur[:, m].mean()) ** 2))
        r2[m] = 1.0 - float(res @ res) / ss if ss > 0 else 0.0
        if coef[0] > 0:
            k[m] = 1.0 / coef[0]
    good = np.isfinite(k)
    if not np.any(good):
        raise ModelError("scale from the prior's gravity: no motor's current follows the prior's torque with a "
                         "positive gain: are the current columns' signs those of the model's joints?")
    k[~good] = float(np.median(k[good]))
    return k, r2


def _gravity_factor(arm, runs, k0, base, armature, friction, parts=None) -> np.ndarray:
    """Step 3: per motor, ``<g_prior, g_0> / <g_0, g_0>`` and the sums (2, n) behind it, with the base
    parameters fitted on ``parts`` (a slice of each run, default all) at the relative constants ``k0``."""
    from ..estimation.fitting import known_torque

    n = arm.n
    R = np.asarray(arm.transmission.R, dtype=np.float64)
    gain = R.T @ np.diag(k0) @ np.linalg.inv(R).T               # tau = R^T diag(k0) i, i = R^-T tau_read
    A, b, G, P = [], [], [], []
    for data, _ in runs:
        sl = slice(None) if parts is None else parts(len(data.q))
        q, qd, qdd = data.q[sl], data.qd[sl], data.qdd[sl]
        Y = base.regressor(arm.lagrange.regressor(q, qd, qdd, armature=armature, friction=friction))
        A.append(Y)
        b.append(data.tau[sl] @ gain.T - known_torque(arm, qd, qdd, armature, friction))
        Yg = np.array(arm.lagrange.regressor(q, 0 * qd, 0 * qdd, armature=armature, friction=friction))
        Yg[..., 10 * n:] = 0.0                                   # rest, and no friction (the offset is no weight)
        G.append(base.regressor(Yg))
        P.append(_motor_side(arm, arm.gravity_torque(q)))
    A, b, G, P = (np.concatenate(x) for x in (A, b, G, P))
    w = 1.0 / np.maximum(np.std(b, axis=0), 1e-12)
    for _ in range(2):                 # each joint by its torque's spread, then by its residual's
        beta = np.linalg.lstsq((A * w[None, :, None]).reshape(-1, A.shape[2]), (b * w).reshape(-1), rcond=None)[0]
        w = 1.0 / np.maximum(np.sqrt(np.mean((b - A @ beta) ** 2, axis=0)), 1e-12)
    g0 = _motor_side(arm, G @ beta)
    g0, P = g0 - g0.mean(axis=0), P - P.mean(axis=0)       # a constant is the friction offset's as much as gravity's
    return np.array([np.sum(P * g0, axis=0), np.sum(g0 * g0, axis=0)])


def constants_from_gravity(arm, runs, *, armature: bool = False, friction=False, motors=None) -> TorqueConstants:
    """``k_t`` per motor, the scale from the prior's gravity (module docstring).

    Parameters
    ----------
    arm : manipdyn.Arm
        The prior: its masses and centres of mass give the gravity torque; kinematics, ``R``.
    runs : list of (Measurements, None)
        Each run's samples, ``tau`` read from currents with unit torque constants (``tau = R^T i``).
    armature, friction
        What the fit identifies with them, as :func:`.fit` takes it.
    motors : sequence of int, optional
        The 1-based motors whose prior gravity torque sets the scale (default
        :func:`default_scale_motors`).
    """
    from ..estimation.base import base_parameters

    if any(p is not None for _, p in runs):
        raise ModelError("scale_from_gravity: a run carries a known payload, which fixes the scale itself; "
                         "leave scale_from_gravity out")
    n = arm.n
    S = default_scale_motors(arm, runs) if motors is None else check_scale_motors(motors, n)
    k_reg, r2 = _regression_constants(arm, runs)
    rel = identify_torque_constants(arm, runs, armature=armature, friction=friction, reference=S,
                                    model_constants=k_reg)
    base = base_parameters(arm, armature=armature, friction=friction)
    idx = [m - 1 for m in S]
    sums = _gravity_factor(arm, runs, rel.values, base, armature, friction)
    c = float(np.sum(sums[0, idx]) / np.sum(sums[1, idx]))
    per_motor = sums[0, idx] / sums[1, idx]
    halves = []
    for part in (lambda N: slice(0, N // 2), lambda N: slice(N // 2, N)):
        h = _gravity_factor(arm, runs, rel.values, base, armature, friction, parts=part)
        halves.append(float(np.sum(h[0, idx]) / np.sum(h[1, idx])))
    if not (np.isfinite(c) and c > 0):
        raise ModelError(f"scale from the prior's gravity: the fit's gravity torque on motor(s) {list(S)} does not "
                         f"follow the prior's (factor {c:.3g}); name other motors (scale_from_gravity) or give a "
                         "payload run")
    s_half = abs(halves[0] - halves[1]) / 2
    s_motors = float(np.std(per_motor, ddof=1) / np.sqrt(len(idx))) if len(idx) > 1 else 0.0
    s_c = max(s_half, s_motors)
    k = c * rel.values
    with np.errstate(invalid="ignore"):
        std = k * np.sqrt((rel.std / rel.values) ** 2 + (s_c / c) ** 2)
    std[~np.isfinite(rel.std)] = np.inf
    undetermined = [m + 1 for m in range(n) if not np.isfinite(rel.std[m])]
    notes = [x.replace("the model's k_t kept", "the prior's torque's (step 1) kept")
             for x in rel.notes if not x.startswith("scale from the model's k_t")]
    from ..._support import limits

    wild = [m for m in range(n) if not 0 < k[m] <= limits.MAX_TORQUE_CONSTANT]
    if wild:            # only an undetermined motor's stand-in can be so far off; it must still be a k_t
        fine = [m for m in range(n) if m not in wild and np.isfinite(std[m])] or [m - 1 for m in S]
        k[wild] = float(np.median(k[fine]))
        std[wild] = np.inf
        notes.append(f"motor(s) {[m + 1 for m in wild]}: the prior's torque gave no usable k_t either; the median "
                     f"of the determined ones ({k[wild[0]]:.4g} N m/A) stands in, not determined")
    off = [m for m in range(n) if m + 1 not in S and np.isfinite(std[m]) and not 1 / FAR < k[m] / k_reg[m] < FAR]
    if off:
        notes.append(f"motor(s) {[m + 1 for m in off]}: k_t differs from the prior's torque's (step 1) by a factor "
                     + ", ".join(f"{k[m] / k_reg[m]:.2g}" for m in off) + ": with no gravity that varies there, it "
                     "rests on inertial torques and friction, and its standard deviation counts only the noise; "
                     "trust it less than that says")
    detail = {"scale_motors": list(S), "links": [S[0], n], "factor": c,
              "factor_per_motor": [float(x) for x in per_motor],
              "factor_halves": halves, "factor_std": s_c,
              "prior_torque_constants": [float(x) for x in k_reg], "prior_torque_r2": [float(x) for x in r2],
              "undetermined": undetermined}
    return TorqueConstants(values=k, std=std, scale="gravity", reference=S, notes=notes, detail=detail)


def torque_constants(arm, runs, *, armature: bool = False, friction=False, reference=None,
                     scale_from_gravity=None) -> TorqueConstants:
    """``k_t`` per motor from current logs, the scale from wherever it can be had: a payload run or the
    model's ``k_t`` (:func:`.torque_constants.identify_torque_constants`), else, or when
    ``scale_from_gravity`` names motors, the prior's gravity (:func:`constants_from_gravity`)."""
    has_payload = any(p is not None for _, p in runs)
    if scale_from_gravity is None and (has_payload or arm.transmission.torque_constant is not None):
        return identify_torque_constants(arm, runs, armature=armature, friction=friction, reference=reference)
    if reference is not None:
        raise ModelError("torque_constant_reference: the scale comes from the prior's gravity here (no payload run, "
                         "no model k_t, or scale_from_gravity given); name its motors with scale_from_gravity")
    return constants_from_gravity(arm, runs, armature=armature, friction=friction, motors=scale_from_gravity)
