"""Torque constants from current logs: ``k_t`` per motor, with the arm's parameters.

Layer 5 (identification).

Many arms log motor currents ``i`` (A), not torques, and their torque constants
``k_t`` (N m/A at each motor) are not known.  With ``tau = R^T diag(k_t) i``
(:mod:`manipdyn.model.drive`) the motor torques are ``R^-T Y(q, qd, qdd) pi``, so each
motor's equation is linear in the base parameters ``beta`` and in ``k_t`` together
(the global identification of drive gains and dynamic parameters, Gautier and
Briot)::

    (R^-T Y_b)_m beta - i_m k_m = -(R^-T tau_known)_m      for every sample and motor m

``tau_known`` holds what the fit does not identify (the prior's armature and friction
when they are not identified) and the torque of a known payload.  Without a payload the
right side is zero except for those prior terms, and ``(beta, k_t)`` and
``(c beta, c k_t)`` fit alike: the scale comes from

* a run with a known payload (:class:`.runs.Payload`): its torque is absolute;
* or the model's ``k_t`` of the reference motors: the constraint
  ``sum_m k_m / k_m,model = |reference|`` (one reference motor: its ``k_t`` is the model's).

With neither, :func:`identify_torque_constants` refuses and says why.  Estimation:
ordinary least squares with equilibrated columns, each (run, motor) noise level from its
residuals, then weighted least squares; the covariance of the weighted problem (times the
residual variance) gives the standard deviations.  The currents enter the regressor, so
their noise biases ``k_t`` by about ``-(noise / RMS current)^2`` (1e-4 at 1 % noise):
negligible against the 2 % the synthetic target asks.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..._support.errors import ModelError

__all__ = ["TorqueConstants", "identify_torque_constants", "CURRENT_NOTE", "one_line"]

#: what :func:`~manipdyn.identification.read_log` notes when it converts currents
CURRENT_NOTE = "tau_m = k_t i"


@dataclass
class TorqueConstants:
    """``values`` (n,) N m/A and ``std`` (n,) their standard deviations; ``scale``: "payload"
    or "model" (where the scale came from); ``reference``: the 1-based motors of a model scale."""

    values: np.ndarray
    std: np.ndarray
    scale: str
    reference: tuple = ()
    notes: list = field(default_factory=list)
    detail: dict = field(default_factory=dict)      # how a gravity scale was found (:mod:`.gravity_scale`)

    def as_dict(self) -> dict:
        """JSON-ready (an undetermined motor's infinite standard deviation as None)."""
        return {"values": self.values.tolist(), "std": [float(x) if np.isfinite(x) else None for x in self.std],
                "scale": self.scale,
                "reference": list(self.reference), "notes": list(self.notes),
                **({"detail": dict(self.detail)} if self.detail else {}), "summary": one_line(self)}


def _blocks(arm, runs, base, armature, friction):
    """Per run: ``(Ym (N, n, r), current (N, n), Km (N, n))``, motor side (module docstring)."""
    from ..estimation.fitting import known_torque

    RinvT = np.linalg.inv(np.asarray(arm.transmission.R, dtype=np.float64)).T
    out = []
    for data, payload in runs:
        Yb = base.regressor(arm.lagrange.regressor(data.q, data.qd, data.qdd, armature=armature, friction=friction))
        known = known_torque(arm, data.qd, data.qdd, armature, friction)
        if payload is not None:
            known = known + payload.torque(arm, data.q, data.qd, data.qdd)
        out.append((np.einsum("mj,Njr->Nmr", RinvT, Yb), data.tau @ RinvT.T, known @ RinvT.T))
    return out


def _reduced(blocks, weights, D):
    """Per motor m, ``R_m`` (r + 2, r + 2) with ``||[Ym_m / D, i_m, Km_m] x|| = ||R_m x||`` over all
    runs' rows, each run's rows times its weight: the fit then costs O(n r^3), not O(N n r^2)."""
    n = blocks[0][1].shape[1]
    out = []
    for m in range(n):
        M = np.concatenate([np.column_stack([Ym[:, m, :] / D, i[:, m], K[:, m]]) * w[m]
                            for (Ym, i, K), w in zip(blocks, weights)])
        Rm = np.linalg.qr(M, mode="r")
        k = M.shape[1]
        out.append(np.vstack([Rm, np.zeros((max(0, k - Rm.shape[0]), k))]))
    return out


def _beta(Rs, a):
    """The base parameters (scaled) best for the inverse gains ``a`` (n,), and the residual rows."""
    r = Rs[0].shape[1] - 2
    A = np.concatenate([Rm[:, :r] * am for Rm, am in zip(Rs, a)])
    b = np.concatenate([Rm[:, r] - am * Rm[:, r + 1] for Rm, am in zip(Rs, a)])
    beta = np.linalg.lstsq(A, b, rcond=None)[0]
    return beta, b - A @ beta


def _fit_gains(Rs, a0, free):
    """Inverse gains ``a = 1 / k_t`` minimising the current residual (variable projection over
    ``log a`` of the ``free`` motors; the others held)."""
    from ..._support.deps import require

    optimize = require("scipy.optimize", "identify_torque_constants")
    a0 = np.asarray(a0, dtype=np.float64)

    def full(u):
        a = a0.copy()
        a[free] = np.exp(u)
        return a

    sol = optimize.least_squares(lambda u: _beta(Rs, full(u))[1], np.log(a0[free]), method="lm", xtol=1e-12,
                                 ftol=1e-12, max_nfev=200 * (1 + len(free)))
    return full(sol.x)


def _covariance(Rs, a, beta, free):
    """Covariance of ``(beta, a[free])`` from the weighted problem's Jacobian (times the residual
    variance per row, estimated by the caller)."""
    r = len(beta)
    cols = []
    J = np.zeros((sum(Rm.shape[0] for Rm in Rs), r + len(free)))
    row = 0
    for m, Rm in enumerate(Rs):
        k = Rm.shape[0]
        J[row:row + k, :r] = -a[m] * Rm[:, :r]
        if m in free:
            J[row:row + k, r + free.index(m)] = -(Rm[:, :r] @ beta + Rm[:, r + 1])
        row += k
    del cols
    return np.linalg.pinv(J.T @ J)


#: relative step of the profile test of :func:`_undetermined`
PROFILE_STEP = 0.1


def _undetermined(Rs, a, free, s2) -> list:
    """The free motors whose ``k_t`` the runs do not determine: scaling its ``a`` by
    ``1 + PROFILE_STEP``, the other parameters refitted, raises the residual's sum of squares by
    less than one residual variance ``s2`` (a profile likelihood: under one standard deviation)."""
    cost = float(np.sum(_beta(Rs, a)[1] ** 2))
    out = []
    for m in free:
        b = a.copy()
        b[m] *= 1.0 + PROFILE_STEP
        if float(np.sum(_beta(Rs, b)[1] ** 2)) - cost < s2:
            out.append(m)
    return out


def _linear_gains(blocks, D):
    """``k_t`` from the equations linear in ``(beta, k_t)`` with the payload's torque on the right
    (least squares): a start only, pulled towards 0 by the currents' noise."""
    n = blocks[0][1].shape[1]
    r = blocks[0][0].shape[2]
    A = np.concatenate([np.concatenate([Ym / D, -i[:, :, None] * np.eye(n)[None]], axis=2).reshape(-1, r + n)
                        for Ym, i, _ in blocks])
    b = np.concatenate([-K.reshape(-1) for _, _, K in blocks])
    k = np.linalg.lstsq(A, b, rcond=None)[0][r:]
    return np.where(k > 0, k, np.median(np.abs(k)) or 1.0)


def identify_torque_constants(arm, runs, *, armature: bool = False, friction=False,
                              reference=None, model_constants=None) -> TorqueConstants:
    """``k_t`` per motor from runs read with unit torque constants (module docstring).

    Parameters
    ----------
    arm : manipdyn.Arm
        The prior: kinematics, transmission (``R``), and what is not identified.
    runs : list of (Measurements, Payload or None)
        Each run's samples, its ``tau`` read from currents with ``k_t = 1`` (so
        ``tau = R^T i``), and its known payload (:func:`.runs.read_runs`).
    armature, friction
        What the fit identifies with them, as :func:`.fit` takes it.
    reference : sequence of int, optional
        1-based motors whose model ``k_t`` (``arm.transmission.torque_constant``) fixes
        the scale when no run carries a payload; default all of them.
    model_constants : (n,) array, optional
        Used instead of ``arm.transmission.torque_constant`` as the model's ``k_t``
        (:mod:`.gravity_scale` gives the prior's gravity's).
    """
    from ..estimation.base import base_parameters

    n = arm.n
    has_payload = any(p is not None for _, p in runs)
    kt_model = arm.transmission.torque_constant if model_constants is None else np.asarray(model_constants, float)
    notes, ref = [], ()
    if not has_payload:
        if kt_model is None:
            raise ModelError("identify_torque_constants: the torque constants' scale is unknown: currents "
                             "explain the torques only up to one factor shared with the inertial parameters. "
                             "Give a run with a known payload (RUNS.toml: payload = {mass, com}) or the model's "
                             "[transmission] torque_constant for at least one motor")
        try:
            if reference is not None and (isinstance(reference, (str, bytes)) or not all(
                    isinstance(k, (int, np.integer)) and not isinstance(k, bool) for k in reference)):
                raise TypeError          # 1.9 is no motor number (int() would make it motor 1)
            ref = tuple(range(1, n + 1)) if reference is None else tuple(int(k) for k in reference)
        except (TypeError, ValueError):
            raise ModelError(f"torque_constant_reference: expected motor numbers 1 to {n}, got {reference!r:.60}") from None
        if not ref or any(not 1 <= k <= n for k in ref):
            raise ModelError(f"torque_constant_reference: expected motors 1 to {n}, got {list(ref)}")
    elif reference is not None:
        notes.append("the scale comes from the payload run(s); torque_constant_reference is not used")
    base = base_parameters(arm, armature=armature, friction=friction)
    try:
        return _estimate(arm, runs, base, armature, friction, has_payload, kt_model, ref, notes)
    except (np.linalg.LinAlgError, FloatingPointError) as exc:
        # zero or constant currents, a payload too light to load any motor: no k_t to find
        raise ModelError(f"identify_torque_constants: the runs do not determine the torque constants ({exc}); "
                         "are the current columns all zero or constant, or the payload too light to load the "
                         "motors?") from None


def _estimate(arm, runs, base, armature, friction, has_payload, kt_model, ref, notes) -> TorqueConstants:
    """The estimate of :func:`identify_torque_constants` once its arguments are checked."""
    n = arm.n
    blocks = _blocks(arm, runs, base, armature, friction)
    D = np.sqrt(sum(np.sum(Ym**2, axis=(0, 1)) for Ym, _, _ in blocks))
    D = np.where(D > 0, D, 1.0)                            # equilibrated columns
    # start: the model's k_t, or the equations linear in (beta, k_t) (biased by the currents' noise)
    a0 = 1.0 / kt_model if kt_model is not None else 1.0 / _linear_gains(blocks, D)
    free = [m for m in range(n) if has_payload or m != ref[0] - 1]
    weights = [np.ones(n) for _ in blocks]
    for _ in range(2):             # unweighted, then each run's motors by their noise
        Rs = _reduced(blocks, weights, D)
        a = _fit_gains(Rs, a0, free)
        beta, _ = _beta(Rs, a)
        weights = [1.0 / np.maximum(s, 1e-12 * max(float(s.max()), 1e-300)) for s in
                   (np.sqrt(np.mean((i - a * (Ym @ (beta / D) + K)) ** 2, axis=0)) for Ym, i, K in blocks)]
        a0 = a
    Rs = _reduced(blocks, weights, D)
    beta, res = _beta(Rs, a)
    rows = sum(len(i) for _, i, _ in blocks) * n
    s2 = float(res @ res) / max(1, rows - len(beta) - len(free))
    cov = _covariance(Rs, a, beta, free) * s2
    var_a = np.zeros(n)
    var_a[free] = np.diag(cov)[len(beta):]
    k, std = 1.0 / a, np.sqrt(np.clip(var_a, 0.0, None)) / a**2
    lost = _undetermined(Rs, a, free, s2)
    if lost:
        std[lost] = np.inf
        if kt_model is None:
            # an arbitrary number (1e16 did) must not be written into a model as if it were measured
            raise ModelError(f"identify_torque_constants: motor(s) {[m + 1 for m in lost]}: k_t is not determined by "
                             f"these runs (a {100 * PROFILE_STEP:g} % change, with the other parameters refitted, "
                             "moves the residual by less than one standard deviation); add a run with a known "
                             "payload that loads those motors, or give the model's [transmission] torque_constant "
                             "(then kept for them)")
        keep = "the model's k_t kept"
        notes.append(f"motor(s) {[m + 1 for m in lost]}: k_t not determined by these runs (a {100 * PROFILE_STEP:g} % "
                     f"change, with the other parameters refitted, moves the residual by less than one standard "
                     f"deviation: the parameters refitted with it absorb the change, as its friction and rotor "
                     f"inertia always can and gravity can when the runs hold too few postures); {keep}; a run with a known payload that loads it determines it")
        if kt_model is not None:
            k[lost] = kt_model[lost] * (k[ref[0] - 1] / kt_model[ref[0] - 1] if ref else 1.0)
    if not has_payload:            # the scale: sum over the reference motors of k / k_model = |reference|
        c = len(ref) / float(sum(k[j - 1] / kt_model[j - 1] for j in ref))
        k, std = k * c, std * c
        if len(ref) > 1:
            notes.append(f"scale from the model's k_t of motors {list(ref)} (their mean ratio to it is 1)")
    if np.any(k <= 0):
        bad = [int(j) + 1 for j in np.flatnonzero(k <= 0)]
        raise ModelError(f"identify_torque_constants: motor(s) {bad} come out with k_t <= 0 ({k[k <= 0].tolist()}): "
                         "the current columns' signs or the transmission's gear-ratio signs disagree")
    return TorqueConstants(values=k, std=std, scale="payload" if has_payload else "model", reference=ref,
                           notes=notes)


def one_line(tc) -> str:
    """The torque constants in one line: their values, standard deviations and where the scale came from."""
    d = dict(getattr(tc, "detail", None) or {})
    if tc.scale == "gravity":
        S = d.get("scale_motors", list(tc.reference))
        lo, n = d.get("links", [S[0], len(tc.values)])
        where = (f"the prior's gravity torque on joint(s) {', '.join(map(str, S))} (the masses and centres of "
                 f"mass of links {lo} to {n})")
    elif tc.scale == "payload":
        where = "the known payload"
    else:
        where = f"the model's k_t of motor(s) {', '.join(map(str, tc.reference))}"
    cells = []
    for j, (v, s) in enumerate(zip(tc.values, tc.std)):
        if s is None or not np.isfinite(s):
            cells.append(f"k{j + 1} {v:.4g} (not determined by the runs)")
        else:
            cells.append(f"k{j + 1} {v:.4g} +- {s:.2g}")
    return f"torque constants from the currents, N m/A, scale from {where}: " + ", ".join(cells)
