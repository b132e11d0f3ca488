"""Estimation of the inertial parameters from joint data: ``fit``.

Layer 5 (identification).

Model: ``tau = Y(q, qd, qdd) pi + e`` with the regressor of
:meth:`TraceFormEngine.regressor` and the layout of :mod:`manipdyn.model.parameters`.
Only the base parameters ``beta = K pi`` (:mod:`.base`) are identifiable:
``tau = Y_b beta + e``.  Methods:

* ``ols``: ordinary least squares on beta;
* ``wls``: weighted least squares, each joint's rows divided by its noise
  level ``sigma_j``, estimated from OLS residuals the way Gautier does it:
  joint j's equations alone, ``tau_j = Y_b,j beta``, are solved by OLS
  over the ``r_j`` base parameters that appear in them, and
  ``sigma_j^2 = ||rho_j||^2 / (N - r_j)``.  (The residuals of the pooled
  OLS fit would not do: that fit is dominated by the large proximal torques
  and leaves misfit, not noise, in the small wrist torques.)  A noise level
  below ``1e-6`` of that joint's own RMS torque is rounding (exact data): it is
  weighed as ``1e-6`` of the largest joint's RMS torque, and named (:mod:`.noise`);
* ``consistent``: the same weighted objective over the full parameters
  subject to ``J_i >= 0`` for every link (:mod:`.sdp`).

The returned arm has full parameters reproducing the identified beta; among
those, the closest to the prior (least squares; for ``consistent`` with
``J_i >= 0``).  What is not identified (armature without ``armature=True``,
friction without ``friction=True``) keeps the prior's values, and its torque
is subtracted from the measurements before the fit.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..._support.state import state_array
from ..._support.errors import ModelError, StateError
from ..._support import limits
from ..._support.limits import check_fit_size
from ...model.inertia import pseudo_inertia_from_parameters
from ...model.parameters import arm_parameters  # noqa: F401 (read here by callers of this module)
from .prior import prior_parameters
from .model import arm_with_parameters
from .base import BaseParameters, base_parameters, check_base
from .sdp import Bounds, consistent_fit
from ...formats.logs.measurements import segment_edges
from .covariance import base_covariance
from .factors import (joint_factors, joint_noise, known_torque, moving_mean_square, noise_from_factors,  # noqa: F401
                      nonnegative_extras, stack_factors, stacked, still_rows)
from .noise import floor_noise
from .report import FLOOR_DROPPED, build_report, shortfall
from ...model.friction_rest import at_rest_velocity

__all__ = ["fit", "FitResult", "METHODS", "link_min_eigenvalues", "known_torque", "joint_noise"]

METHODS = ("ols", "wls", "consistent")

#: largest condition number of the stacked base regressor that ``ols`` and ``wls`` accept.
#: Above it the data do not excite every base parameter: float64 leaves fewer than 6
#: significant digits in the worst-determined direction and the estimate there is noise
#: (zero or constant motion, a column scaled by 1e30).
MAX_CONDITION = 1e10
#: the same for ``consistent``, whose constraints (J_i >= 0 and the plausibility bounds)
#: still pin down what the data leave open, up to where float64 has ~2 digits left.
#: Both are module attributes: raise them only for data you know to be exact.
MAX_CONDITION_CONSISTENT = 1e14


def link_min_eigenvalues(pi, n: int) -> np.ndarray:
    """Smallest eigenvalue of each link's pseudo-inertia J_i (n,) from full parameters (p,)."""
    J = pseudo_inertia_from_parameters(np.asarray(pi)[:10 * n].reshape(n, 10))
    return np.linalg.eigvalsh(J)[:, 0]


