"""Nonlinear friction shapes by variable projection: :func:`fit_friction_shapes`.

Layer 5 (identification).

A friction law's Stribeck and sigmoid terms (:mod:`manipdyn.model.friction`) are
linear in their amplitudes and nonlinear in their shapes: the Stribeck
velocity ``vs`` (per actuator), the sigmoid's steepness ``alpha`` and shift
``p3`` (per actuator).  With the shapes ``theta`` fixed, the model
``tau = Y_b(q, qd, qdd) beta + F(qd; theta) phi`` is linear in the base
parameters ``beta`` and the friction amplitudes ``phi``, and their
weighted least-squares solution is one QR.  Variable projection (Golub and
Pereyra, "The differentiation of pseudo-inverses and nonlinear least squares
problems whose variables separate", SIAM J. Numer. Anal. 10(2), 1973)
minimises over ``theta`` alone the residual left after that solution:

    min_theta || W (I - A(theta) A(theta)^+) y ||,    A(theta) = W [Y_b | F(theta)],

with ``scipy.optimize.least_squares`` (trust-region reflective; forward
differences with absolute steps, on variables shifted to start away from 0:
see :func:`fit_shapes`'s comments for why).  ``W`` divides each joint's rows by its noise level ``sigma_j``
(``wls``'s weights), estimated once by :func:`~manipdyn.identification.fit`
at the initial shapes.  The link regressor ``Y_b`` does not depend on
``theta``: it is computed once, and only the friction columns are rebuilt per
evaluation.  Shapes are searched on a log scale for ``vs`` and ``alpha``
(both > 0), within a factor :data:`SHAPE_RANGE` of the initial value either
way; ``p3`` within ``+-`` :data:`SHAPE_RANGE` times the initial ``|p3|``
(at least ``SHAPE_RANGE / alpha``).  The search is local, so it starts from the best of
a coarse grid per actuator (:func:`_grid_start`: the initial ``vs`` and ``alpha`` times
each of :data:`GRID`).  The Stribeck exponent is held fixed.

The answer is one final :func:`~manipdyn.identification.fit` at the fitted
shapes with the asked-for method (so ``consistent``'s constraints and the
written model are the ones ``fit`` makes).  A shape whose amplitude is zero
in the data is not determined by it; it stays near its initial value and
``report["friction_shapes"]`` says which shapes moved.
"""

from __future__ import annotations

import numpy as np

from ..._support.errors import ModelError
from ...model.friction import Friction
from .base import base_parameters
from .fitting import fit, still_rows

__all__ = ["fit_friction_shapes", "fit_shapes", "SHAPE_RANGE", "SHAPES"]

#: how far (a factor, either way) a shape may move from its initial value
SHAPE_RANGE = 100.0
#: the shape parameters variable projection fits, per term
SHAPES = {"stribeck": ("stribeck_velocity",), "sigmoid": ("sigmoid_alpha", "sigmoid_p3")}
_LOG = ("stribeck_velocity", "sigmoid_alpha")


def _samples(data):
    if all(hasattr(data, k) for k in ("q", "qd", "qdd", "tau")):
        return data.q, data.qd, data.qdd, data.tau
    try:
        q, qd, qdd, tau = data
    except (TypeError, ValueError):
        raise ModelError("data: expected Measurements (read_log) or a tuple (q, qd, qdd, tau) of (N, n) "
                         f"arrays, got {type(data).__name__}") from None
    return q, qd, qdd, tau


def _with_shapes(law: Friction, shapes: dict) -> Friction:
    """``law`` with the shape arrays in ``shapes`` replaced (amplitudes kept)."""
    kw = dict(viscous=law.viscous, offset=law.offset, smoothing=law.smoothing, deadband=law.deadband,
              side=law.side, stribeck_exponent=law.stribeck_exponent, n=law.n,
              stribeck_level=law.stribeck_level, stribeck_velocity=law.stribeck_velocity,
              sigmoid_A=law.sigmoid_A, sigmoid_alpha=law.sigmoid_alpha, sigmoid_p3=law.sigmoid_p3)
    if law.asymmetric:
        kw.update(coulomb_pos=law.coulomb_pos, coulomb_neg=law.coulomb_neg)
    else:
        kw["coulomb"] = law.coulomb
    kw.update(shapes)
    return Friction(**kw)


