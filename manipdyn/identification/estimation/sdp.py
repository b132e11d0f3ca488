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
Clarabel fails; both are open source.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._support.errors import ModelError
from ...model.parameters import PARAMETER_BASIS
from ...model.inertia import pseudo_inertia_from_parameters
from ...model.plausible import gyration_floor, smallest_gyration
from ..._support.deps import require
from .solvers import solve as _solve

__all__ = ["Bounds", "consistent_fit", "solve_problem", "smallest_gyration", "EPS"]

#: margin of the PSD constraints, J_i >= EPS * I (see the module docstring)
EPS = 1e-8
#: weight of step 1's pull towards the prior (see :func:`consistent_fit`)
REG = 1e-7
#: ratio of the data's torque to the prior's beyond which the prior's magnitude is scaled away
#: (see :func:`consistent_fit`)
PRIOR_RANGE = 10.0
#: defaults of :meth:`Bounds.plausible`: link mass factor, COM box (m), total mass fraction
PLAUSIBLE_MASS = 0.5
PLAUSIBLE_COM = 0.1
PLAUSIBLE_TOTAL = 0.25
PLAUSIBLE_GYRATION = 0.01


@dataclass(frozen=True)
class Bounds:
    """Optional bounds of the consistent fit (URDF link frames, SI units).

    Attributes
    ----------
    mass : (n, 2) array or None
        ``lo_i <= m_i <= hi_i`` (kg).
    com : (n, 2, 3) array or None
        The centre of mass inside the box ``[lo, hi]`` (m): ``m lo <= m c <= m hi``.
    gyration : (n,) array or None
        Floor ``r_i`` (m) of the radii of gyration about the COM: ``J_i - r_i^2 m_i diag(1, 1, 1, 0) >= 0``
        (linear in J), every principal second moment about the COM at least ``m_i r_i^2``.
    """

    mass: np.ndarray | None = None
    com: np.ndarray | None = None
    total_mass: tuple | None = None
    gyration: np.ndarray | None = None

    def __post_init__(self):
        for name in ("mass", "com", "total_mass", "gyration"):
            v = getattr(self, name)
            if v is None:
                continue
            if isinstance(v, np.ma.MaskedArray):
                if np.ma.getmaskarray(v).any():
                    raise ModelError(f"Bounds.{name}: a masked array with masked entries (the mask "
                                     "would be dropped); pass v.filled(value)")
                v = np.ma.getdata(v)
            try:
                a = np.asarray(v)
                if a.dtype.kind == "O" and not isinstance(v, np.ndarray):
                    a = np.array(v, dtype=np.float64)   # nested Python numbers
                    if any(isinstance(x, (bool, np.bool_)) for x in np.ravel(np.asarray(v, dtype=object))):
                        raise TypeError("a bool")
            except (TypeError, ValueError, OverflowError) as exc:
                raise ModelError(f"Bounds.{name}: expected real numbers, got {v!r:.60} ({exc})") from None
            if a.dtype.kind not in "fiu":
                raise ModelError(f"Bounds.{name}: expected real numbers, got dtype {a.dtype} "
                                 f"({ {'b': 'bool', 'c': 'complex', 'O': 'object', 'U': 'string', 'S': 'bytes', 'M': 'datetime64', 'm': 'timedelta64'}.get(a.dtype.kind, a.dtype.kind)})")
            a = np.array(a, dtype=np.float64)   # native byte order, a copy we own
            if not np.all(np.isfinite(a)):
                raise ModelError(f"Bounds.{name}: must be finite, got {a.tolist()}")
            want = {"mass": (None, 2), "com": (None, 2, 3), "total_mass": (2,), "gyration": (None,)}[name]
            if a.ndim != len(want) or any(w is not None and w != s for w, s in zip(want, a.shape)):
                raise ModelError(f"Bounds.{name}: expected shape {tuple('n' if w is None else w for w in want)}, "
                                 f"got {a.shape}")
            lo, hi = ((a[..., 0, :], a[..., 1, :]) if name == "com" else (0 * a, a) if name == "gyration"
                      else (a[..., 0], a[..., 1]))
            if np.any(lo > hi):
                raise ModelError(f"Bounds.{name}: a lower bound exceeds its upper bound")
            if name in ("mass", "total_mass", "gyration") and np.any(lo < 0):
                raise ModelError(f"Bounds.{name}: masses must be >= 0")
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @classmethod
    def plausible(cls, arm, mass: float | None = PLAUSIBLE_MASS, com: float | None = PLAUSIBLE_COM,
                  total: float | None = PLAUSIBLE_TOTAL, gyration: float | None = PLAUSIBLE_GYRATION) -> "Bounds":
        """The default bounds of ``identify --method consistent``: plausible around the prior.

        * each link's mass within ``+-mass`` (fraction) of the prior's ``m``: ``[m (1 - mass),
          m (1 + mass)]`` (default 0.5; a massless prior link may take up to ``mass`` times a
          tenth of the heaviest prior link's mass);
        * each centre of mass within ``+-com`` m of the prior's, per axis of the URDF link
          frame (default 0.1 m: a centre of mass stays on its link);
        * the total mass within ``+-total`` (fraction) of the prior's (default 0.25);
        * every radius of gyration about a body's COM at least ``gyration`` (default 0.01) of the
          arm's size (joint offsets and tool summed), or half the prior body's own if less; from the
          geometry alone where the prior body is degenerate (massless, a rod or a plate): never 0 m
          (:func:`manipdyn.model.completion.gyration_floor`).  Else, where the data do not decide a
          body's shape, the fit ends on ``J_i >= 0`` (issue 30).

        A bound given as None is left out.  Why: ten seconds of data rarely pin down every
        parameter direction, and an unbounded physically consistent fit can put a 79 kg
        Panda (the real one is 18 kg) on a face of the feasible set that fits the noise.
        """
        joints, _ = arm.chain()
        m = np.array([j.body.mass for j in joints])
        c = np.array([j.body.com for j in joints])
        kw = {}
        if mass is not None:
            if not 0 <= mass < float("inf"):
                raise ModelError(f"mass: expected a finite fraction >= 0, got {mass}")
            hi = np.where(m > 0, m * (1 + mass), mass * max(float(m.max()), 0.0) / 10)
            kw["mass"] = np.stack([m * max(0.0, 1 - mass), hi], axis=1)
        if com is not None:
            if not 0 <= com < float("inf"):
                raise ModelError(f"com: expected a finite distance >= 0 m, got {com}")
            kw["com"] = np.stack([c - com, c + com], axis=1)
        if total is not None:
            if not 0 <= total < 1:
                raise ModelError(f"total: expected a fraction in [0, 1), got {total}")
            kw["total_mass"] = (float(m.sum()) * (1 - total), float(m.sum()) * (1 + total))
        if gyration:       # never above half a prior body's own (a flat link stays feasible), never 0 m
            kw["gyration"] = gyration_floor(arm, gyration)
        return cls(**kw)

    def scaled(self, factor: float) -> "Bounds":
        """The same bounds for parameters multiplied by ``factor`` (masses scaled, COM boxes kept)."""
        return Bounds(mass=None if self.mass is None else self.mass * factor, com=self.com,
                      total_mass=None if self.total_mass is None else self.total_mass * factor, gyration=self.gyration)

    def check(self, n: int) -> None:
        """Raise :class:`ModelError` unless these bounds are for an arm of ``n`` links."""
        for name in ("mass", "com"):
            a = getattr(self, name)
            if a is not None and a.shape[0] != n:
                raise ModelError(f"Bounds.{name}: {a.shape[0]} rows for an arm of {n} links")

    def satisfied(self, pi, n: int, rtol: float = 1e-9) -> bool:
        """Whether the full parameters ``pi`` satisfy every bound (to ``rtol`` of the bound)."""
        pi = np.asarray(pi, dtype=np.float64)
        m = pi[10 * np.arange(n)]
        if self.mass is not None:
            tol = rtol * np.maximum(self.mass[:, 1], 1e-12)
            if np.any(m < self.mass[:, 0] - tol) or np.any(m > self.mass[:, 1] + tol):
                return False
        if self.com is not None:
            mc = pi[(10 * np.arange(n))[:, None] + np.arange(1, 4)]
            tol = rtol * np.maximum(np.abs(self.com).max(), 1.0) * np.maximum(np.abs(m), 1e-12)[:, None]
            if np.any(mc < m[:, None] * self.com[:, 0] - tol) or np.any(mc > m[:, None] * self.com[:, 1] + tol):
                return False
        if self.total_mass is not None:
            tot, (lo, hi) = float(m.sum()), self.total_mass
            if tot < lo - rtol * hi or tot > hi + rtol * hi:
                return False
        return True       # the gyration floor is a plausibility floor, best effort: active() names it

    def active(self, pi, n: int, rtol: float = 1e-4) -> list[str]:
        """The bounds that the full parameters ``pi`` sit on (within ``rtol``), as readable strings."""
        pi = np.asarray(pi, dtype=np.float64)
        m = pi[10 * np.arange(n)]
        out = []
        if self.mass is not None:
            for i in range(n):
                lo, hi = self.mass[i]
                tol = rtol * max(hi, 1e-9)
                if m[i] <= lo + tol or m[i] >= hi - tol:
                    which = "lower" if m[i] <= lo + tol else "upper"
                    out.append(f"link {i + 1} mass at its {which} bound {m[i]:.4g} kg")
        if self.com is not None:
            for i in range(n):
                if m[i] <= 0:
                    continue
                ci = pi[10 * i + 1:10 * i + 4] / m[i]
                for ax, name in enumerate("xyz"):
                    lo, hi = self.com[i, 0, ax], self.com[i, 1, ax]
                    tol = rtol * max(abs(hi - lo), 1e-9)
                    if ci[ax] <= lo + tol or ci[ax] >= hi - tol:
                        out.append(f"link {i + 1} centre of mass {name} = {ci[ax]:.4g} m at its bound")
        if self.total_mass is not None:
            lo, hi = self.total_mass
            tot = float(m.sum())
            if tot <= lo + rtol * hi or tot >= hi - rtol * hi:
                out.append(f"total mass {tot:.4g} kg at its bound [{lo:.4g}, {hi:.4g}] kg")
        if self.gyration is not None:      # the body's own radius, as the model on disk has it (issue 38)
            rg = smallest_gyration(pi, n)
            out += [f"link {i + 1} radius of gyration {rg[i]:.3g} m at its floor {self.gyration[i]:.3g} m"
                    if rg[i] >= self.gyration[i] * (1 - FLOOR_RTOL) else
                    f"link {i + 1} radius of gyration {rg[i]:.3g} m below its floor {self.gyration[i]:.3g} m: the "
                    "floor does not hold on this body"
                    for i in range(n) if m[i] > 0 and rg[i] <= self.gyration[i] * (1 + FLOOR_RTOL)]
        return out

    @classmethod
    def around(cls, arm, mass: float = 0.5, com: float = 0.1) -> "Bounds":
        """Masses within ``+-mass`` (fraction) of the prior's, COMs within ``+-com`` m of them."""
        joints, _ = arm.chain()
        m = np.array([j.body.mass for j in joints])
        c = np.array([j.body.com for j in joints])
        return cls(mass=np.stack([m * (1 - mass), m * (1 + mass)], axis=1),
                   com=np.stack([c - com, c + com], axis=1))


