"""Physical bodies with given base parameters: the one completion used by identification and the writers.

Layer 1 (model).

The joint torques see a link's ten parameters only through the base parameters (the combinations
of the parameter vector ``pi`` that the regressor ``Y(q, qd, qdd)`` does not annihilate).  A published
or identified arm may hold bodies no rigid body can be (a massless link with an inertia, a broken
triangle inequality), while some physical arm has exactly the same base parameters, hence exactly
the same dynamics.  :func:`complete_parameters` finds one:

* **The exact route.**  Every change is drawn from the null space ``N`` of the map to the base
  parameters (of ``K``, the base-parameter map, when the caller has it; else of the regressor
  stacked over seeded random states of the arm, ``W``): ``pi' = pi + N z``.  The base parameters
  are then kept by construction, to rounding (``|W (pi' - pi)|`` about 1e-15 of ``|W pi|``), whatever
  the semidefinite solver's accuracy on ``z``: the solver decides only how physical and how
  plausible the body is, never the dynamics.
* **Physical, with a margin MuJoCo accepts.**  In units of the arm (mass ``m_ref``, the mean link
  mass; length ``L``, the arm's size), every changed body satisfies ``J_i >= MARGIN I`` (its 4x4
  pseudo-inertia positive definite): mass, principal second moments about the COM and hence
  principal moments and the triangle inequalities ``A + B >= C`` all strictly positive, far above
  MuJoCo's ``mjMINVAL`` (1e-15) for any arm of grams and millimetres or more.
* **A plausible shape.**  Best effort (dropped, with a note, when no body satisfies it): every
  radius of gyration about the COM at least :func:`gyration_floor` (from the arm's own geometry
  when the prior body is degenerate: never 0 m) and at most the arm's size ``L`` (no body wider
  than the arm).  Among the bodies left, the one closest to the prior (the published body, or the
  identification's prior), in the arm's units.
* **Where no physical arm has these base parameters,** the nearest one: the physical arm whose
  torques differ least from the model's over the states (``min |W S (y - y0)|``), with how far off
  it is: the largest torque difference on those states (N m or N), the relative difference of the
  base parameters, and the largest single base parameter's relative miss.

cvxpy (the ``identify`` extra) solves the semidefinite programs, imported through
:func:`manipdyn._support.deps.require`; a missing extra is a
:class:`~manipdyn._support.errors.MissingExtraError` with the install command.  A body that needs no
change never calls the solver.

What MuJoCo refuses, and the floor: :mod:`manipdyn.model.plausible`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._support.errors import ModelError, is_solver_panic
from .inertia import LinkInertia, parameters_from_pseudo_inertia, pseudo_inertia_from_parameters
from .parameters import stacked_regressor
from .plausible import (GYRATION_FLOOR, MASSLESS, MJ_MINVAL, arm_scale, gyration_floor, is_massless, mujoco_refusal,
                        without_subnormals)

__all__ = ["Completion", "complete_parameters", "complete_bodies", "is_massless", "gyration_floor", "mujoco_refusal",
           "arm_scale", "MARGIN", "MJ_MINVAL", "GYRATION_FLOOR", "EXACT_RTOL"]

#: the margin of a changed body, ``J >= MARGIN I`` in the arm's units (module docstring): a changed
#: body of a 1 kg, 1 m arm has mass and second moments of at least 1e-9 (kg, kg m^2), six decades
#: above mjMINVAL
MARGIN = 1e-9
#: a completion counts as exact when ``|W (pi' - pi)|`` is under this fraction of ``|W pi|`` (the null
#: space is exact to rounding: measured 1e-16 to 1e-14 on the bundled arms; 1e-6 is the fit's target)
EXACT_RTOL = 1e-9
#: rank tolerance of the null space, relative to the largest singular value of the column-scaled map:
#: the regressor's dependent directions sit at 1e-15, the independent ones above 1e-6 (base.py's gap)
_RANK_RTOL = 1e-10
_D = np.diag([1.0, 1.0, 1.0, 0.0])


@dataclass(frozen=True)
class Completion:
    """What :func:`complete_parameters` found.

    Attributes
    ----------
    parameters : (p,) array
        The completed parameter vector (layout of :mod:`manipdyn.model.parameters`, URDF link frames).
    exact : bool
        The base parameters are kept (the torques agree to :data:`EXACT_RTOL` on the states).
    changed : list of int
        Indices (0-based) of the links whose bodies changed.
    notes : list of str
        One sentence per changed body (what was completed, and why), then one per dropped
        plausibility bound, then, when not exact, how far the nearest physical arm is.
    torque_difference : float
        Largest ``|Y (pi' - pi)|`` over the arm's seeded states (N m or N); 0 when nothing changed.
    torque_rtol : float
        That over the largest ``|Y pi|`` on the same states.
    base_error : float
        ``|K (pi' - pi)| / |K pi|`` with the caller's base-parameter map ``K`` (else the regressor's
        row space on the states stands for it).
    worst_base : float
        The largest single base parameter's relative miss ``|K (pi' - pi)|_k / |K pi|_k`` (0 when exact).
    solver : str
        The solver that answered ("none" when no body needed a change).
    """

    parameters: np.ndarray
    exact: bool
    changed: list
    notes: list = field(default_factory=list)
    torque_difference: float = 0.0
    torque_rtol: float = 0.0
    base_error: float = 0.0
    worst_base: float = 0.0
    solver: str = "none"

    def summary(self) -> str:
        """One line: exact or how far off."""
        if self.exact:
            return (f"{len(self.changed)} bod{'y' if len(self.changed) == 1 else 'ies'} completed with the same "
                    f"base parameters (torques agree to {self.torque_difference:.2g} on the model's states)")
        return (f"no physical arm has these base parameters; the nearest one differs by up to "
                f"{self.torque_difference:.3g} N m (N) on the model's states ({self.torque_rtol:.2g} of the "
                f"largest torque); its base parameters differ by {self.base_error:.2g} relative"
                + (f" (the worst one by {self.worst_base:.2g})" if self.worst_base != self.base_error else ""))


def _scales(n: int, p: int, m_ref: float, L: float) -> np.ndarray:
    """Per parameter, its unit: kg for masses, kg m for first moments, kg m^2 for inertias; 1 for extras."""
    per = np.array([m_ref, m_ref * L, m_ref * L, m_ref * L] + [m_ref * L * L] * 6)
    return np.concatenate([np.tile(per, n), np.ones(p - 10 * n)])


def _null_space(A, s) -> np.ndarray:
    """A basis (p, k) of the null space of ``A`` (rows, p), orthonormal in the scaled coordinates ``x / s``."""
    As = A * s[None, :]
    norms = np.linalg.norm(As, axis=0)
    zero = norms == 0
    if not np.any(As):
        return np.eye(A.shape[1]) * s[:, None]
    _u, sv, vt = np.linalg.svd(As[:, ~zero], full_matrices=True)
    rank = int(np.sum(sv > _RANK_RTOL * sv[0])) if sv.size else 0
    Nsub = vt[rank:].T                                     # (free, k)
    N = np.zeros((A.shape[1], Nsub.shape[1] + int(zero.sum())))
    N[np.flatnonzero(~zero), :Nsub.shape[1]] = Nsub
    N[np.flatnonzero(zero), Nsub.shape[1] + np.arange(int(zero.sum()))] = 1.0   # columns the map never sees
    return N * s[:, None]


def _J_expr(x, i, E):
    return sum(x[10 * i + k] * E[k] for k in range(10))


def _body_constraints(cp, y, links, floor, ceiling, margin):
    from .parameters import PARAMETER_BASIS as E

    cons = []
    for i in links:
        J = _J_expr(y, i, E)
        if floor is not None and floor[i] > 0:
            cons.append(J - float(floor[i]) ** 2 * y[10 * i] * _D - margin * np.eye(4) >> 0)
        else:
            cons.append(J - margin * np.eye(4) >> 0)
        if ceiling is not None:     # second moments about the COM at most ceiling^2 m: Schur form
            # ceiling^2 m I3 - Sigma >= 0 with Sigma = J11 - m c c^T: [[ceil^2 m I - J11 + h h^T/m]] is
            # not linear; the linear sufficient form: ceiling^2 m I3 - J11 >= 0 (J11 >= Sigma)
            cons.append(float(ceiling) ** 2 * y[10 * i] * np.eye(3) - J[:3, :3] >> 0)
    return cons


def _solve(cp, prob):
    """The solver that answered ``prob`` (Clarabel, else SCS), or None.  A solver's error, its
    refusal of the data (NaN, inf) or its panic (Clarabel's Rust ``PanicException``, a
    ``BaseException``: :func:`manipdyn._support.errors.is_solver_panic`) is that solver's failure."""
    import warnings

    for solver in ("CLARABEL", "SCS"):
        if solver not in cp.installed_solvers():
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                prob.solve(solver=solver)
        except (cp.error.SolverError, ValueError, ArithmeticError):
            continue
        except BaseException as exc:
            if not is_solver_panic(exc):
                raise
            continue
        if prob.status in ("optimal", "optimal_inaccurate"):
            return solver + ("" if prob.status == "optimal" else " (inaccurate)")
        if prob.status in ("infeasible", "infeasible_inaccurate"):
            return None
    return None


def _normalized_eigenvalues(pi, links, m_ref, L) -> np.ndarray:
    """Smallest eigenvalue of each listed link's pseudo-inertia in the arm's units (``J / m_ref`` with
    lengths over ``L``): the quantity the margin :data:`MARGIN` bounds."""
    links = list(links)
    if not links:
        return np.zeros(0)
    P = np.asarray(pi, dtype=np.float64)[:10 * (max(links) + 1)].reshape(-1, 10)[links]
    J = pseudo_inertia_from_parameters(P)
    Ti = np.diag([1.0 / L] * 3 + [1.0])
    return np.linalg.eigvalsh(Ti @ J @ Ti / m_ref)[:, 0]


def _physical(pi, links, m_ref, L, margin) -> bool:
    return bool(np.all(_normalized_eigenvalues(pi, links, m_ref, L) >= margin))


def complete_parameters(arm, pi=None, *, K=None, prior=None, links=None, floor=None, plausible: bool = True,
                        nonnegative=None, W=None) -> Completion:
    """Physical bodies with the base parameters of ``pi`` (module docstring).

    Parameters
    ----------
    arm : manipdyn.Arm
        The kinematics (and, by default, the prior bodies and the parameters themselves).
    pi : (p,) array, optional
        The parameter vector to complete (default: the arm's own link parameters, 10 n).  Entries
        after the 10 n link ones (armature, friction) may move only within ``K``'s null space too.
    K : (r, p) array, optional
        The base-parameter map ``beta = K pi`` (e.g. ``BaseParameters.K``); default: the regressor
        over the arm's seeded states (:func:`manipdyn.model.parameters.stacked_regressor`), whose null
        space is the same.
    prior : (p,) array, optional
        The body to stay close to (default ``pi``; the prior arm's parameters for an identification).
    links : sequence of int, optional
        The links whose bodies must be made physical (default: every link).  The others are left as
        they are when some completion of ``links`` alone exists, else every link may change.
    floor : (n,) array, optional
        Radius-of-gyration floor per link, m (default :func:`gyration_floor`); with ``plausible``.
    plausible : bool
        Ask for the floor and a radius of gyration at most the arm's size (best effort).
    nonnegative : (p - 10 n,) bool array, optional
        Which extra entries must stay >= 0 (default: none constrained).
    W : (rows, 10 n) or (rows, p) array, optional
        The stacked regressor on which differences are measured, the "model's states" (default
        :func:`manipdyn.model.parameters.stacked_regressor`; an identification passes its data's).

    Returns a :class:`Completion`; raises :class:`ModelError` for parameters of the wrong shape and
    :class:`~manipdyn._support.errors.MissingExtraError` when a body needs the solver and cvxpy is missing.
    """
    n = arm.n
    own = np.concatenate([parameters_from_pseudo_inertia(np.array([j.body.J for j in arm.chain()[0]])).reshape(-1)])
    pi = own if pi is None else np.asarray(pi, dtype=np.float64)
    if pi.ndim != 1 or pi.shape[0] < 10 * n or not np.all(np.isfinite(pi)):
        raise ModelError(f"pi: expected a finite vector of at least {10 * n} entries (10 per link), got "
                         f"shape {pi.shape}")
    p = pi.shape[0]
    prior = pi if prior is None else np.asarray(prior, dtype=np.float64)
    if prior.shape != pi.shape:
        raise ModelError(f"prior: expected shape {pi.shape}, got {prior.shape}")
    given = pi          # the bodies as given, for what the notes say was completed
    pi, prior, sub_notes = without_subnormals(pi, prior, n)
    if not np.any(pi[:10 * n]):
        raise ModelError(MASSLESS)
    if K is not None:
        K = np.asarray(K, dtype=np.float64)
        if K.ndim != 2 or K.shape[1] != p:
            raise ModelError(f"K: expected shape (r, {p}) (the base-parameter map), got {K.shape}")
    m_ref, L = arm_scale(arm)
    s = _scales(n, p, m_ref, L)
    if W is None:
        W = stacked_regressor(arm, 60)
    if floor is None:
        floor = gyration_floor(arm)
    floor = np.asarray(floor, dtype=np.float64)
    bodies = [_body(given, i) for i in range(n)]
    refused = {i: mujoco_refusal(b) for i, b in enumerate(bodies)}
    want = sorted(range(n) if links is None else {int(i) for i in links})
    bad = [i for i in want if refused[i] is not None or not _physical(pi, [i], m_ref, L, 0.0)]
    if not bad:
        return Completion(parameters=pi.copy(), exact=True, changed=[], notes=sub_notes, solver="none")
    from .._support.deps import require

    cp = require("cvxpy", "completing a body that no rigid body can be (manipdyn.model.completion)")
    W = _full_width(W, p)
    A = K if K is not None else W
    # the refused bodies alone; with the links before them (a link's mass is grouped with its parent's
    # parameters); then every link
    near = sorted(set(bad) | {i - 1 for i in bad if i > 0})
    attempts = [a for a in (bad, near) if links is not None and len(a) < n] + [list(range(n))]
    attempts = [a for k, a in enumerate(attempts) if a not in attempts[:k]]
    notes: list = list(sub_notes)
    result = None
    for free_links in attempts:
        result = _exact(cp, pi, prior, A, s, n, p, free_links, floor, plausible, nonnegative, K is not None,
                        m_ref, L, MARGIN, notes)
        if result is not None:
            break
    exact = result is not None
    if result is None:       # the nearest physical arm, then the bodies closest to the prior among its kind
        result = _nearest(cp, pi, prior, s, n, p, W, K, MARGIN, nonnegative)
        keep = [i for i in range(n) if refused[i] is None and _physical(pi, [i], m_ref, L, MARGIN)
                and np.abs((result[0] - pi)[10 * i:10 * i + 10] / s[10 * i:10 * i + 10]).max() < 1e-11]
        for i in keep:         # solver noise on a body that needs no change: the body as given
            result[0][10 * i:10 * i + 10] = pi[10 * i:10 * i + 10]
    new, solver = result
    return _finish(arm, pi, new, n, W, K, exact, solver, refused, notes, bodies)


def _exact(cp, pi, prior, A, s, n, p, free_links, floor, plausible, nonnegative, extras_move, m_ref, L, margin,
           notes):
    """``(pi', solver)``: ``pi`` moved within the null space of ``A`` (only the ``free_links``' entries, and
    the extras when ``extras_move``) to physical bodies closest to ``prior``; None when there are none."""
    free = np.zeros(p, dtype=bool)
    for i in free_links:
        free[10 * i:10 * i + 10] = True
    free[10 * n:] = extras_move
    Nf = _null_space(A[:, free], s[free])            # (free, k), orthonormal in the scaled coordinates
    if Nf.shape[1] == 0:
        return None
    N = np.zeros((p, Nf.shape[1]))
    N[free] = Nf
    Ny = N / s[:, None]
    y0, yprior = pi / s, prior / s
    # the solver is asked for 100 times the margin (its own feasibility tolerance is about 1e-8 in these
    # units, above MARGIN), then for the margin itself, accepting a tenth of it (still 1e-10 of the arm's
    # units, five decades above mjMINVAL for a 1 kg, 1 m arm)
    for plaus, ask, accept in ([(True, 100 * margin, margin)] if plausible else []) + [
            (False, 100 * margin, margin), (False, margin, 0.1 * margin)]:
        z = cp.Variable(N.shape[1])
        y = y0 + Ny @ z
        cons = _body_constraints(cp, y, free_links, floor / L if plaus else None, 1.0 if plaus else None, ask)
        if nonnegative is not None and p > 10 * n:
            idx = 10 * n + np.flatnonzero(np.asarray(nonnegative, dtype=bool))
            if idx.size:
                cons.append(y[idx] >= 0)
        solver = _solve(cp, cp.Problem(cp.Minimize(cp.sum_squares(y - yprior)), cons))
        if solver is None or z.value is None:
            continue
        new = _snap(pi + N @ np.asarray(z.value, dtype=np.float64), pi, N, s)
        if not _physical(new, free_links, m_ref, L, accept):
            continue
        if plausible and not plaus:
            notes.append("the plausible shape (radii of gyration between "
                         f"{', '.join(f'{f:.3g}' for f in floor[free_links])} m and the arm's size {L:.3g} m) "
                         "has no body with these base parameters: dropped, the bodies are physical only")
        return new, solver
    return None


def _snap(new, pi, N, s, rtol=1e-11):
    """``new`` with the solver's round-off (entries under ``rtol`` of their unit) moved to exactly 0
    within the null space ``N``: a product of inertia of 5e-14 kg m^2
    is the interior-point solver's rounding, not a body.  The move is the least-squares one in the
    null space (the base parameters stay), then the entries are set to 0 (a change at rounding level)."""
    E = np.flatnonzero((np.abs(new) < rtol * s) & (new != 0) & np.any(N != 0, axis=1))   # free entries only
    if E.size == 0:
        return new
    w = np.linalg.lstsq(N[E], -new[E], rcond=None)[0]
    out = new + N @ w
    if np.abs((out - new) / s).max() > 1e-9:     # the null space cannot zero them without moving the body
        return new
    out[E] = 0.0
    return out


def _nearest(cp, pi, prior, s, n, p, W, K, margin, nonnegative):
    """The physical arm whose torques on the states differ least from ``pi``'s (no exact one exists)."""
    y0, yprior = pi / s, prior / s
    y = cp.Variable(p)
    A = (K if K is not None else _full_width(W, p)) * s[None, :]
    scale = max(float(np.linalg.norm(A @ y0)), 1e-300)
    cons = _body_constraints(cp, y, range(n), None, None, margin)
    if nonnegative is not None and p > 10 * n:
        idx = 10 * n + np.flatnonzero(np.asarray(nonnegative, dtype=bool))
        if idx.size:
            cons.append(y[idx] >= 0)
    solver = _solve(cp, cp.Problem(cp.Minimize(cp.norm(A @ (y - y0)) / scale), cons))
    if solver is None or y.value is None:
        raise ModelError("completion: the solver found no physical arm at all (is the arm's scale extreme?)")
    d1 = float(np.linalg.norm(A @ (np.asarray(y.value) - y0))) / scale
    # step 2: among the arms as near (to 1e-3 of the distance), the one closest to
    # the prior: the bodies the data (or the model) do not constrain stay where they were
    y2 = cp.Variable(p)
    cons2 = _body_constraints(cp, y2, range(n), None, None, margin)
    if nonnegative is not None and p > 10 * n:
        idx = 10 * n + np.flatnonzero(np.asarray(nonnegative, dtype=bool))
        if idx.size:
            cons2.append(y2[idx] >= 0)
    cons2.append(cp.norm(A @ (y2 - y0)) / scale <= d1 * (1 + 1e-3) + 1e-12)
    first = np.asarray(y.value, dtype=np.float64)
    if _solve(cp, cp.Problem(cp.Minimize(cp.sum_squares(y2 - yprior)), cons2)) is not None and y2.value is not None:
        y = y2
    new = (np.asarray(y.value, dtype=np.float64) if y.value is not None else first) * s
    # guard the margin against the solver's rounding: raise the eigenvalues under it
    m_ref, L = s[0], s[1] / s[0]
    J = pseudo_inertia_from_parameters(new[:10 * n].reshape(n, 10))
    Ti, T = np.diag([1.0 / L] * 3 + [1.0]), np.diag([L] * 3 + [1.0])
    w, V = np.linalg.eigh(Ti @ J @ Ti / m_ref)
    if np.any(w < margin):
        Jn = (V * np.maximum(w, margin)[:, None, :]) @ np.swapaxes(V, -1, -2)
        new[:10 * n] = parameters_from_pseudo_inertia(T @ Jn @ T * m_ref).reshape(-1)
    if nonnegative is not None and p > 10 * n:
        idx = 10 * n + np.flatnonzero(np.asarray(nonnegative, dtype=bool))
        new[idx] = np.maximum(new[idx], 0.0)
    return new, solver


def _body(pi, i) -> LinkInertia:
    J = pseudo_inertia_from_parameters(np.asarray(pi)[10 * i:10 * i + 10])
    J = 0.5 * (J + J.T)
    if J[3, 3] <= 0:
        J[:3, 3] = J[3, :3] = 0.0
        J[3, 3] = max(J[3, 3], 0.0)
    try:
        return LinkInertia.from_pseudo_inertia(J, name=f"link {i + 1}")
    except ModelError:
        return LinkInertia(mass=0.0, name=f"link {i + 1}")


def _describe(old: LinkInertia, new: LinkInertia) -> str:
    parts = []
    if not np.isclose(old.mass, new.mass, rtol=1e-9, atol=0):
        parts.append(f"mass {old.mass:.6g} -> {new.mass:.6g} kg")
    if not np.allclose(old.com, new.com, rtol=1e-9, atol=1e-12):
        parts.append(f"centre of mass {np.round(old.com, 6).tolist()} -> {np.round(new.com, 6).tolist()} m")
    wo, wn = (np.linalg.eigvalsh(0.5 * (b.inertia + b.inertia.T)) for b in (old, new))
    if not np.allclose(wo, wn, rtol=1e-9, atol=1e-15) or not np.allclose(old.inertia, new.inertia, rtol=1e-9,
                                                                             atol=1e-15):
        parts.append(f"principal moments {[float(f'{x:.4g}') for x in wo]} -> {[float(f'{x:.4g}') for x in wn]} "
                     "kg m^2")
    return ", ".join(parts) or "unchanged beyond rounding"


def _full_width(W, p):
    """The stacked regressor ``W`` with zero columns for the extras it does not have: (rows, p)."""
    W = np.asarray(W, dtype=np.float64)
    return W if W.shape[1] == p else np.concatenate([W, np.zeros((W.shape[0], p - W.shape[1]))], axis=1)


def _finish(arm, pi, new, n, W, K, exact, solver, refused, notes, bodies) -> Completion:
    d = new - pi
    W = _full_width(W, pi.shape[0])
    tau = W @ pi
    dt = W @ d
    big = max(float(np.abs(tau).max()), 1e-300)
    tdiff = float(np.abs(dt).max())
    if K is not None:
        kb, kd = K @ pi, K @ d
    else:
        kb, kd = tau, dt
    base_err = float(np.linalg.norm(kd) / max(float(np.linalg.norm(kb)), 1e-300))
    worst = (float(np.max(np.abs(kd) / np.maximum(np.abs(kb), 1e-12 * max(float(np.abs(kb).max()), 1e-300))))
             if K is not None else base_err)
    if K is None:
        exact = exact and tdiff <= EXACT_RTOL * big
    changed = []
    out_notes = []
    slight = []
    joints, _tool = arm.chain()
    m_ref, L = arm_scale(arm)
    s = _scales(n, 10 * n, m_ref, L)
    for i in range(n):
        nb = _body(new, i)
        if np.array_equal(new[10 * i:10 * i + 10], pi[10 * i:10 * i + 10]):
            continue
        changed.append(i)
        name = getattr(joints[i], "link_name", "") or f"link {i + 1}"
        why = refused[i]
        if why is None and np.abs(d[10 * i:10 * i + 10] / s[10 * i:10 * i + 10]).max() < 1e-4:
            slight.append(name)
            continue
        reason = (f"MuJoCo refuses the body as given: {why}" if why is not None else
                  "it moved with the refused bodies, which share base parameters with it")
        out_notes.append(f"link {name!r} (joint {i + 1}) completed ({reason}): {_describe(bodies[i], nb)}; "
                         + ("the base parameters are kept, so the dynamics are the model's"
                            if exact else "part of the nearest physical arm"))
    if slight:
        out_notes.append(f"link{'s' if len(slight) > 1 else ''} {', '.join(map(repr, slight))} moved with them by "
                         f"under 1e-4 of the arm's units ({m_ref:.3g} kg, {L:.3g} m)")
    out_notes += notes
    c = Completion(parameters=new, exact=bool(exact), changed=changed, notes=out_notes, torque_difference=tdiff,
                   torque_rtol=tdiff / big, base_error=base_err, worst_base=0.0 if exact else worst, solver=solver)
    if not exact:
        out_notes.append(c.summary())
    return c


def complete_bodies(arm, plausible: bool = True):
    """``(bodies, completion)``: the arm's chain bodies (:class:`LinkInertia`, URDF link frames) with
    every body MuJoCo refuses (:func:`mujoco_refusal`) completed (:func:`complete_parameters`); the
    bodies MuJoCo accepts are kept as they are when the refused ones can be completed alone."""
    joints, _tool = arm.chain()
    refused = [i for i, j in enumerate(joints) if mujoco_refusal(j.body) is not None]
    if not refused:
        return [j.body for j in joints], Completion(parameters=np.zeros(0), exact=True, changed=[])
    c = complete_parameters(arm, links=refused, plausible=plausible)
    out = [(_body(c.parameters, i) if i in c.changed else j.body) for i, j in enumerate(joints)]
    out = [LinkInertia(mass=b.mass, com=b.com, inertia=b.inertia, name=getattr(j.body, "name", "link"))
           if i in c.changed else b for i, (b, j) in enumerate(zip(out, joints))]
    return out, c

