"""The physically consistent fit: semidefinite programs solved with cvxpy.

Layer: application (identification).

Physical consistency of a link is exactly ``J_i >= 0`` (its 4x4
pseudo-inertia positive semidefinite; Wensing, Kim and Slotine 2017).  J is
linear in the ten parameters (``J = sum_k pi_k E_k``,
:data:`manipdyn.parameters.PARAMETER_BASIS`), so both steps are convex:

1. ``min ||R (K pi) - c||`` subject to ``J_i(pi) >= eps I`` for every link
   (plus armature and friction >= 0, plus optional :class:`Bounds`), where
   ``R``, ``c`` are the QR-reduced weighted least-squares problem of the base
   parameters (:mod:`.estimation`);
2. among the ``pi`` with the same base parameters ``K pi = beta*``, the one
   closest to the prior (least-squares deviation), with the same constraints
   (margin ``EPS / 2``).  The equality holds to the solver's accuracy, ~1e-9;
   if Clarabel cannot solve step 2, step 1's answer is kept.

``eps = 1e-8`` (kg m^2, kg m, kg) keeps every identified body strictly
physical after the solver's rounding (the Schur complement of J, the
second moment about the COM, is then >= eps I, so the triangle inequalities
hold with that margin).  Solvers: Clarabel (interior point), then SCS if
Clarabel fails; both are open source.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..parameters import PARAMETER_BASIS
from ._deps import require

__all__ = ["Bounds", "consistent_fit", "solve_problem", "EPS"]

#: margin of the PSD constraints, J_i >= EPS * I (see the module docstring)
EPS = 1e-8
#: weight of step 1's pull towards the prior (see :func:`consistent_fit`)
REG = 1e-7


@dataclass(frozen=True)
class Bounds:
    """Optional bounds of the consistent fit (URDF link frames, SI units).

    Attributes
    ----------
    mass : (n, 2) array or None
        ``lo_i <= m_i <= hi_i`` (kg).
    com : (n, 2, 3) array or None
        The centre of mass inside the box ``[lo, hi]`` (m): ``m lo <= m c <= m hi``.
    """

    mass: np.ndarray | None = None
    com: np.ndarray | None = None

    @classmethod
    def around(cls, arm, mass: float = 0.5, com: float = 0.1) -> "Bounds":
        """Masses within ``+-mass`` (fraction) of the prior's, COMs within ``+-com`` m of them."""
        joints, _ = arm.chain()
        m = np.array([j.body.mass for j in joints])
        c = np.array([j.body.com for j in joints])
        return cls(mass=np.stack([m * (1 - mass), m * (1 + mass)], axis=1),
                   com=np.stack([c - com, c + com], axis=1))


def _solve(cp, problem, what, solvers=("CLARABEL", "SCS")):
    """Solve with Clarabel, else SCS; an inaccurate answer is accepted only from the last."""
    import warnings

    errors = []
    fallback = None
    for solver in solvers:
        if solver not in cp.installed_solvers():
            errors.append(f"{solver} not installed")
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)   # "solution may be inaccurate"
                problem.solve(solver=solver)
        except cp.error.SolverError as exc:
            errors.append(f"{solver}: {exc}")
            continue
        if problem.status == "optimal":
            return solver
        if problem.status == "optimal_inaccurate":
            fallback = fallback or (solver, [v.value for v in problem.variables()])
        errors.append(f"{solver}: {problem.status}")
    if fallback is not None:
        solver, values = fallback
        for v, val in zip(problem.variables(), values):
            v.value = val
        return f"{solver} (inaccurate)"
    raise ModelError(f"consistent fit, {what}: no solver succeeded ({'; '.join(errors)})"
                     + ("; the bounds may be infeasible" if "infeasible" in " ".join(errors) else ""))


def solve_problem(problem, what: str, solvers=("CLARABEL", "SCS")) -> str:
    """Solve the cvxpy ``problem`` with Clarabel, else SCS; return the solver's name.

    An "optimal_inaccurate" answer is kept (its name then ends in
    ``" (inaccurate)"``) only when no solver is accurate; when none succeeds,
    :class:`ModelError` says why, naming ``what``.
    """
    cp = require("cvxpy", what)
    return _solve(cp, problem, what, solvers)