@dataclass
class FitResult:
    """Result of :func:`fit`.

    Attributes
    ----------
    arm : manipdyn.Manipulator or None
        The identified arm (None when its parameters cannot be written, e.g.
        a negative mass from ``ols``; ``arm_error`` says why).
    parameters : (p,)
        Full parameter vector (layout of :mod:`manipdyn.model.parameters`).
    base : BaseParameters
    beta : (r,)
        Identified base parameters.
    residuals : (N, n)
        Measured minus predicted torque on the fit data, N m or N.
    sigma : (n,)
        Per-joint noise level from each joint's own OLS residuals (N m or N).
    method : str
    condition_number : float
        Of the base regressor stacked over the data.
    consistent : bool
        Every link's J_i >= 0 (smallest eigenvalue >= 0).
    covariance : (r, r) or None
        Covariance of ``beta`` for ``wls`` and ``consistent`` (:mod:`.uncertainty`);
        None for ``ols``.
    report : dict
        The figures of ``manipdyn identify --json``.  For ``consistent`` also
        ``relative_residual`` and ``least_squares_relative_residual`` (norm of the weighted
        residual over the weighted torque's, for this fit and the unconstrained optimum),
        ``stopped_short`` (the solver stopped before the best physical fit) and ``fit_notes``
        (why the fit leaves more than least squares: the constraints it sits on, or the solver).
    """

    arm: object
    parameters: np.ndarray
    base: BaseParameters
    beta: np.ndarray
    residuals: np.ndarray
    sigma: np.ndarray
    method: str
    condition_number: float
    consistent: bool
    prior: object = None
    arm_error: str | None = None
    covariance: np.ndarray | None = None     # (r, r) of beta, wls and consistent (.uncertainty)
    report: dict = field(default_factory=dict)
    rest: np.ndarray | None = None           # (n,) rest threshold, rad/s: fit's ``rest``

    @property
    def n(self) -> int:
        return self.prior.n

    @property
    def name(self) -> str:
        return f"{self.method} fit"

    def inverse_dynamics(self, q, qd, qdd) -> np.ndarray:
        """:meth:`predict`, under the name every model has (so a fit can be scored by
        :func:`manipdyn.identification.results.validation.validate`)."""
        return self.predict(q, qd, qdd)

    def predict(self, q, qd, qdd) -> np.ndarray:
        """Torques of the identified model, (N, n) or (n,): ``Y_b beta`` plus the prior's
        armature and friction torques where those were not identified."""
        b = self.base
        qd = qd if self.rest is None else at_rest_velocity(qd, self.rest)
        Y = self.prior.lagrange.regressor(q, qd, qdd, armature=b.armature, friction=b.friction)
        return b.regressor(Y) @ self.beta + known_torque(self.prior, qd, qdd, b.armature, b.friction)


def _check(q, qd, qdd, tau, n):
    """The four data arrays as native float64 (N, n), validated as the dynamics calls do
    (:func:`manipdyn._support.state.state_array`: bool, complex, object, string, datetime and masked
    entries refused, other byte orders and integer dtypes converted), or a :class:`ModelError`."""
    arrays = []
    for name, x in (("q", q), ("qd", qd), ("qdd", qdd), ("tau", tau)):
        try:
            a = state_array(x, name, n)
        except StateError as exc:
            raise ModelError(str(exc).replace(f"shape ({n},) or (N, {n})", f"shape (N, {n})")) from None
        if a.ndim != 2 or a.shape[1] != n:
            raise ModelError(f"{name}: expected shape (N, {n}), got {a.shape}")
        bad = ~np.isfinite(a)
        if bad.any():
            i, j = (int(k) for k in np.argwhere(bad)[0])
            raise ModelError(f"{name}: must be finite; row {i}, column {j} is {float(a[i, j])!r}")
        arrays.append(a)
    if len({a.shape[0] for a in arrays}) != 1:
        raise ModelError(f"q, qd, qdd, tau: expected the same number of samples, got "
                         f"{[a.shape[0] for a in arrays]}")
    return arrays


