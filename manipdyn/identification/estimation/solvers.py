"""Running a conic program on the open solvers (Clarabel, then SCS), and weighing their answers.

Layer 5 (identification).  Used by :mod:`.sdp` (the physically consistent fit) and, through
:func:`manipdyn.identification.estimation.sdp.solve_problem`, by the payload fit.
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError, is_solver_panic

#: an answer's constraints may be violated by at most this (in the solver's units) to count as
#: feasible when two solvers' answers are weighed against each other; below the PSD margin EPS,
#: so a body that passes is still physical (J_i >= EPS I - VIOLATION_TOL I >= 0; half of
#: ``sdp.EPS = 1e-8``, held equal by tests/test_pipeline.py)
VIOLATION_TOL = 5e-9


_INSTALLED: dict = {}


def _installed(cp) -> frozenset:
    """cvxpy's installed solvers, asked once per process (cvxpy probes every solver's import each time)."""
    key = id(cp)
    if key not in _INSTALLED:
        _INSTALLED[key] = frozenset(cp.installed_solvers())
    return _INSTALLED[key]


def _evaluate(problem) -> tuple[float, float]:
    """``(objective, largest constraint violation)`` of the values the variables now hold."""
    try:
        obj = float(problem.objective.value)
    except (TypeError, ValueError):
        return float("inf"), float("inf")
    viol = 0.0
    for con in problem.constraints:
        v = con.violation()
        v = float(np.max(np.abs(np.atleast_1d(v)))) if v is not None else float("inf")
        viol = max(viol, v)
    return (obj if np.isfinite(obj) else float("inf")), viol


def solve(cp, problem, what, solvers=("CLARABEL", "SCS")):
    """Solve with Clarabel, else SCS; return the solver's name (the variables hold its answer).

    An "optimal" answer of the first solver is taken as it is.  When it reports only
    "optimal_inaccurate" (Clarabel's reduced tolerances, ~1e-5 on the duality gap), the next
    solver is tried too, and the two answers are weighed by manipdyn itself: the one whose
    constraints hold (to :data:`VIOLATION_TOL`) with the smaller objective is kept.  A
    first-order solver's "optimal" (SCS's default tolerance, 1e-4) is no better a certificate
    than an interior-point solver's "inaccurate", and its answer moves with the BLAS kernel by
    far more (a held-out torque RMS of 0.050 to 0.20 N m on one UR5 fit, issue 38 item 10), so
    the label alone does not decide.  The name ends in ``" (inaccurate)"`` when the kept answer
    was so labelled and no other solver's answer was at least as good; in ``" (reduced accuracy,
    checked)"`` when it was so labelled but verified feasible, another solver was tried, and no
    other feasible answer has a smaller objective (SCS's "optimal" often breaks the PSD
    constraints by 1e-3, and then it is no answer at all).

    cvxpy's notes on reading a sparse Parameter's value (:mod:`.programs`' base-parameter map) are
    silenced: its own canonicalization reads it densely and says so.
    """
    import warnings

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*sparse CVXPY expression", category=RuntimeWarning)
        return _solve(cp, problem, what, solvers)


def _solve(cp, problem, what, solvers):
    """:func:`solve` without its warning filter."""
    import warnings

    errors = []
    candidates = []      # (solver, status, values, objective, violation)
    for solver in solvers:
        if solver not in _installed(cp):
            errors.append(f"{solver} not installed")
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)   # "solution may be inaccurate"
                problem.solve(solver=solver)
        except cp.error.SolverError as exc:
            errors.append(f"{solver}: {exc}")
            continue
        except BaseException as exc:      # Clarabel's Rust panic is a BaseException
            if not is_solver_panic(exc):
                raise
            errors.append(f"{solver}: the solver panicked ({str(exc)[:200]})")
            continue
        if problem.status == "optimal" and not candidates:
            return solver
        if problem.status in ("optimal", "optimal_inaccurate"):
            obj, viol = _evaluate(problem)
            candidates.append((solver, problem.status, [v.value for v in problem.variables()], obj, viol))
        else:
            errors.append(f"{solver}: {problem.status}")
    if candidates:
        feasible = [c for c in candidates if c[4] <= VIOLATION_TOL]
        pool = feasible or [min(candidates, key=lambda c: c[4])]
        solver, status, values, _obj, viol = min(pool, key=lambda c: c[3])
        for v, val in zip(problem.variables(), values):
            v.value = val
        if status == "optimal":
            return solver
        # kept from the feasible pool by the smallest objective: no other feasible answer beats it
        if viol <= VIOLATION_TOL and len(candidates) > 1:
            return f"{solver} (reduced accuracy, checked)"
        return f"{solver} (inaccurate)"
    raise ModelError(f"consistent fit, {what}: no solver succeeded ({'; '.join(errors)})"
                     + ("; the bounds may be infeasible" if "infeasible" in " ".join(errors) else ""))
