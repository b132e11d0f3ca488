"""Payload identification: the ten inertial parameters of a load carried by a known arm.

Layer 5 (identification).

The arm (links, armature, friction) is taken as known; a rigid payload fixed
to link ``k`` (the last link by default, at the tool frame) only adds its
pseudo-inertia to that link's (eq. 2.20: pseudo-inertias in one frame add).
The torque it causes is therefore linear in its ten parameters
``pi_P = [m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]``
(Pinocchio's order, tensor about the payload frame's ORIGIN, payload-frame
axes)::

    tau - tau_arm(q, qd, qdd) = Y_k(q, qd, qdd) G pi_P + e

with ``tau_arm = arm.inverse_dynamics`` (Pinocchio), ``Y_k`` the ten
regressor columns of link k (:meth:`TraceFormEngine.regressor`, URDF link
frame ``L_k``) and ``G`` (10, 10) the linear map from payload-frame to
link-frame parameters: column ``j`` is
``parameters_from_pseudo_inertia(transform_pseudo_inertia(E_j, X))`` with
``E_j`` the basis of :data:`manipdyn.model.parameters.PARAMETER_BASIS` and ``X`` the
payload frame in ``L_k`` (the conversions of :mod:`manipdyn.model.inertia`).

Estimation:

1. each joint's noise level ``sigma_j`` the way Gautier does it (as
   :func:`~manipdyn.identification.fit` does): joint j's equations alone are
   fitted by ordinary least squares, ``sigma_j^2 = ||rho_j||^2 / (N - r_j)``
   with ``r_j`` the rank of its 10 columns (the pooled fit would leave the
   large proximal joints' noise in the small wrist torques); floored at
   ``1e-6`` of the largest joint's RMS torque (exact data then weigh the
   joints equally);
2. weighted least squares (rows divided by ``sigma_j``): the covariance
   ``(A^T A)^-1`` gives the standard deviations; mass and COM by the delta
   method (``c = h / m``).  Directions the data do not excite (the equilibrated
   weighted regressor's singular values below ``1e-10`` of the largest) get an
   infinite standard deviation;
3. the reported payload, two small semidefinite programs (Clarabel, then
   SCS): (a) ``min ||A pi - b||`` subject to the payload's pseudo-inertia
   ``J >= EPS I``; (b) among the payloads whose misfit is within
   ``FIT_SLACK`` (relative) of (a)'s, the one of least second moment
   ``tr(J[:3, :3])``.  When the data determine every parameter, (b) moves
   the answer by ~1e-3 standard deviations; when the rotations do not excite
   the inertia, the payload is the point mass at the identified COM (the
   body of least inertia with that mass and COM), not an arbitrary point of
   a flat face.  If (b) fails, (a)'s answer is kept.

A parameter is reported as poorly determined when its standard deviation
exceeds ``rtol`` (default 10 %) of its scale: ``m`` for the mass, ``m l``
for the first moments and ``m l^2`` for the second moments, with ``l`` the
payload's size (argument ``length``, default 0.1 m).  With small rotations
typically only the mass and COM (four parameters) are determined.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..._support.errors import ModelError
from ..._support.limits import check_signals
from ...model.inertia import (LINK_PARAMETERS, parameters_from_pseudo_inertia, tensor_from_pseudo_inertia,
                       transform_pseudo_inertia)
from ...model.parameters import PARAMETER_BASIS
from ..._support.deps import require
from ..estimation.fitting import joint_noise
from ..estimation.sdp import EPS, solve_problem

__all__ = ["PayloadResult", "identify_payload", "payload_parameter_map"]

#: weight of step 3a's pull towards the least second moment (it makes the minimiser unique)
REG = 1e-7
#: relative growth of the misfit allowed when picking the least-inertia payload (step 3b)
FIT_SLACK = 1e-6
#: singular values below this fraction of the largest: directions the data do not see
RANK_RTOL = 1e-10


def payload_parameter_map(X) -> np.ndarray:
    """``G`` (10, 10): link-frame parameters ``= G @`` payload-frame parameters.

    ``X`` (4, 4) is the payload frame in the link frame (maps a point's
    payload-frame coordinates to link-frame coordinates).  Linear because
    ``J_link = X J_payload X^T`` is (:func:`manipdyn.model.inertia.transform_pseudo_inertia`).
    """
    return parameters_from_pseudo_inertia(transform_pseudo_inertia(PARAMETER_BASIS, X)).T


@dataclass
class PayloadResult:
    """Result of :func:`identify_payload` (SI units, payload frame).

    Attributes
    ----------
    mass : float
        kg.
    com : (3,)
        Centre of mass in the payload frame, m.
    inertia : (3, 3)
        Inertia tensor about the COM, payload-frame axes, tensor sign, kg m^2.
    J : (4, 4)
        Pseudo-inertia in the payload frame (eq. 2.20), positive semidefinite.
    parameters : (10,)
        ``[m, m c, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]``, tensor about the
        payload frame's origin (the consistent estimate).
    parameters_wls : (10,)
        The unconstrained weighted least-squares estimate (minimum norm in
        equilibrated units if the data do not excite every parameter).
    parameter_std : (10,)
        Standard deviations of the WLS estimate (inf: not excited).
    mass_std : float
        kg.
    com_std : (3,)
        m (delta method on ``c = h / m``).
    residuals : (N, n)
        Residual torque minus the payload's predicted torque, N m or N.
    sigma : (n,)
        Per-joint noise level, N m or N.
    condition_number : float
        Of the weighted regressor with its columns scaled to unit norm (inf
        when some parameter is not excited at all).
    solver : str
        The semidefinite program's solver ("CLARABEL", "SCS", ...).
    poorly_determined : tuple of str
        Names (:data:`manipdyn.model.inertia.LINK_PARAMETERS`) of the parameters
        whose standard deviation exceeds ``rtol`` of their scale.
    notes : list of str
        Readable remarks (which parameters are poorly determined and why).
    link : int
        0-based index of the link carrying the payload.
    frame : (4, 4)
        Payload frame in that link's URDF frame (``L_k``).
    """

    mass: float
    com: np.ndarray
    inertia: np.ndarray
    J: np.ndarray
    parameters: np.ndarray
    parameters_wls: np.ndarray
    parameter_std: np.ndarray
    mass_std: float
    com_std: np.ndarray
    residuals: np.ndarray
    sigma: np.ndarray
    condition_number: float
    solver: str
    poorly_determined: tuple
    link: int
    frame: np.ndarray
    arm: object = None
    notes: list = field(default_factory=list)

    def predict(self, q, qd, qdd) -> np.ndarray:
        """Torque of the arm carrying the payload, (N, n) or (n,): arm's torque plus ``Y_k G pi``."""
        Y = self.arm.lagrange.regressor(q, qd, qdd)[..., 10 * self.link:10 * self.link + 10]
        return self.arm.inverse_dynamics(q, qd, qdd) + Y @ (payload_parameter_map(self.frame) @ self.parameters)

    def arm_with_payload(self, name: str | None = None):
        """The arm carrying the identified payload (a new arm of the same kind, DH or URDF).

        On the last link this is ``arm.with_payload`` (:func:`manipdyn.model.variants.with_payload`)
        with the payload expressed in the tool frame; on another link, the link's parameters plus
        the payload's (:func:`.model.arm_with_parameters`).
        """
        from ...model.arm import Manipulator, URDFArm
        from ...model.kinematics import transform_inverse
        from ...model.parameters import arm_parameters

        arm = self.arm
        if not isinstance(arm, (Manipulator, URDFArm)):
            raise ModelError(f"arm_with_payload: needs an arm (manipdyn.Manipulator or manipdyn.URDFArm), got "
                             f"{type(arm).__name__}")
        J_link = transform_pseudo_inertia(self.J, self.frame)        # URDF link frame L_k
        name = name if name is not None else f"{arm.name or 'arm'}+payload"
        if self.link == arm.n - 1:
            from ...model.variants import with_payload

            _, tool = arm.chain()                                      # tool frame = L_n tool (DH: frame n)
            m, c, I = tensor_from_pseudo_inertia(transform_pseudo_inertia(J_link, transform_inverse(tool)),
                                                 name="payload")
            return with_payload(arm, m, c, I, name=name)
        from ..estimation.model import arm_with_parameters

        pi = arm_parameters(arm)
        pi[10 * self.link:10 * self.link + 10] += parameters_from_pseudo_inertia(J_link)
        return arm_with_parameters(arm, pi, name=name)

    def as_dict(self) -> dict:
        """JSON-ready figures (what ``manipdyn identify --payload --json`` would print)."""
        return {"mass": self.mass, "mass_std": self.mass_std, "com": self.com.tolist(),
                "com_std": self.com_std.tolist(), "inertia": self.inertia.tolist(),
                "parameters": dict(zip(LINK_PARAMETERS, self.parameters.tolist())),
                "parameter_std": dict(zip(LINK_PARAMETERS, self.parameter_std.tolist())),
                "noise_sigma": self.sigma.tolist(),
                "rms_residual": np.sqrt(np.mean(self.residuals**2, axis=0)).tolist(),
                "condition_number": self.condition_number, "solver": self.solver,
                "poorly_determined": list(self.poorly_determined), "link": self.link + 1,
                "notes": list(self.notes)}