def _unknowns(law: Friction):
    """``[(field, initial (n,))]`` of the law's shapes, and the packing of theta."""
    fields = [f for t in law.terms if t in SHAPES for f in SHAPES[t]]
    if not fields:
        raise ModelError("friction: the law has no nonlinear shape to fit; give a Friction with a Stribeck "
                         "term (stribeck_level, stribeck_velocity) or a sigmoid (sigmoid_A, sigmoid_alpha, "
                         "sigmoid_p3) holding the initial shapes")
    return [(f, np.array(getattr(law, f), dtype=np.float64)) for f in fields]


def _pack_bounds(unknowns):
    x0, lo, hi = [], [], []
    for f, v in unknowns:
        if f in _LOG:
            x = np.log(v)
            x0.append(x), lo.append(x - np.log(SHAPE_RANGE)), hi.append(x + np.log(SHAPE_RANGE))
        else:   # the sigmoid's shift, rad/s: a range scaled by |p3| or by 1 / alpha
            alpha = dict(unknowns)["sigmoid_alpha"]
            half = SHAPE_RANGE * np.maximum(np.abs(v), 1.0 / alpha)
            x0.append(v.copy()), lo.append(v - half), hi.append(v + half)
    return np.concatenate(x0), np.concatenate(lo), np.concatenate(hi)


def _unpack(x, unknowns, n):
    out = {}
    for k, (f, _) in enumerate(unknowns):
        v = x[k * n:(k + 1) * n]
        out[f] = np.exp(v) if f in _LOG else v.copy()
    return out


#: factors of the initial scale shapes (``vs``, ``alpha``) tried per actuator before the search
GRID = (0.1, 0.3, 1.0, 3.0, 10.0)


def _grid_start(residual, x0, unknowns, n):
    """``(x0, factor (n,))``: per actuator, the factor of :data:`GRID` on its scale shapes whose
    residual on that joint's rows is smallest.

    The search is local: started a factor of 5 away from a sigmoid's steepness it can settle
    in a wrong valley (a shifted, flat sigmoid).  Every actuator's scale shapes are set to
    ``factor * initial`` at once, and each joint keeps the factor that explains its own
    rows best (the link parameters, shared by all joints, are re-solved each time), so
    this costs ``len(GRID)`` linear solves.  Shifts (``p3``) start where they were.
    """
    logs = [k for k, (f, _) in enumerate(unknowns) if f in _LOG]
    best, norms = np.ones(n), np.full(n, np.inf)
    for g in GRID:
        x = x0.copy()
        for k in logs:
            x[k * n:(k + 1) * n] += np.log(g)
        r = residual(x).reshape(-1, n)
        rn = np.einsum("ij,ij->j", r, r)
        better = rn < norms
        best[better], norms[better] = g, rn[better]
    x = x0.copy()
    for k in logs:
        x[k * n:(k + 1) * n] += np.log(best)
    return x, best


def _fd_steps(x0, unknowns, n) -> np.ndarray:
    """Absolute finite-difference steps per entry of theta: 1e-4 on the log scale shapes
    (a 0.01 % change of ``vs`` or ``alpha``), 1e-4 of ``max(|p3|, 1 / alpha)`` on a shift."""
    steps = np.full(x0.shape, 1e-4)
    alpha = dict(unknowns).get("sigmoid_alpha")
    for k, (f, v) in enumerate(unknowns):
        if f not in _LOG:
            steps[k * n:(k + 1) * n] = 1e-4 * np.maximum(np.abs(v), 1.0 / alpha)
    return steps