def solve_problem(problem, what: str, solvers=("CLARABEL", "SCS")) -> str:
    """Solve the cvxpy ``problem`` with Clarabel, else SCS; return the solver's name.

    An "optimal_inaccurate" answer is kept (its name then ends in
    ``" (inaccurate)"``) only when no solver is accurate; when none succeeds,
    :class:`ModelError` says why, naming ``what``.
    """
    cp = require("cvxpy", what)
    return _solve(cp, problem, what, solvers)


#: a body whose smallest radius of gyration is within this fraction above its floor sits on it
FLOOR_RTOL = 0.02


def _constraints(cp, x, n, extra, bounds, eps=EPS, nonnegative=None):
    E = PARAMETER_BASIS
    cons = []
    floor = None if bounds is None or bounds.gyration is None else bounds.gyration ** 2
    for i in range(n):
        J = sum(x[10 * i + k] * E[k] for k in range(10))
        if floor is not None and floor[i] > 0:
            J = J - floor[i] * x[10 * i] * np.diag([1.0, 1, 1, 0])
        cons.append(J - eps * np.eye(4) >> 0)
    if extra:
        idx = np.arange(10 * n, x.shape[0])   # armature, friction coefficients (not offsets)
        if nonnegative is not None:
            idx = idx[np.asarray(nonnegative, dtype=bool)]
        if idx.size:
            cons.append(x[idx] >= 0)
    if bounds is not None:
        if bounds.mass is not None:
            mb = np.asarray(bounds.mass, dtype=np.float64)
            cons += [x[10 * np.arange(n)] >= mb[:, 0], x[10 * np.arange(n)] <= mb[:, 1]]
        if bounds.com is not None:
            cb = np.asarray(bounds.com, dtype=np.float64)
            for i in range(n):
                m, mc = x[10 * i], x[10 * i + 1:10 * i + 4]
                cons += [mc >= m * cb[i, 0], mc <= m * cb[i, 1]]
        if bounds.total_mass is not None:
            tot = cp.sum(x[10 * np.arange(n)])
            cons += [tot >= bounds.total_mass[0], tot <= bounds.total_mass[1]]
    return cons


