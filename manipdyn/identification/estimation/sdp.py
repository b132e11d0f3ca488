"""The physically consistent fit: semidefinite programs solved with cvxpy.

Layer 5 (identification).

Physical consistency of a link is exactly ``J_i >= 0`` (its 4x4
pseudo-inertia positive semidefinite; Wensing, Kim and Slotine 2017).  J is
linear in the ten parameters (``J = sum_k pi_k E_k``,
:data:`manipdyn.model.parameters.PARAMETER_BASIS`), so both steps are convex:

0. when the least-squares base parameters ``R^-1 c`` are those of some physical arm (within the
   bounds), that arm closest to the prior is the answer (step 1's optimum, at least-squares
   accuracy);
1. ``min ||R (K pi) - c||`` subject to ``J_i(pi) >= eps I`` for every link
   (plus armature and friction >= 0, plus optional :class:`Bounds`), where
   ``R``, ``c`` are the QR-reduced weighted least-squares problem of the base
   parameters (:mod:`.estimation`);
2. among the ``pi`` with the same base parameters ``K pi = beta*``, the one
   closest to the prior (least-squares deviation), with the same constraints
   (margin ``EPS / 2``).  The equality holds to the solver's accuracy, ~1e-9;
   if Clarabel cannot solve step 2, step 1's answer is kept.

Units: the programs are solved for ``x = pi / u`` with ``u = ||c|| / ||R K prior||``, the
measured torque over the prior's, so the solver sees data of the prior's magnitude whatever
the torques' scale (30 or 1e30 times a UR5's): the answer scales with the data.

``eps = 1e-8`` (kg m^2, kg m, kg, in units of ``u`` when ``u < 1``) keeps every identified body strictly
physical after the solver's rounding (the Schur complement of J, the
second moment about the COM, is then >= eps I, so the triangle inequalities
hold with that margin).  Solvers: Clarabel (interior point), then SCS if
Clarabel fails; both are open source.  The programs are compiled once per structure and reused
with each call's numbers (:mod:`.programs`, cvxpy's DPP); the bounds live in :mod:`.bounds`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._support.errors import ModelError
from ...model.parameters import PARAMETER_BASIS
from ...model.inertia import pseudo_inertia_from_parameters
from ...model.plausible import smallest_gyration
from .bounds import (FLOOR_RTOL, PLAUSIBLE_COM, PLAUSIBLE_GYRATION, PLAUSIBLE_MASS,  # noqa: F401 (their home was here)
                     PLAUSIBLE_TOTAL, Bounds)
from ..._support.deps import require
from .solvers import solve as _solve
from .programs import bound_values, program

__all__ = ["Bounds", "consistent_fit", "solve_problem", "smallest_gyration", "EPS"]

#: margin of the PSD constraints, J_i >= EPS * I (see the module docstring)
EPS = 1e-8
#: weight of step 1's pull towards the prior (see :func:`consistent_fit`)
REG = 1e-7
#: ratio of the data's torque to the prior's beyond which the prior's magnitude is scaled away
#: (see :func:`consistent_fit`)
PRIOR_RANGE = 10.0


def solve_problem(problem, what: str, solvers=("CLARABEL", "SCS")) -> str:
    """Solve the cvxpy ``problem`` with Clarabel, else SCS; return the solver's name.

    An "optimal_inaccurate" answer is kept (its name then ends in
    ``" (inaccurate)"``) only when no solver is accurate; when none succeeds,
    :class:`ModelError` says why, naming ``what``.
    """
    cp = require("cvxpy", what)
    return _solve(cp, problem, what, solvers)


def consistent_fit(R, c, K, n, prior, extra: bool, bounds: Bounds | None = None,
                   prior_weight: float = 0.0, rows: int | None = None, nonnegative=None, extra_scale=None):
    """The two steps of the module docstring.

    Parameters
    ----------
    R : (m, r), c : (m,)
        Reduced weighted least-squares problem ``min ||R beta - c||``.
    K : (r, p)
        Base-parameter map, ``beta = K pi``.
    n : int
        Number of links.
    prior : (p,)
        Prior full parameters.
    extra : bool
        Whether pi holds armature/friction entries (constrained >= 0).
    prior_weight : float
        Weight ``w`` of the entropic pull towards the prior's bodies (0: none).  Step 1 then
        minimises ``||R K pi - c||^2 / rows + w * sum_i d(J_i, J0_i) / n`` where
        ``d(J, J0) = tr(J0^-1 J) - log det(J0^-1 J) - 4`` is the log-determinant (Bregman)
        divergence of the pseudo-inertias: zero at the prior, invariant to the units and
        frame of each body, and infinite at a degenerate body (Lee, Wensing and Park,
        "Geometric robot dynamic identification", 2020).  Each weighted row has unit
        noise variance, so ``w`` is the prior's weight relative to the mean squared
        normalised residual: with ``w = 1e-2`` a 10 % change of a well-excited body costs
        about what 1 % more residual does.
    rows : int
        Number of weighted equations behind ``R`` (N n); needed with ``prior_weight``.
    nonnegative : (p - 10 n,) bool, optional
        Which extra entries (armature, friction) are constrained >= 0 (default: all).
    extra_scale : (p - 10 n,) positive array, optional
        With ``prior_weight > 0``: the scale of each extra entry (armature, friction coefficients,
        offsets; in their SI units) for a pull of the extras towards the prior's, step 1's objective
        gaining ``w * sum_e ((pi_e - prior_e) / extra_scale_e)^2 / max(1, p - 10 n)``.  None (the
        default), or ``prior_weight`` 0: no such term.

    The programs come from :mod:`.programs`: compiled once per structure and reused with new numbers.

    Returns ``(pi, solver)``.
    """
    cp = require("cvxpy", "the consistent fit")
    R, c, prior = (np.asarray(v, dtype=np.float64) for v in (R, c, prior))
    K = np.asarray(K, dtype=np.float64)
    p = K.shape[1]
    extra_scale = _extra_scale(extra_scale, p - 10 * n)
    # units: the solver works on x = pi / u with u the ratio of the
    # measured torque to the prior's, ||c|| / ||R K prior||.  Data 30 or 1e30 times a prior's
    # torque then give the solver the problem of data of the prior's magnitude: its tolerances, the
    # PSD margin EPS (in units of u) and the pull towards the prior act the same at any
    # scale, and the answer scales with the data.  R K pi - c = (u R) K x - c: the objective
    # is unchanged.
    u = _unit(R, c, K, prior)
    # the PSD margin: EPS in the solver's units, but never more than EPS in SI (data 1e30 times
    # the prior's must not force 1e22 kg bodies through the margin against mass bounds)
    eps = EPS * min(1.0, 1.0 / u)
    R = R * u
    # the prior in the solver's units, as the target of the pull (step 1) and of step 2: the
    # prior itself while the data are within PRIOR_RANGE of its magnitude; beyond, scaled
    # with the data (continuously) so that the target stays within PRIOR_RANGE of the answer:
    # a prior 1e30 times off says nothing about its magnitude, and an interior-point solver
    # cannot resolve parameters 1e30 apart
    prior_u = prior / float(np.clip(u, 1.0 / PRIOR_RANGE, PRIOR_RANGE))
    floor2 = None
    if bounds is not None and prior_weight and bounds.gyration is not None:
        # with a prior weight the radius-of-gyration floor is held in step 2 only, which keeps the base
        # parameters (the dynamics) step 1 found: the floor is a plausibility bound on what the data do not see,
        # and in step 1 it overrode the pull on what they do see (measured on the Panda at weight 1: joint 6's
        # held-out torque 20 % worse with the floor in step 1, 8.5 % without)
        floor2 = bounds.scaled(1.0 / u)
        bounds = Bounds(mass=bounds.mass, com=bounds.com, total_mass=bounds.total_mass)
    if bounds is not None:
        bounds = bounds.scaled(1.0 / u)
    scale = max(1e-300, float(np.linalg.norm(c)))
    extra_idx = np.arange(10 * n, p) if extra else np.arange(0)
    if extra and nonnegative is not None:
        extra_idx = extra_idx[np.asarray(nonnegative, dtype=bool)]
    # step 1: the best fit among physical arms.  The norm, not its square: a
    # conic solver then resolves the residual to its tolerance (~1e-8 of |c|)
    # rather than to the square root of it, which matters on exact data.
    # The unidentifiable directions leave a whole face of minimisers; a pull of
    # weight REG towards the prior makes the minimiser unique (interior-point
    # solvers report "inaccurate" on unbounded optimal faces) and moves the fit
    # by ~REG relative.  Step 2 then picks the full parameters.
    pscale = max(1.0, float(np.linalg.norm(prior_u)))
    if prior_weight and prior_weight > 0:
        if not rows:
            raise ValueError("rows: needed with prior_weight")
        # d(u J', J0) = d(J', J0 / u): the divergence in the solver's units, to the prior scaled
        # as above when the data are beyond PRIOR_RANGE of it
        J0 = pseudo_inertia_from_parameters(prior_u[:10 * n].reshape(n, 10))
        J0 = J0 + EPS * max(1.0, float(np.abs(J0).max())) * np.eye(4)   # a massless prior link
        step1 = ("weighted", {"R": R, "K": K, "c": c, "rows": float(rows), "J0inv": np.linalg.inv(J0),
                              "weight": float(prior_weight)})
        if extra_scale is not None and p > 10 * n:
            # w sum_e ((x_e - prior_e) / (extra_scale_e / u))^2 / max(1, p - 10 n), in the solver's units
            d = np.sqrt(float(prior_weight) / max(1, p - 10 * n)) * u / extra_scale
            step1[1].update(d=d, dt=d * prior_u[10 * n:])
    else:
        # the pull's target is the prior scaled with the data (x = prior): the fit (beta) is
        # then the same problem at any scale of the data
        step1 = ("fit", {"R": R, "K": K, "c": c, "scale": scale, "prior": prior, "reg": REG,
                         "pnorm": max(1.0, float(np.linalg.norm(prior)))})
    ctx = _Context(cp, K, n, p, extra_idx, prior_u, pscale, eps)
    if not prior_weight:
        xs = _least_squares_if_physical(ctx, R, c, bounds)
        if xs is not None:
            return u * project_physical(xs, n, eps=eps, nonnegative=nonnegative), "CLARABEL; least squares is physical"
    if bounds is None:
        xs, solver = _two_steps(ctx, step1, None, (R, c), step2_bounds=floor2)
        return u * project_physical(xs, n, eps=eps, nonnegative=nonnegative), solver
    # the answer without the bounds is kept when it satisfies them: they are then inactive and the smaller
    # problem is solved more accurately (interior-point solvers lose digits on many inactive inequality
    # rows: 1e-7 instead of 1e-11 relative on exact data).  The answer with them comes first: when one of
    # its mass, centre-of-mass or total-mass bounds is active, the answer without them crosses it (the
    # bound binds), and that solve, half the cost of the fit, is skipped
    try:
        bounded = _two_steps(ctx, step1, bounds, (R, c), step2_bounds=floor2)
    except ModelError as exc:
        bounded = exc
    if isinstance(bounded, ModelError) or not Bounds(mass=bounds.mass, com=bounds.com,
                                                     total_mass=bounds.total_mass).active(bounded[0], n):
        try:
            xs, solver = _two_steps(ctx, step1, None, (R, c), step2_bounds=floor2)
            if bounds.satisfied(xs, n):
                return u * project_physical(xs, n, eps=eps, nonnegative=nonnegative), solver
        except ModelError:
            pass
    if isinstance(bounded, ModelError):
        raise bounded
    xs, solver = bounded
    return u * project_physical(xs, n, eps=eps, nonnegative=nonnegative), solver


def _extra_scale(extra_scale, count: int):
    """``extra_scale`` checked: None, or ``count`` positive numbers, ``inf`` for an entry not pulled (a
    :class:`ModelError` else); None when no entry is pulled."""
    if extra_scale is None:
        return None
    try:
        a = np.array(extra_scale, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"extra_scale: expected {count} positive numbers (one per armature, friction "
                         f"coefficient and offset), got {extra_scale!r:.60} ({exc})") from None
    if a.shape != (count,):
        raise ModelError(f"extra_scale: expected shape ({count},) (one per armature, friction coefficient and "
                         f"offset, after the 10 n link parameters), got {a.shape}")
    if not np.all((a > 0) & ~np.isnan(a)):
        raise ModelError(f"extra_scale: expected numbers > 0 (inf: not pulled), got {a.tolist()}")
    return None if np.all(np.isinf(a)) else a


@dataclass(frozen=True)
class _Context:
    """What the programs of one :func:`consistent_fit` call share (in the solver's units)."""

    cp: object
    K: np.ndarray
    n: int
    p: int
    extra_idx: np.ndarray
    prior: np.ndarray
    pscale: float
    eps: float

    def closest(self, beta, bounds, fixed=None):
        """The program of the full parameters closest to the prior with base parameters ``beta``
        (margin ``eps / 2``), the bodies held at ``fixed`` (10 n,) when given: ``(problem, x)``."""
        values = {"prior": self.prior, "pscale": self.pscale, "K": self.K, "beta": np.asarray(beta, dtype=np.float64)}
        if fixed is not None:
            values["fixed"] = np.asarray(fixed, dtype=np.float64)
        values.update(bound_values(bounds, self.eps / 2))
        return program(self.cp, "closest", self.n, self.p, self.extra_idx, values)


def _unit(R, c, K, prior) -> float:
    """``||c|| / ||R K prior||`` (the data's torque over the prior's), or the least-squares
    answer's norm over the prior's when the prior predicts no torque; 1 if neither says anything."""
    cn = float(np.linalg.norm(c))
    tp = float(np.linalg.norm(R @ (K @ prior)))
    ratio = cn / tp if tp > 0 and np.isfinite(tp) else 0.0
    if not (ratio > 0 and np.isfinite(ratio)):
        beta = np.linalg.lstsq(R, c, rcond=None)[0]
        ratio = float(np.linalg.norm(np.linalg.pinv(K) @ beta)) / max(1.0, float(np.linalg.norm(prior)))
    if not (ratio > 0 and np.isfinite(ratio)):
        return 1.0
    return ratio


def _least_squares_if_physical(ctx, R, c, bounds):
    """The full parameters closest to the prior whose base parameters are the least-squares
    ones, ``K x = R^-1 c``, when some physical (and in-bounds) x has them, else None.

    Such an x minimises step 1's residual over all x, so it is step 1's answer (up to the
    REG pull); taking it directly keeps the least-squares accuracy (1e-11 of the smallest
    joint's torque on exact data) where a conic solver would stop at ~1e-8 of the largest.
    """
    K, n = ctx.K, ctx.n
    beta = np.linalg.lstsq(R, c, rcond=None)[0]
    prob, x2 = ctx.closest(beta, bounds)
    try:
        if _solve(ctx.cp, prob, "least squares", solvers=("CLARABEL",)) != "CLARABEL":
            return None
    except ModelError:   # infeasible: the least-squares answer is no physical arm
        return None
    x = np.asarray(x2.value, dtype=np.float64)
    r_ls = float(np.linalg.norm(R @ beta - c))
    if float(np.linalg.norm(R @ (K @ x) - c)) > r_ls + 1e-10 * max(float(np.linalg.norm(c)), 1e-300):
        return None      # the equality held too loosely for the smallest joint's torques
    if bounds is not None and not bounds.satisfied(x, n):
        return None
    return x


def _two_steps(ctx, step1, bounds, data, bodies_fixed: bool = False, step2_bounds=None):
    """Step 1 (the fit; ``step1`` its program's kind and numbers) and step 2 (closest to the prior,
    same base parameters): ``(pi, solver)``.  ``step2_bounds``: bounds step 2 holds beyond step 1's (the
    gyration floor, with a prior weight), tried first.  ``bodies_fixed``: step 2 moves only the entries beyond
    the bodies (armature, friction), the bodies held at step 1's: with a prior weight, step 1 pulled the bodies
    towards the prior by the log-det divergence, strictly convex in them, so its bodies are already the ones
    closest to the prior in that physical measure; a Euclidean step 2 would move them off it, onto the
    ``J >= 0`` boundary where the Euclidean projection of the prior lands (measured on the Panda: four links
    degenerate, smallest radius of gyration 1e-4 m)."""
    K = ctx.K
    kind, values = step1
    values = dict(values, **bound_values(bounds, ctx.eps))
    prob1, x = program(ctx.cp, kind, ctx.n, ctx.p, ctx.extra_idx, values)
    solver = _solve(ctx.cp, prob1, "step 1 (fit)")
    x1 = np.asarray(x.value, dtype=np.float64)
    # step 2: closest to the prior with the same base parameters, K pi = K x1
    # (an equality the interior-point solver keeps to ~1e-9).  Margin EPS / 2:
    # step 1's answer, often on the EPS boundary, is then strictly feasible.
    beta1 = K @ x1
    if bodies_fixed and ctx.p == 10 * ctx.n:
        return x1, solver
    if step2_bounds is not None:       # step 2 holds what step 1 did not (the floor), if it can
        try:
            step2, x2 = ctx.closest(beta1, step2_bounds)
            _solve(ctx.cp, step2, "step 2 (closest to the prior, on the floor)", solvers=("CLARABEL",))
            pi = np.asarray(x2.value, dtype=np.float64)
            if np.linalg.norm(K @ pi - beta1) <= 1e-7 * max(float(np.linalg.norm(beta1)), 1e-300):
                return pi, solver
        except ModelError:
            pass                        # no body of these base parameters clears the floor: step 2 below
    step2, x2 = ctx.closest(beta1, bounds, fixed=x1[:10 * ctx.n] if bodies_fixed else None)
    try:
        _solve(ctx.cp, step2, "step 2 (closest to the prior)", solvers=("CLARABEL",))
        pi = np.asarray(x2.value, dtype=np.float64)
        if np.linalg.norm(K @ pi - beta1) > 1e-7 * max(float(np.linalg.norm(beta1)), 1e-300):
            pi = x1   # an inaccurate step 2 moved the base parameters: keep step 1's
        elif data is not None:
            # the equality holds to ~1e-9 of the largest base parameter, which can still be much
            # of a small one (a wrist's): keep step 2 only if it fits the data as well as step 1
            R, c = data
            r1, r2 = (float(np.linalg.norm(R @ (K @ v) - c)) for v in (x1, pi))
            if r2 > r1 + 1e-10 * max(float(np.linalg.norm(c)), 1e-300):
                pi = x1
    except ModelError:
        pi = x1   # step 1's answer has the same base parameters and is physical
    return pi, solver


def project_physical(pi, n: int, eps: float = EPS, nonnegative=None) -> np.ndarray:
    """Every link's J_i with eigenvalues below ``eps`` raised to ``eps`` (a no-op for a
    solver answer within tolerance; it guards against an inaccurate one), (p,)."""
    from ...model.inertia import parameters_from_pseudo_inertia, pseudo_inertia_from_parameters

    pi = np.array(pi, dtype=np.float64)
    J = pseudo_inertia_from_parameters(pi[:10 * n].reshape(n, 10))
    w, V = np.linalg.eigh(J)
    low = w < 0.5 * eps
    if np.any(low):
        J = (V * np.maximum(w, eps)[:, None, :]) @ np.swapaxes(V, -1, -2)
        pi[:10 * n] = parameters_from_pseudo_inertia(J).reshape(-1)
    if pi.size > 10 * n:
        idx = np.arange(10 * n, pi.size)
        if nonnegative is not None:
            idx = idx[np.asarray(nonnegative, dtype=bool)]
        pi[idx] = np.maximum(pi[idx], 0.0)
    return pi