def fit(arm, q, qd, qdd, tau, method: str = "wls", friction: bool = False, armature: bool = False,
        bounds: Bounds | str | None = "plausible", base: BaseParameters | None = None,
        name: str | None = None, prior_weight: float = 0.0, metadata=None, regressor=None,
        factors=None, *, segments=None, complete: bool = True, extra_scale=None, rest=None) -> FitResult:
    """Identify ``arm``'s parameters from samples (module docstring).

    Parameters
    ----------
    arm : manipdyn.Manipulator
        Kinematics and prior (the start of the full-parameter choice; they do not bias beta).
    q, qd, qdd, tau : (N, n)
        Joint positions, velocities, accelerations and torques (SI), validated as the dynamics
        validate states (:func:`manipdyn._support.state.state_array`); a :class:`ModelError` names the argument.
    method : "ols" | "wls" | "consistent"
    friction : bool or friction spec
        ``True``: viscous and Coulomb friction (sharp sign, joint side); or which friction
        terms to identify, as the regressor's ``friction=`` takes them
        (:func:`manipdyn.model.friction.friction_spec`): term names such as
        ``("viscous", "coulomb", "offset")``, a :class:`manipdyn.FrictionTerms` (side,
        smoothing ``tanh(v / v_s)``), or a :class:`manipdyn.Friction` whose nonlinear
        shapes (Stribeck, sigmoid) are held fixed.  In ``consistent`` every coefficient is
        constrained >= 0 except the offsets.
    armature : bool
        Identify the motors' reflected rotor inertias.
    bounds : Bounds, "plausible" or None
        Extra constraints of ``consistent`` (mass ranges, COM boxes, total mass).  The
        default ``"plausible"`` is :meth:`Bounds.plausible` around the prior (masses +-50 %, COMs
        +-0.1 m, total mass +-25 %, a radius-of-gyration floor: dropped when the solve with it fails);
        None leaves only ``J_i >= 0``; ignored by ols/wls.  Active bounds: ``report["active_bounds"]``.
    prior_weight : float
        ``consistent`` only: weight of the entropic pull of each body towards the prior's
        (:func:`manipdyn.identification.estimation.sdp.consistent_fit`); 0 (the default) fits the
        data alone.
    metadata : (source, sources, description), optional
        Citation of the identified arm (:func:`.provenance.model_metadata`); default: the
        prior's.
    base : BaseParameters, optional
        Reuse a :func:`base_parameters` result of this arm with the same armature/friction
        flags (checked on the numbers: :func:`.base.check_base`; another arm's is refused).
    name : str, optional
        Name of the identified arm.
    regressor : (N, n, p) array, optional
        ``arm.lagrange.regressor(q, qd, qdd, armature=armature, friction=friction)`` when the
        caller already has it (cross-validation slices one regressor into folds:
        :mod:`.selection`); its shape is checked, its numbers are trusted.
    factors : (n, r + 1, r + 1) array, optional
        :func:`joint_factors` of these samples' base regressor and torques (less the known
        torques), when the caller has them (cross-validation stacks them from blocks).
    segments : sequence of int, optional
        The runs' sample counts (:func:`.runs.stack`): each run's joints weighed by their noise in
        it (``report["noise_sigma_per_run"]``; ``sigma`` their RMS); not with ``factors``.
    complete : bool
        ``ols`` and ``wls``: when a body of the least-squares answer is no physical body, look for
        physical bodies with the same base parameters (:func:`manipdyn.model.completion.complete_parameters`)
        and write those (``report["completion"]`` says what was found, and how far the nearest physical
        arm is when none has them).  Folds of a cross-validation, which need only the base
        parameters, pass False.
    rest : (n,) or float, optional
        Rest threshold, rad/s (:mod:`manipdyn.model.friction_rest`): joint j's samples with
        ``|qd_j| <= rest_j`` are at rest, their velocity taken as 0 (no Coulomb torque on the noise's
        sign) and their rows left out of joint j's least squares (the torque there holds an unknown
        static friction); :meth:`FitResult.predict` applies the same threshold.
    extra_scale : (p - 10 n,) positive array, optional
        ``consistent`` with ``prior_weight > 0``: the scale of each armature, friction coefficient and
        offset (SI units) for the pull of those entries towards the prior's
        (:func:`manipdyn.identification.estimation.sdp.consistent_fit`, which checks it); None (the
        default): no such pull.
    """
    if method not in METHODS:
        raise ModelError(f"method: expected one of {', '.join(METHODS)}, got {method!r}")
    if isinstance(bounds, str):
        if bounds != "plausible":
            raise ModelError(f"bounds: expected a Bounds, 'plausible' or None, got {bounds!r}")
        bounds = Bounds.plausible(arm) if method == "consistent" else None
    if bounds is not None and not isinstance(bounds, Bounds):
        raise ModelError(f"bounds: expected a Bounds, 'plausible' or None, got {type(bounds).__name__}")
    if bounds is not None and method != "consistent":
        raise ModelError("bounds: only the 'consistent' method takes bounds")
    if bounds is not None:
        bounds.check(arm.n)
    if not (0.0 <= float(prior_weight) <= limits.MAX_PRIOR_WEIGHT):
        raise ModelError(f"prior_weight: expected a number in [0, {limits.MAX_PRIOR_WEIGHT:g}] "
                         f"(manipdyn.limits.MAX_PRIOR_WEIGHT), got {prior_weight}")
    if prior_weight and method != "consistent":
        raise ModelError("prior_weight: only the 'consistent' method takes a prior weight")
    if extra_scale is not None and method != "consistent":
        raise ModelError("extra_scale: only the 'consistent' method takes an extra scale")
    n = arm.n
    q, qd, qdd, tau = _check(q, qd, qdd, tau, n)
    qd, keep = still_rows(qd, rest)       # the joints at rest: still, and out of their own rows (friction_rest)
    if rest is not None:
        rest = np.broadcast_to(np.asarray(rest, dtype=np.float64), (n,)).copy()
    # no MAX_SIGNAL cap: logs are capped where read; the fit is unit-independent (test_fit_scaling)
    if not np.any(tau):
        raise ModelError("tau: every torque of every joint is 0; a logged torque is never exactly 0 "
                         "throughout (a missing column, or the wrong one?)")
    if base is None:
        base = base_parameters(arm, armature=armature, friction=friction)
    else:
        check_base(base, arm, armature, friction)
    N, r = len(q), base.count
    check_fit_size(N, n, len(base.names))
    if N * n < r:
        raise ModelError(f"data: {N} samples give {N * n} equations for {r} base parameters")
    if regressor is None:
        regressor = arm.lagrange.regressor(q, qd, qdd, armature=armature, friction=friction)
    elif np.shape(regressor) != (N, n, len(base.names)):
        raise ModelError(f"regressor: expected shape ({N}, {n}, {len(base.names)}) (the samples' full "
                         f"regressor), got {np.shape(regressor)}")
    Yb = base.regressor(regressor)
    y = tau - known_torque(arm, qd, qdd, armature, friction)
    Yf, yf = (Yb, y) if keep is None else (Yb * keep[:, :, None], y * keep)     # the rows each joint fits
    edges = segment_edges(segments, N)
    if segments is not None and factors is not None:
        raise ModelError("factors, segments: give one (factors hold no run boundaries)")
    runs = [joint_factors(Yf[a:b], yf[a:b]) for a, b in zip(edges[:-1], edges[1:])] if len(edges) > 2 else None
    if runs is not None:         # each run's factors: its own noise levels, then its weights
        factors = stack_factors(runs)
    elif factors is None:
        factors = joint_factors(Yf, yf)
    elif np.shape(factors) != (n, r + 1, r + 1):
        raise ModelError(f"factors: expected shape ({n}, {r + 1}, {r + 1}), got {np.shape(factors)}")
    R0, c0, _ = stacked(factors)
    s = np.linalg.svd(R0, compute_uv=False)              # the singular values of the stacked Y_b
    cond = float(s[0] / s[-1]) if s[-1] > 0 else float("inf")
    limit = MAX_CONDITION_CONSISTENT if method == "consistent" else MAX_CONDITION
    if not cond <= limit:
        raise ModelError(f"data: the base regressor's condition number is {cond:.3g}, over the {method} "
                         f"threshold {limit:.0e}: the motion does not excite every base parameter (is q "
                         f"constant, or a column scaled wrongly?); use an excitation trajectory "
                         f"(manipdyn excite)")
    counts = np.diff(edges)
    rows = [k if keep is None else keep[a:b].sum(axis=0) for k, a, b in zip(counts, edges[:-1], edges[1:])]
    sigmas = (np.array([noise_from_factors(F, k) for F, k in zip(runs, rows)]) if runs is not None
              else noise_from_factors(factors, N if keep is None else keep.sum(axis=0))[None, :])
    sigmas, floored = floor_noise(sigmas, y)          # rounding, not noise, on exact data (.noise)
    sigma = sigmas[0] if runs is None else np.sqrt(counts @ sigmas**2 / N)
    prior = prior_parameters(arm, armature, friction, len(base.names))

    cov = None
    if method == "ols":
        beta = np.linalg.lstsq(R0, c0, rcond=None)[0]
        pi = base.full_closest_to(beta, prior)
        solver = "lstsq"
    else:
        w = 1.0 / sigma
        if runs is None:
            R, c, rho_w = stacked(factors, w)
        else:                    # each run's joints by their noise in that run
            w = np.repeat(1.0 / sigmas, counts, axis=0)                       # (N, n)
            R, c, rho_w = stacked(stack_factors([F * (1.0 / s)[:, None, None] for F, s in zip(runs, sigmas)]))
        cov = base_covariance(R)     # rows have unit variance after weighting (.uncertainty)
        if method == "wls":
            beta = np.linalg.lstsq(R, c, rcond=None)[0]
            pi = base.full_closest_to(beta, prior)
            solver = "lstsq"
        else:
            tries = [bounds] + ([Bounds(mass=bounds.mass, com=bounds.com, total_mass=bounds.total_mass)]  # the floor:
                                if bounds is not None and bounds.gyration is not None else [])  # best effort
            dropped = None
            for k, b in enumerate(tries):
                try:
                    pi, solver = consistent_fit(R, c, base.K, n, prior, extra=len(base.names) > 10 * n, bounds=b,
                                                nonnegative=nonnegative_extras(base.names, n),
                                                prior_weight=float(prior_weight), rows=N * n,
                                                extra_scale=extra_scale)
                    if b is not None and not b.satisfied(pi, n, rtol=1e-6):
                        raise ModelError("consistent fit: the answer does not satisfy the bounds (the solver "
                                         "cannot resolve them at the data's scale)")
                    bounds = b
                    break
                except ModelError as exc:
                    if k == len(tries) - 1:
                        raise ModelError(f"{exc}{_scale_hint(R, c, base.K, prior, b)}") from None
                    dropped = str(exc).splitlines()[0]
            beta = base.from_full(pi)
    residuals = y - Yb @ beta
    completion = None
    if method != "consistent" and complete and np.any(link_min_eigenvalues(pi, n) <= 0):
        pi, completion = _complete(arm, pi, base, prior, regressor)
    eig = link_min_eigenvalues(pi, n)
    consistent = bool(np.all(eig >= 0.0))
    out_arm, err = None, None
    try:
        import warnings

        from ..._support.errors import PhysicalConsistencyWarning

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PhysicalConsistencyWarning)
            out_arm = arm_with_parameters(arm, pi, armature=armature, friction=friction,
                                          name=name if name is not None else arm.name,
                                          metadata=metadata)
    except ModelError as exc:
        err = str(exc)
    if isinstance(completion, str):   # the completion's own solver failed: the raw parameters, and why
        err, completion = (f"{err}; " if err else "") + f"no physical completion: {completion}", None
    elif completion is not None and not completion.exact:
        err = (f"{err}; " if err else "") + completion.summary().replace(" on the model's states", " on these data")
    result = FitResult(arm=out_arm, parameters=pi, base=base, beta=beta, residuals=residuals,
                       sigma=sigma, method=method, condition_number=cond, consistent=consistent,
                       prior=arm, arm_error=err, covariance=cov, rest=rest)
    result.report = build_report(result, solver=solver, samples=N, cov=cov, min_eigenvalues=eig)
    result.report["active_bounds"] = bounds.active(pi, n) if bounds is not None else []
    result.report["prior_weight"] = float(prior_weight)
    result.report.update({"noise_sigma_per_run": sigmas.tolist()} if runs is not None else {})
    result.report["noise_floor_joints"] = floored
    if completion is not None:
        result.report["completion"] = {
            "exact": completion.exact, "changed_links": [i + 1 for i in completion.changed],
            "base_error": completion.base_error, "worst_base_error": completion.worst_base,
            "torque_difference": completion.torque_difference, "notes": completion.notes}
    if method == "consistent":
        result.report.update(shortfall(R, c, rho_w, y * w, residuals * w, pi, n, nonnegative_extras(base.names, n),
                                       bounds, solver, result.report["active_bounds"],
                                       float(prior_weight)))
        if dropped is not None:      # the floor is best effort: say that it went, and why
            result.report["gyration_floor_dropped"] = True
            result.report["fit_notes"].insert(0, FLOOR_DROPPED.format(dropped))
    return result