def consistent_fit(R, c, K, n, prior, extra: bool, bounds: Bounds | None = None,
                   prior_weight: float = 0.0, rows: int | None = None, nonnegative=None):
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

    Returns ``(pi, solver)``.
    """
    cp = require("cvxpy", "the consistent fit")
    R, c, prior = (np.asarray(v, dtype=np.float64) for v in (R, c, prior))
    K = np.asarray(K, dtype=np.float64)
    p = K.shape[1]
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
    if bounds is not None:
        bounds = bounds.scaled(1.0 / u)
    x = cp.Variable(p)
    scale = max(1e-300, float(np.linalg.norm(c)))
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
        E = PARAMETER_BASIS
        div = sum(cp.trace(np.linalg.inv(J0[i]) @ sum(x[10 * i + k] * E[k] for k in range(10)))
                  - cp.log_det(sum(x[10 * i + k] * E[k] for k in range(10))) for i in range(n))
        obj = cp.sum_squares(R @ (K @ x) - c) / rows + float(prior_weight) * div / n
    else:
        # the pull's target is the prior scaled with the data (x = prior): the fit (beta) is
        # then the same problem at any scale of the data
        obj = cp.norm(R @ (K @ x) - c) / scale + REG * cp.norm(x - prior) / max(1.0, float(np.linalg.norm(prior)))
    if not prior_weight:
        xs = _least_squares_if_physical(cp, R, c, K, n, prior_u, pscale, extra, bounds, nonnegative, eps)
        if xs is not None:
            return u * project_physical(xs, n, eps=eps, nonnegative=nonnegative), "CLARABEL; least squares is physical"
    # bounds are tried last: when the answer without them already satisfies them, they are
    # inactive and the smaller problem is solved more accurately (interior-point solvers
    # lose digits on many inactive inequality rows: 1e-7 instead of 1e-11 relative on exact data)
    if bounds is not None:
        try:
            xs, solver = _two_steps(cp, x, obj, K, n, prior_u, pscale, extra, None, nonnegative, eps, (R, c),
                                    bodies_fixed=bool(prior_weight))
            if bounds.satisfied(xs, n):
                return u * project_physical(xs, n, eps=eps, nonnegative=nonnegative), solver
        except ModelError:
            pass
    xs, solver = _two_steps(cp, x, obj, K, n, prior_u, pscale, extra, bounds, nonnegative, eps, (R, c),
                            bodies_fixed=bool(prior_weight))
    return u * project_physical(xs, n, eps=eps, nonnegative=nonnegative), solver


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


def _least_squares_if_physical(cp, R, c, K, n, prior, pscale, extra, bounds, nonnegative, eps):
    """The full parameters closest to the prior whose base parameters are the least-squares
    ones, ``K x = R^-1 c``, when some physical (and in-bounds) x has them, else None.

    Such an x minimises step 1's residual over all x, so it is step 1's answer (up to the
    REG pull); taking it directly keeps the least-squares accuracy (1e-11 of the smallest
    joint's torque on exact data) where a conic solver would stop at ~1e-8 of the largest.
    """
    beta = np.linalg.lstsq(R, c, rcond=None)[0]
    x2 = cp.Variable(K.shape[1])
    prob = cp.Problem(cp.Minimize(cp.sum_squares((x2 - prior) / pscale)),
                      [K @ x2 == beta] + _constraints(cp, x2, n, extra, bounds, eps=eps / 2,
                                                      nonnegative=nonnegative))
    try:
        if _solve(cp, prob, "least squares", solvers=("CLARABEL",)) != "CLARABEL":
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


def _two_steps(cp, x, obj, K, n, prior, pscale, extra, bounds, nonnegative, eps=EPS, data=None, bodies_fixed=False):
    """Step 1 (the fit) and step 2 (closest to the prior, same base parameters): ``(pi, solver)``.

    ``bodies_fixed``: step 1 pulled the bodies towards the prior by the log-det divergence, which is strictly
    convex in them, so its bodies are already the ones closest to the prior in that (physical) measure; a
    Euclidean step 2 would move them off it, onto the ``J >= 0`` boundary where the Euclidean projection of
    the prior lands (measured on the Panda: four links degenerate, radius of gyration 1e-4 m).  Step 2 then
    moves only the entries beyond the bodies (armature, friction)."""
    p = K.shape[1]
    step1 = cp.Problem(cp.Minimize(obj), _constraints(cp, x, n, extra, bounds, eps=eps, nonnegative=nonnegative))
    solver = _solve(cp, step1, "step 1 (fit)")
    x1 = np.asarray(x.value, dtype=np.float64)
    # step 2: closest to the prior with the same base parameters, K pi = K x1
    # (an equality the interior-point solver keeps to ~1e-9).  Margin EPS / 2:
    # step 1's answer, often on the EPS boundary, is then strictly feasible.
    x2 = cp.Variable(p)
    fixed = [x2[:10 * n] == x1[:10 * n]] if bodies_fixed else []
    if bodies_fixed and p == 10 * n:
        return x1, solver
    step2 = cp.Problem(cp.Minimize(cp.sum_squares((x2 - prior) / pscale)),
                       [K @ x2 == K @ x1] + fixed + _constraints(cp, x2, n, extra, bounds, eps=eps / 2,
                                                                 nonnegative=nonnegative))
    try:
        _solve(cp, step2, "step 2 (closest to the prior)", solvers=("CLARABEL",))
        pi = np.asarray(x2.value, dtype=np.float64)
        beta1 = K @ x1
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