def fit_friction_shapes(arm, data, friction: Friction, method: str = "wls", *, armature: bool = False,
                        max_nfev: int = 60, **fit_kwargs):
    """Identify ``arm`` with a friction law whose nonlinear shapes are fitted too (module docstring).

    Parameters
    ----------
    arm : manipdyn.Manipulator
        Kinematics, transmission and prior, as for :func:`~manipdyn.identification.fit`.
    data : Measurements or (q, qd, qdd, tau)
        Joint-side samples, (N, n) each, SI (e.g. from :func:`~manipdyn.identification.read_log`).
    friction : manipdyn.Friction
        The law's terms, side, smoothing, and the INITIAL shapes (``stribeck_velocity``;
        ``sigmoid_alpha``, ``sigmoid_p3``), in the law's side's units (motor side:
        rad/s at the motor).  Its amplitudes are ignored (they are identified).
    method : "ols" | "wls" | "consistent"
        Of the final fit; the search itself uses the weighted least squares of ``wls``.
    armature : bool
        Identify the rotor inertias too.
    max_nfev : int
        Cap on ``least_squares``' residual evaluations.
    **fit_kwargs
        Passed to the final :func:`~manipdyn.identification.fit` (``bounds``, ``name``, ...).

    Returns
    -------
    FitResult
        Of the final fit; its arm carries the fitted shapes (``arm.friction_model``), and
        ``report["friction_shapes"]`` holds the initial shapes, the grid factor each search
        started from (``start_factor``), the fitted shapes, the weighted residual norm before
        and after, the evaluations, the solver's message, the shapes that ended at the search's
        bound (``at_bound``) and those the data do not determine (``undetermined``: the
        residual does not change with them).
    """
    law, info = fit_shapes(arm, data, friction, armature=armature, max_nfev=max_nfev, rest=fit_kwargs.get("rest"))
    q, qd, qdd, tau = (np.asarray(a, dtype=np.float64) for a in _samples(data))
    result = fit(arm, q, qd, qdd, tau, method=method, friction=law, armature=armature, **fit_kwargs)
    result.report["friction_shapes"] = info
    return result