def _attachment(arm, link, frame):
    """``(k, X)``: 0-based link index and the payload frame in the URDF link frame L_k."""
    joints, tool = arm.chain()
    if frame is None:
        F = np.eye(4)
    else:
        try:
            F = np.array(frame, dtype=np.float64)
        except (TypeError, ValueError):
            raise ModelError(f"frame: expected a 4x4 homogeneous transform, got {frame!r}") from None
        if F.shape != (4, 4) or not np.all(np.isfinite(F)):
            raise ModelError(f"frame: expected a finite 4x4 homogeneous transform, got shape {F.shape}")
        R = F[:3, :3]
        if (not np.allclose(F[3], [0, 0, 0, 1], atol=1e-9)
                or not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0):
            raise ModelError("frame: expected a homogeneous transform (rotation part orthonormal "
                             "with det +1, last row [0, 0, 0, 1])")
    if link is None:
        return arm.n - 1, tool @ F
    names = [j.link_name or f"link{i + 1}" for i, j in enumerate(joints)]
    if not isinstance(link, str) or link not in names:
        raise ModelError(f"link: no link named {link!r} in {arm.name!r}; the links are "
                         f"{', '.join(names)} (or None for the tool frame)")
    return names.index(link), F


def _check(arm, q, qd, qdd, tau):
    n = arm.n
    arrays = []
    for nm, x in (("q", q), ("qd", qd), ("qdd", qdd), ("tau", tau)):
        try:
            a = np.asarray(x, dtype=np.float64)
        except (TypeError, ValueError):
            raise ModelError(f"{nm}: expected real numbers of shape (N, {n})") from None
        if a.ndim != 2 or a.shape[1] != n:
            raise ModelError(f"{nm}: expected shape (N, {n}), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ModelError(f"{nm}: must be finite (row {int(np.argwhere(~np.isfinite(a))[0, 0])})")
        arrays.append(a)
    check_signals("data", q=arrays[0], qd=arrays[1], qdd=arrays[2], tau=arrays[3])
    counts = [a.shape[0] for a in arrays]
    if len(set(counts)) != 1:
        raise ModelError(f"q, qd, qdd, tau: expected the same number of samples, got {counts}")
    if counts[0] * n < 10:
        raise ModelError(f"data: {counts[0]} samples give {counts[0] * n} equations for the "
                         "payload's 10 parameters")
    return arrays


def _consistent(A, b, x_wls, length):
    """Step 3 of the module docstring: ``(pi, solver)``."""
    cp = require("cvxpy", "payload identification")
    Rb = np.linalg.qr(np.column_stack([A, b]), mode="r")
    R, c = Rb[:10, :10], Rb[:10, 10]
    x = cp.Variable(10)
    J = sum(x[k] * PARAMETER_BASIS[k] for k in range(10))
    psd = [J - EPS * np.eye(4) >> 0]
    # the misfit in units of the data (weighted: one noise sigma per equation); a payload whose
    # whole signal is below one sigma (no payload: bare-arm torques) is measured against that
    scale = max(float(np.linalg.norm(c)), 1.0)
    tref = max(abs(float(x_wls[0])), 1e-3) * length**2       # kg m^2, the size of a second moment
    trace_S = cp.trace(J[:3, :3]) / tref
    fit = cp.norm(R @ x - c) / scale
    solver = solve_problem(cp.Problem(cp.Minimize(fit + REG * trace_S), psd), "payload (fit)")
    x1 = np.asarray(x.value, dtype=np.float64)
    # (b) the least second moment among the best fits: the misfit may grow by
    # FIT_SLACK relative (parameters move by ~sqrt(2 FIT_SLACK) standard deviations)
    best = float(np.linalg.norm(R @ x1 - c)) / scale
    try:
        solve_problem(cp.Problem(cp.Minimize(trace_S), psd + [fit <= best * (1 + FIT_SLACK) + 1e-9]),
                      "payload (least inertia)", solvers=("CLARABEL",))
        x2 = np.asarray(x.value, dtype=np.float64)
        if float(np.linalg.norm(R @ x2 - c)) / scale <= best * (1 + 10 * FIT_SLACK) + 1e-8:
            return x2, solver
    except ModelError:
        pass
    return x1, solver      # (a)'s answer: as good a fit, and physical


def identify_payload(arm, q, qd, qdd, tau, link: str | None = None, frame=None, rtol: float = 0.1,
                     length: float = 0.1) -> PayloadResult:
    """Identify a rigid payload carried by ``arm`` (module docstring).

    Parameters
    ----------
    arm : manipdyn.Arm
        The arm WITHOUT the payload, taken as known (its torque
        ``arm.inverse_dynamics`` is subtracted from ``tau``).
    q, qd, qdd, tau : (N, n)
        Joint positions, velocities, accelerations and measured torques (SI).
    link : str, optional
        Name of the link carrying the payload (a link of ``arm.chain()``);
        default None: the last link, payload frame at the tool frame
        (the frame of ``arm.fkine``).
    frame : (4, 4), optional
        The payload frame in the attachment frame (the tool frame, or the
        named link's URDF frame); default identity.
    rtol : float
        A parameter whose standard deviation exceeds ``rtol`` of its scale is
        poorly determined (module docstring).
    length : float
        Size of the payload, m, setting the scale of first and second moments.

    Raises :class:`ModelError` for wrong shapes, non-finite data, too few
    samples, an unknown link or a malformed frame.
    """
    if not (isinstance(rtol, (int, float)) and rtol > 0):
        raise ModelError(f"rtol: expected a positive number, got {rtol!r}")
    if not (isinstance(length, (int, float)) and np.isfinite(length) and length > 0):
        raise ModelError(f"length: expected a positive length in m, got {length!r}")
    q, qd, qdd, tau = _check(arm, q, qd, qdd, tau)
    k, X = _attachment(arm, link, frame)
    N, n = q.shape
    Y = arm.lagrange.regressor(q, qd, qdd)[..., 10 * k:10 * k + 10] @ payload_parameter_map(X)  # (N, n, 10)
    r = tau - arm.inverse_dynamics(q, qd, qdd)                # what the payload explains

    # 1. per-joint noise, each joint's own OLS fit
    sigma = joint_noise(Y, r)             # each joint's own OLS fit, as fit() weighs wls
    floor = 1e-6 * max(float(np.sqrt(np.mean(tau**2, axis=0)).max()), 1e-300)
    sigma = np.maximum(sigma, floor)

    # 2. WLS on columns scaled to unit norm; covariance; excitation
    w = 1.0 / sigma
    A, b = (Y * w[None, :, None]).reshape(-1, 10), (r * w).reshape(-1)
    d = np.linalg.norm(A, axis=0)
    unexcited = d <= RANK_RTOL * max(float(d.max()), 1e-300)
    d = np.where(unexcited, 1.0, d)
    U, s, Vt = np.linalg.svd(A / d, full_matrices=False)
    good = s > RANK_RTOL * s[0] if s[0] > 0 else np.zeros(10, bool)
    cond = float(s[0] / s[-1]) if np.all(good) else float("inf")
    inv_s = np.where(good, 1.0 / np.where(good, s, 1.0), 0.0)
    x_wls = (Vt.T @ (inv_s * (U.T @ b))) / d
    cov = (Vt.T * inv_s**2) @ Vt / np.outer(d, d)
    blind = np.any(np.abs(Vt[~good]) > 1e-6, axis=0) | unexcited   # touched by an unseen direction
    std = np.sqrt(np.clip(np.diag(cov), 0, None))
    std[blind] = np.inf

    # 3. the physically consistent payload
    pi, solver = _consistent(A, b, x_wls, float(length))
    m, h = float(x_wls[0]), x_wls[1:4]
    if np.isfinite(std[:4]).all() and m > 0:
        Gc = np.column_stack([-h / m**2, np.eye(3) / m])           # d(h/m)/d(m, h)
        com_std = np.sqrt(np.clip(np.diag(Gc @ cov[:4, :4] @ Gc.T), 0, None))
    else:
        com_std = np.full(3, np.inf)
    J = sum(pi[j] * PARAMETER_BASIS[j] for j in range(10))
    J = 0.5 * (J + J.T)
    mass, com, inertia = tensor_from_pseudo_inertia(J, name="payload")

    ref = max(abs(mass), 1e-300) * np.array([1.0] + [length] * 3 + [length**2] * 6)
    poor = tuple(nm for nm, sd, rf in zip(LINK_PARAMETERS, std, ref) if not sd <= rtol * rf)
    notes = []
    if poor:
        names = ", ".join(poor)
        notes.append(f"the data do not determine {names} well (standard deviation above "
                     f"{rtol:g} of m, m l, m l^2 with l = {length:g} m): excite more rotation of "
                     "the payload" + ("; mass and COM are determined" if not set(poor) & set(LINK_PARAMETERS[:4])
                                      else ""))
    if mass <= 10 * EPS:
        notes.append("the identified mass is zero to the solver's accuracy: no payload is seen")
    return PayloadResult(mass=mass, com=com, inertia=inertia, J=J, parameters=pi, parameters_wls=x_wls,
                         parameter_std=std, mass_std=float(std[0]), com_std=com_std,
                         residuals=r - Y @ pi, sigma=sigma, condition_number=cond, solver=solver,
                         poorly_determined=poor, link=k, frame=X, arm=arm, notes=notes)