#: a completion reproduces the least-squares base parameters when it misses them by at most this (relative)
COMPLETION_RTOL = 1e-6


def _complete(arm, pi, base, prior, regressor):
    """``(pi', completion)``: physical bodies with the base parameters of the least-squares ``pi``
    (ols, wls) when some exist (to :data:`COMPLETION_RTOL`), else ``pi`` itself and the completion
    saying how far the nearest physical arm is (or the reason, a string, when the completion failed).  Differences are measured on the fit's own states
    (at most 2000 of them, evenly spaced)."""
    from ...model.completion import complete_parameters

    N = regressor.shape[0]
    rows = regressor[::max(1, N // 2000)].reshape(-1, regressor.shape[-1])
    try:
        c = complete_parameters(arm, pi, K=base.K, prior=prior, W=rows)
    except ModelError as exc:        # e.g. data 1e30 times the prior's: the fit stands, unwritten as a model
        return pi, str(exc)
    if c.exact and c.base_error <= COMPLETION_RTOL:
        return c.parameters, c
    if c.exact:                      # the null space held to rounding only: say so, as a miss
        import dataclasses

        c = dataclasses.replace(c, exact=False)
    return pi, c


def _scale_hint(R, c, K, prior, bounds) -> str:
    """A clause naming the measured torque's ratio to the prior's when bounds are in play and
    the ratio is far from 1 (torques in other units, a wrong prior), else ''."""
    tp = float(np.linalg.norm(R @ (K @ prior)))
    ratio = float(np.linalg.norm(c)) / tp if tp > 0 else float("inf")
    if bounds is None or 0.1 <= ratio <= 10:
        return ""
    return (f"; the measured torques are {ratio:.3g} times the prior's, far outside the plausibility "
            f"bounds around it: are the torques in the prior's units (N m, N)? Otherwise drop the "
            f"bounds (bounds=None, --no-bounds)")