def fit_shapes(arm, data, friction: Friction, *, armature: bool = False, max_nfev: int = 60, rest=None):
    """``(law, info)``: the shapes of ``friction`` fitted by variable projection (module docstring).

    The search of :func:`fit_friction_shapes` alone, for callers that go on to fit with the
    shapes held (e.g. to choose a prior weight first).  ``law`` is ``friction`` with the fitted
    shapes (its amplitudes untouched: zeros for a spec); ``info`` is what
    ``report["friction_shapes"]`` holds.  Parameters as for :func:`fit_friction_shapes`; ``rest``
    (n,) or None: the fit's rest threshold (:func:`~manipdyn.identification.fit`), a joint at rest still
    and out of its rows in the search too (a static friction there, at any level up to the breakaway,
    would pull a Stribeck shape towards whatever the rests held).
    """
    from ..._support.deps import require

    optimize = require("scipy.optimize", "fit_friction_shapes")
    if not isinstance(friction, Friction):
        raise ModelError(f"friction: expected a manipdyn.Friction holding the initial shapes, "
                         f"got {type(friction).__name__}")
    if friction.n != arm.n:
        raise ModelError(f"friction: the law is for {friction.n} actuators, the arm has {arm.n} joints")
    if isinstance(max_nfev, bool) or not isinstance(max_nfev, (int, np.integer)) or max_nfev < 1:
        raise ModelError(f"max_nfev: expected an integer >= 1, got {max_nfev!r}")
    q, qd, qdd, tau = (np.asarray(a, dtype=np.float64) for a in _samples(data))
    n = arm.n
    unknowns = _unknowns(friction)
    # the weights: each joint's noise level at the initial shapes (wls's, module docstring)
    try:
        first = fit(arm, q, qd, qdd, tau, method="wls", friction=friction, armature=armature, rest=rest)
    except ModelError as exc:
        raise ModelError(f"friction shapes: the search by variable projection runs weighted least squares "
                         f"at the starting shapes, and {exc}") from None
    qd, keep = still_rows(qd, rest)
    w = np.broadcast_to(1.0 / first.sigma, q.shape) if keep is None else keep / first.sigma    # (N, n): 0 at rest
    base0 = base_parameters(arm, armature=armature, friction=False)
    Yb = base0.regressor(arm.lagrange.regressor(q, qd, qdd, armature=armature, friction=False))
    y = tau if armature else tau - qdd @ np.asarray(arm.rotor_inertia)
    Aw0 = (Yb * w[:, :, None]).reshape(len(q) * n, -1)
    yw = (y * w).reshape(-1)
    tr = arm.transmission

    def residual(x):
        law = _with_shapes(friction, _unpack(x, unknowns, n))
        F = law.columns(qd, tr) * w[:, :, None]
        A = np.column_stack([Aw0, F.reshape(len(q) * n, -1)])
        sol = np.linalg.lstsq(A, yw, rcond=None)[0]
        return A @ sol - yw

    x0, lo, hi = _pack_bounds(unknowns)
    cost0 = float(np.linalg.norm(residual(x0)))
    x0, grid = _grid_start(residual, x0, unknowns, n)
    steps = _fd_steps(x0, unknowns, n)
    last = {}
    # the search runs on y = x - lo >= 0, never near 0 at its start: least_squares sizes its
    # first trust region by |y0|, and a log-shape of exactly 1 (x0 = 4e-16 after the grid)
    # made that region 1e-15 wide and the search stop at once (measured, before this shift)
    lo0 = lo.copy()

    def cached(y):
        key = y.tobytes()
        if key not in last:
            last.clear()
            last[key] = residual(y + lo0)
        return last[key]

    def jacobian(y):
        x = y + lo0
        # forward differences with ABSOLUTE steps (_fd_steps): scipy's relative diff_step
        # shrinks to ~1e-8 at x = 0, i.e. at a log-shape of exactly 1 or a shift of 0, where
        # the difference then vanished and the search stopped at its start (measured: a
        # Stribeck velocity started at 0.1 rad/s, moved by the grid to 1.0, "converged" after
        # one evaluation with a zero gradient)
        r0 = cached(y)
        J = np.empty((r0.size, x.size))
        for k in range(x.size):
            h = steps[k] if x[k] + steps[k] <= hi[k] else -steps[k]
            xk = x.copy()
            xk[k] += h
            J[:, k] = (residual(xk) - r0) / h
        return J

    res = optimize.least_squares(cached, x0 - lo0, jac=jacobian, bounds=(np.zeros_like(lo), hi - lo0),
                                 method="trf", x_scale="jac", max_nfev=int(max_nfev))
    shapes = _unpack(res.x + lo0, unknowns, n)
    at_bound = [f"{f}[{i + 1}]" for k, (f, _) in enumerate(unknowns) for i in range(n)
                if res.active_mask[k * n + i] != 0]
    # a shape the residual does not feel (a Stribeck velocity far above every speed in the log, a
    # sigmoid so flat it is viscous friction) is not determined by the data: say which
    cols = np.linalg.norm(res.jac, axis=0)       # trf returns the Jacobian at res.x (our own)
    flat = [f"{f}[{i + 1}]" for k, (f, _) in enumerate(unknowns) for i in range(n)
            if not cols[k * n + i] > 1e-6 * max(float(cols.max()), 1e-300)]
    info = {
        "initial": {f: v.tolist() for f, v in unknowns},
        "start_factor": grid.tolist(),
        "fitted": {f: v.tolist() for f, v in shapes.items()},
        "weighted_residual_norm": {"initial": cost0, "fitted": float(np.linalg.norm(res.fun))},
        "evaluations": int(res.nfev), "converged": bool(res.status > 0), "message": str(res.message),
        "at_bound": at_bound, "undetermined": flat,
    }
    return _with_shapes(friction, shapes), info