def _constraints(cp, x, n, extra, bounds, eps=EPS):
    E = PARAMETER_BASIS
    cons = []
    for i in range(n):
        J = sum(x[10 * i + k] * E[k] for k in range(10))
        cons.append(J - eps * np.eye(4) >> 0)
    if extra:
        cons.append(x[10 * n:] >= 0)           # armature, viscous and Coulomb friction
    if bounds is not None:
        if bounds.mass is not None:
            mb = np.asarray(bounds.mass, dtype=np.float64)
            cons += [x[10 * np.arange(n)] >= mb[:, 0], x[10 * np.arange(n)] <= mb[:, 1]]
        if bounds.com is not None:
            cb = np.asarray(bounds.com, dtype=np.float64)
            for i in range(n):
                m, mc = x[10 * i], x[10 * i + 1:10 * i + 4]
                cons += [mc >= m * cb[i, 0], mc <= m * cb[i, 1]]
    return cons


def consistent_fit(R, c, K, n, prior, extra: bool, bounds: Bounds | None = None):
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

    Returns ``(pi, solver)``.
    """
    cp = require("cvxpy", "the consistent fit")
    p = K.shape[1]
    x = cp.Variable(p)
    scale = max(1e-300, float(np.linalg.norm(c)))
    # step 1: the best fit among physical arms.  The norm, not its square: a
    # conic solver then resolves the residual to its tolerance (~1e-8 of |c|)
    # rather than to the square root of it, which matters on exact data.
    # The unidentifiable directions leave a whole face of minimisers; a pull of
    # weight REG towards the prior makes the minimiser unique (interior-point
    # solvers report "inaccurate" on unbounded optimal faces) and moves the fit
    # by ~REG relative.  Step 2 then picks the full parameters.
    pscale = max(1.0, float(np.linalg.norm(prior)))
    step1 = cp.Problem(cp.Minimize(cp.norm(R @ (K @ x) - c) / scale + REG * cp.norm(x - prior) / pscale),
                       _constraints(cp, x, n, extra, bounds))
    solver = _solve(cp, step1, "step 1 (fit)")
    x1 = np.asarray(x.value, dtype=np.float64)
    # step 2: closest to the prior with the same base parameters, K pi = K x1
    # (an equality the interior-point solver keeps to ~1e-9).  Margin EPS / 2:
    # step 1's answer, often on the EPS boundary, is then strictly feasible.
    x2 = cp.Variable(p)
    step2 = cp.Problem(cp.Minimize(cp.sum_squares((x2 - prior) / pscale)),
                       [K @ x2 == K @ x1] + _constraints(cp, x2, n, extra, bounds, eps=EPS / 2))
    try:
        _solve(cp, step2, "step 2 (closest to the prior)", solvers=("CLARABEL",))
        pi = np.asarray(x2.value, dtype=np.float64)
        beta1 = K @ x1
        if np.linalg.norm(K @ pi - beta1) > 1e-7 * max(float(np.linalg.norm(beta1)), 1e-300):
            pi = x1   # an inaccurate step 2 moved the base parameters: keep step 1's
    except ModelError:
        pi = x1   # step 1's answer has the same base parameters and is physical
    return project_physical(pi, n), solver


def project_physical(pi, n: int, eps: float = EPS) -> np.ndarray:
    """Every link's J_i with eigenvalues below ``eps`` raised to ``eps`` (a no-op for a
    solver answer within tolerance; it guards against an inaccurate one), (p,)."""
    from ..inertia import parameters_from_pseudo_inertia, pseudo_inertia_from_parameters

    pi = np.array(pi, dtype=np.float64)
    J = pseudo_inertia_from_parameters(pi[:10 * n].reshape(n, 10))
    w, V = np.linalg.eigh(J)
    low = w < 0.5 * eps
    if np.any(low):
        J = (V * np.maximum(w, eps)[:, None, :]) @ np.swapaxes(V, -1, -2)
        pi[:10 * n] = parameters_from_pseudo_inertia(J).reshape(-1)
    if pi.size > 10 * n:
        pi[10 * n:] = np.maximum(pi[10 * n:], 0.0)
    return pi
