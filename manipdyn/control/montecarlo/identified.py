"""Plants drawn from an identification: the arms that the data still allow.

Layer 6 (control: montecarlo).

``manipdyn identify ... --base-json F.json`` (or ``-o F.json``) writes a base model
(:mod:`manipdyn.identification.results.basemodel`): the prior, the identified base parameters
``beta_hat`` with their covariance ``C`` (``wls`` and ``consistent``; a file with
standard deviations only is read as a diagonal ``C``; with ``identify --bootstrap N``
the file also carries the block bootstrap's covariance, which is used instead: it
keeps the correlation of real residuals over time that the analytical ``C`` ignores),
and the full parameters ``pi_hat`` with ``K pi_hat = beta_hat``.  :class:`IdentifiedPlants`
turns it into the plants of a Monte-Carlo study (``manipdyn montecarlo MODEL
--plants-from F.json``, or ``montecarlo.study(..., plants="F.json")``):

1. **Draw.**  Run ``k`` of the study seeded ``s`` draws ``z ~ N(0, I_r)`` from
   ``default_rng(SeedSequence(s, spawn_key=(k, 1)))`` (a stream of its own: the
   run's start offset and torque noise keep theirs, ``spawn_key=(k,)``), and
   ``beta = beta_hat + L z`` with ``L L^T = C`` (Cholesky, or the symmetric square
   root when C is only semidefinite).
2. **To full parameters.**  ``pi0 = pi_hat + K^+ (beta - beta_hat)``: the smallest
   change (least squares) of the identified full parameters that gives the drawn
   base parameters.  What the data cannot see (the non-identifiable directions)
   stays at the identification's choice.  When ``pi0`` is physical (every link's
   pseudo-inertia ``J_i >= EPS / 2``, armature and friction coefficients ``>= 0``;
   offsets may have either sign) it is the plant, unchanged.
3. **Otherwise, the physical arm nearest in the metric of the covariance.**  Among the
   full parameters ``pi`` with ``J_i >= EPS I`` (``EPS = 1e-8``) and armature and
   friction ``>= 0``, the plant is the one whose base parameters are closest to the
   drawn ``beta`` in the Mahalanobis distance ``d = ||L^-1 (K pi - beta)||`` (sigmas
   of the identification, correlations included), with a pull of weight
   ``PULL = 1e-3`` (relative) towards ``pi0`` that picks the unseen directions: a
   second-order cone and semidefinite program (cvxpy, Clarabel), ~40 ms for a
   7-joint arm, solved once per draw and only for draws that need it.

Why this and not the alternatives (measured on the README's Panda identification,
``consistent``, 64 base parameters, 100 draws):

* **The Frobenius projection** of each ``J_i`` (what this module did before) moves the
  draw in full-parameter space without regard to what the data pinned down: it changed
  well-identified base parameters by a median 14 of their standard deviations (max 15).
  The covariance metric moves the draw along the directions the data leave loose: a
  median 1.4 sigma for the largest single base parameter, a Mahalanobis distance of 2.9
  for a draw whose own distance from ``beta_hat`` is ``|z| ~ 8``.  Draws that stay
  draws keep what the data say, including what a controller tuned to the prior does
  not survive: the identified Panda's link 2 is light about the axis joints 1 and 3
  share at the demo path's start, and PD, PD + gravity and adaptive control diverge at
  1 kHz on the identified arm itself and on most draws (5 of 10 PD runs with the
  Frobenius projection, whose rounder bodies hid it; 10 of 10 now).  The runs say why
  (the sampled loop, :mod:`.diverged`), and a shorter ``--dt`` holds them.
* **Rejection** (redraw until physical) would sample the Gaussian truncated to the
  physical set, the posterior under a flat prior on physical arms.  But a ``consistent``
  fit sits on the ``J_i >= 0`` faces of most links (all seven for the Panda), so
  nearly every Gaussian draw leaves the set: 0 of 100 Panda draws had a physical arm
  with exactly their base parameters, even using the non-identifiable directions.
  Rejection would not end.
* **The consistent bootstrap's refits** are physical by construction, but a study of
  ``runs`` plants would need as many refits (70 of the Panda log took 2.3 min here), or repeat
  a few; their spread is used instead, as ``C`` (above).

A projected draw has other base parameters than the Gaussian gave it; the study's
report says how many draws were projected (``study["plants"]["projected"]``: any, for
a ``J_i``, for a drive coefficient) and by how much (``shift_sigma_*``: the largest
change of one base parameter in its standard deviations; ``distance_*``: the
Mahalanobis distance ``d``; median and max over the projected draws).

The plant is the prior's Pinocchio model with body ``i``'s inertia set from
``pi`` (the ten parameters are Pinocchio's dynamic parameters in the URDF link frame),
the armature and the viscous and Coulomb friction from ``pi`` when identified, the
prior's otherwise.  An identified constant ``offset`` per joint is a bias of the
torque measurement, not a force on the arm: the plant has none.  Identified Stribeck,
sigmoid or asymmetric friction terms are refused (the plant's engine has no such law).
The hand-chosen variations of :class:`Distributions` (payload, link scale, added
friction) do not apply; the start offset and the torque noise do.

Everything a worker needs (``L``, ``L^-1``, ``K``, ``K^+``, ``pi_hat``) is computed once
on the client and travels as tuples of floats, so the draws are the same wherever
they run (the cone program is solved alike on every worker; its answer is checked
physical and its distance recomputed in NumPy).
"""

from __future__ import annotations

import dataclasses
import functools
import os
from dataclasses import dataclass

import numpy as np

from ..._support.errors import ModelError

__all__ = ["IdentifiedPlants", "load_identified", "plant_source"]


#: weight of the pull towards ``pi0`` in the projection (relative to ``max(1, |pi_hat|)``): moving
#: the full parameters by their whole norm costs a thousandth of a sigma of base parameters
PULL = 1e-3
#: a projected draw whose Mahalanobis distance to its Gaussian base parameters is below this many
#: sigmas counts as not moved (the cone solver's accuracy is ~1e-6 of the objective)
UNMOVED = 1e-4


def _tuple(a) -> tuple:
    a = np.asarray(a, dtype=np.float64)
    return tuple(_tuple(x) for x in a) if a.ndim > 1 else tuple(float(x) for x in a)


def _factor(cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(L, W)``: ``L L^T = cov`` (Cholesky, or ``V sqrt(max(w, 0))`` if cov is only
    semidefinite) and the whitening ``W`` with ``|W x|`` the Mahalanobis norm: ``L^-1``, or
    ``diag(max(w, 1e-12 max(w))^-1/2) V^T`` (a direction without variance costs 1e6 sigmas per
    unit of the largest standard deviation)."""
    try:
        L = np.linalg.cholesky(cov)
        return L, np.linalg.inv(L)
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(0.5 * (cov + cov.T))
        floor = 1e-12 * max(float(w.max()), 1e-300)
        return V * np.sqrt(np.clip(w, 0.0, None))[None, :], (V / np.sqrt(np.maximum(w, floor))[None, :]).T


@dataclass(frozen=True)
class IdentifiedPlants:
    """The identified distribution of plants (module docstring); build it with :func:`load_identified`.

    Attributes
    ----------
    prior : tuple
        :func:`manipdyn.check.scale.model_text` of the identification's prior (kinematics).
    source : str
        The base model's file name, for reports.
    method : str
        The identification method.
    parameters : tuple (p,)
        ``pi_hat``.
    factor : tuple (r, r)
        ``L`` with ``L L^T = C``.
    pinv_K : tuple (p, r)
        ``K^+``.
    armature, friction : bool
        Whether ``pi`` holds armature and friction entries.
    correlated : bool
        False when the file had standard deviations only (C diagonal).
    K : tuple (r, p)
        The base-parameter map ``beta = K pi``.
    whiten : tuple (r, r)
        ``W`` with ``|W (beta' - beta)|`` the Mahalanobis distance (``L^-1``).
    nonnegative : tuple (p - 10 n,) of bool
        Which extra entries (armature, friction) must be >= 0 (offsets need not).
    covariance : str
        Where ``C`` comes from: ``"fit"``, ``"bootstrap (N refits)"``, or ``"fit (...)"`` saying why
        the file's bootstrap was not used.
    friction_columns : tuple
        ``(viscous, coulomb)``: the entries of ``pi`` holding each joint's coefficient (``()``:
        not identified, the prior's).
    """

    prior: tuple
    source: str
    method: str
    parameters: tuple
    factor: tuple
    pinv_K: tuple
    armature: bool
    friction: bool
    correlated: bool
    K: tuple = ()
    whiten: tuple = ()
    nonnegative: tuple = ()
    covariance: str = "fit"
    friction_columns: tuple = ((), ())

    def __hash__(self) -> int:
        # the draws are cached per (plants, seed, run): hashing ~20,000 floats took 1.4 ms, once is enough
        h = self.__dict__.get("_hash")
        if h is None:
            h = hash(tuple(getattr(self, f.name) for f in dataclasses.fields(self)))
            object.__setattr__(self, "_hash", h)
        return h

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state.pop("_hash", None)        # strings hash differently in another process
        return state

    @property
    def n(self) -> int:
        from ...check.scale import arm_from_text

        return arm_from_text(*self.prior).n

    def draw_base(self, seed: int, run: int) -> tuple[np.ndarray, np.ndarray]:
        """``(z, pi0)`` of run ``run`` before the projection: the standard normal draw (r,) and
        ``pi_hat + K^+ L z`` (p,), whose base parameters are ``beta_hat + L z``."""
        L = np.array(self.factor)
        rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(int(run), 1)))
        z = rng.standard_normal(L.shape[1])
        return z, np.array(self.parameters) + np.array(self.pinv_K) @ (L @ z)

    def draw_parameters(self, seed: int, run: int) -> tuple[np.ndarray, bool]:
        """Full parameters ``pi`` (p,) of run ``run`` of the study seeded ``seed`` (physical:
        module docstring), and whether the projection moved their base parameters."""
        d = _draw(self, int(seed), int(run))
        return d["pi"].copy(), d["moved"]

    def draw_details(self, seed: int, run: int) -> dict:
        """Run ``run``'s draw: ``{"pi", "moved", "inertia", "drive", "distance", "shift_sigma"}``
        (the plant's parameters; whether it was projected; whether ``pi0`` had a ``J_i`` below the
        margin, a drive coefficient below 0; the Mahalanobis distance of its base parameters from
        the drawn ones and the largest change of one base parameter, in its standard deviations)."""
        d = dict(_draw(self, int(seed), int(run)))
        d["pi"] = d["pi"].copy()
        return d

    def projected(self, seed: int, runs: int) -> dict:
        """How many of runs ``0..runs-1`` had their draw projected:
        ``{"any": k, "inertia": k_J, "drive": k_f, "shift_sigma_p50", "shift_sigma_max",
        "distance_p50", "distance_max"}`` (the counts of :meth:`draw_details`' flags; median
        and max over the projected draws of its ``shift_sigma`` and ``distance``)."""
        counts, shifts, dist = {"any": 0, "inertia": 0, "drive": 0}, [], []
        for k in range(int(runs)):
            d = _draw(self, int(seed), k)
            counts["any"] += d["moved"]
            counts["inertia"] += d["inertia"]
            counts["drive"] += d["drive"]
            if d["moved"]:
                shifts.append(d["shift_sigma"])
                dist.append(d["distance"])
        for key, v in (("shift_sigma", shifts), ("distance", dist)):
            counts[key + "_p50"] = float(np.median(v)) if v else 0.0
            counts[key + "_max"] = float(np.max(v)) if v else 0.0
        return counts

    def physical(self) -> bool:
        """Whether the identified full parameters themselves have every J_i >= 0 and armature and
        friction >= 0 (a ``wls`` identification often has not: then every draw is projected)."""
        return not any(_violations(self, np.array(self.parameters)))

    def plant(self, nominal, draw, seed: int):
        """The plant of run ``draw.run`` of the study seeded ``seed`` (module docstring).

        ``nominal`` is the study's arm (names the plant, gives the joint types); the
        plant's kinematics are the identification's prior's.
        """
        import pinocchio as pin

        from ...engines.pinocchio.engine import PinocchioEngine
        from ...check.scale import arm_from_text
        from .plant import Plant

        prior = arm_from_text(*self.prior)
        n = prior.n
        pi, moved = self.draw_parameters(seed, draw.run)
        model = prior.pinocchio.model.copy()
        for j in range(1, n + 1):
            model.inertias[j] = pin.Inertia.FromDynamicParameters(pi[10 * (j - 1):10 * j].copy())
        col = 10 * n
        if self.armature:
            model.armature = pi[col:col + n].copy()
            col += n
        if self.friction:
            friction = np.zeros((2, n)) if prior.friction is None else np.array(prior.friction, dtype=np.float64)
            for row, cols in enumerate(self.friction_columns):
                if cols:
                    friction[row] = pi[list(cols)]
        else:
            friction = None if prior.friction is None else np.array(prior.friction, dtype=np.float64)
        plant = Plant(nominal, PinocchioEngine(model, friction=friction, num_threads=1), draw)
        plant.parameters, plant.projected = pi, moved
        return plant

    def to_dict(self, seed: int, runs: int) -> dict:
        """What a study's report says about its plants."""
        return {"source": "identified", "file": self.source, "method": self.method,
                "n_base": len(self.factor), "correlated": self.correlated, "covariance": self.covariance,
                "projected": self.projected(seed, runs), "runs": int(runs),
                "identified_parameters_physical": self.physical(),
                "projection": "to the physical arm (J_i >= 1e-8 I, armature and friction >= 0) nearest "
                              "the drawn base parameters in the metric of their covariance"}


def _violations(plants: IdentifiedPlants, pi: np.ndarray) -> tuple[bool, bool]:
    """``(inertia, drive)``: some ``J_i`` has an eigenvalue below ``EPS / 2``; some armature or
    friction coefficient (not an offset) is below 0."""
    from ...identification.estimation.fitting import link_min_eigenvalues
    from ...identification.estimation.sdp import EPS

    n = len(plants.parameters) - len(plants.nonnegative)
    n //= 10
    inertia = bool(np.any(link_min_eigenvalues(pi, n) < 0.5 * EPS))
    mask = np.asarray(plants.nonnegative, dtype=bool)
    drive = bool(mask.size and np.any(pi[10 * n:][mask] < 0))
    return inertia, drive


@functools.lru_cache(maxsize=4)
def _projector(plants: IdentifiedPlants):
    """The cone program of the module docstring's step 3, compiled once per process:
    ``(problem, x, target, start)`` with ``target = W beta`` and ``start = pi0`` its parameters."""
    from ..._support.deps import require
    from ...identification.estimation.sdp import EPS
    from ...model.parameters import PARAMETER_BASIS

    cp = require("cvxpy", "plants drawn from an identification")
    K, W = np.array(plants.K), np.array(plants.whiten)
    p = K.shape[1]
    n = (p - len(plants.nonnegative)) // 10
    x = cp.Variable(p)
    target, start = cp.Parameter(K.shape[0]), cp.Parameter(p)
    scale = max(1.0, float(np.linalg.norm(plants.parameters)))
    obj = cp.norm((W @ K) @ x - target) + PULL * cp.norm(x - start) / scale
    cons = [sum(x[10 * i + k] * PARAMETER_BASIS[k] for k in range(10)) - EPS * np.eye(4) >> 0
            for i in range(n)]
    idx = 10 * n + np.flatnonzero(np.asarray(plants.nonnegative, dtype=bool))
    if idx.size:
        cons.append(x[idx] >= 0)
    return cp.Problem(cp.Minimize(obj), cons), x, target, start


def _solve(problem, what: str) -> None:
    """Solve the projection with Clarabel, else SCS, never warm-started: a warm start from the
    previous draw's answer would make a draw depend on which draws its process solved before,
    and a study's plants on how its runs were chunked."""
    import warnings

    import cvxpy as cp

    errors = []
    for solver in ("CLARABEL", "SCS"):
        if solver not in cp.installed_solvers():
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)     # "solution may be inaccurate"
                problem.solve(solver=solver, warm_start=False)
        except cp.error.SolverError as exc:
            errors.append(f"{solver}: {exc}")
            continue
        if problem.status in ("optimal", "optimal_inaccurate"):
            return
        errors.append(f"{solver}: {problem.status}")
    raise ModelError(f"{what}: no solver succeeded ({'; '.join(errors) or 'neither Clarabel nor SCS installed'})")


@functools.lru_cache(maxsize=4096)
def _draw(plants: IdentifiedPlants, seed: int, run: int) -> dict:
    """:meth:`IdentifiedPlants.draw_details` (cached per process: the report and the plant both ask)."""
    from ...identification.estimation.sdp import EPS, project_physical

    _, pi0 = plants.draw_base(seed, run)
    inertia, drive = _violations(plants, pi0)
    if not (inertia or drive):
        return {"pi": pi0, "moved": False, "inertia": False, "drive": False, "distance": 0.0,
                "shift_sigma": 0.0}
    K, W, L = np.array(plants.K), np.array(plants.whiten), np.array(plants.factor)
    beta = K @ pi0
    problem, x, target, start = _projector(plants)
    target.value, start.value = W @ beta, pi0
    _solve(problem, f"{plants.source}: the projection of run {run}'s draw")
    n = (len(pi0) - len(plants.nonnegative)) // 10
    pi = project_physical(np.asarray(x.value, dtype=np.float64), n, eps=EPS,
                          nonnegative=np.asarray(plants.nonnegative, dtype=bool))
    delta = K @ pi - beta
    distance = float(np.linalg.norm(W @ delta))
    std = np.sqrt(np.einsum("ij,ij->i", L, L))
    return {"pi": pi, "moved": distance > UNMOVED, "inertia": inertia, "drive": drive,
            "distance": distance, "shift_sigma": float(np.max(np.abs(delta) / np.maximum(std, 1e-300)))}


def plant_source(study) -> str:
    """One line naming where a study's plants come from (report header, figure title)."""
    p = study.plants
    if p is None:
        d = study.distributions
        if d.sized:
            from .sizing import sized_source

            return sized_source(study)
        varied = [f"links x 1 +- {d.link_scale:g}" if d.link_scale else "links as the model",
                  f"payload <= {d.payload_mass:g} kg" if d.payload_mass else "no payload"]
        if d.friction_viscous or d.friction_coulomb:     # say what is added, and only then
            varied.append(f"added friction: viscous <= {d.friction_viscous:g} N m s/rad, "
                          f"Coulomb <= {d.friction_coulomb:g} N m")
        else:
            varied.append("no added friction")
        return f"plants: hand-chosen distributions ({', '.join(varied)})"
    c = p.projected(study.seed, study.runs)
    cov = "" if p.covariance == "fit" else f", covariance of the {p.covariance}"
    return (f"plants: drawn from the identification {p.source} ({p.method}, {len(p.factor)} base "
            f"parameters{cov}); projected: {c['any']} of {study.runs} draws (J_i >= 0: {c['inertia']}, "
            f"friction/armature >= 0: {c['drive']}) to the nearest physical arm in the metric of the "
            f"covariance, moving a base parameter by up to {c['shift_sigma_p50']:.2g} sigma (median; "
            f"max {c['shift_sigma_max']:.2g}), Mahalanobis distance {c['distance_p50']:.2g} (median; "
            f"max {c['distance_max']:.2g})")


def load_identified(path) -> IdentifiedPlants:
    """Read a base model JSON file (``manipdyn identify --base-json``) as :class:`IdentifiedPlants`.

    Raises :class:`ModelError` naming the file: not a base model, no uncertainty in it
    (an ``ols`` identification), a prior that is not a DH model, or base parameters that
    do not match the prior's (the file was edited or written by another version).
    """
    from ...model.arm import Manipulator
    from ...identification.estimation.base import base_parameters
    from ...identification.results.basemodel import load_base_model
    from ...identification.estimation.fitting import nonnegative_extras
    from ...model.parameters import parameter_names
    from ...check.scale import model_text

    where = os.fspath(path)
    bm = load_base_model(where)
    arm = bm.arm
    if not isinstance(arm, Manipulator):
        raise ModelError(f"{where}: the prior is a URDF arm; --plants-from needs an identification of a DH "
                         "model (a bundled model or a .toml model file as identify's prior)")
    base = base_parameters(arm, armature=bm.armature, friction=bm.friction)
    expressions = [row.get("expression") for row in bm.data["base_parameters"]]
    if base.count != len(bm.beta) or base.expressions() != expressions:
        raise ModelError(f"{where}: key 'base_parameters': the {len(bm.beta)} expressions are not the "
                         f"{base.count} base parameters of its prior (an edited file?)")
    terms = getattr(bm.friction, "terms", ())
    if set(terms) - {"viscous", "coulomb", "offset"} or getattr(bm.friction, "side", "joint") != "joint":
        raise ModelError(f"{where}: key 'friction': the plants have viscous and Coulomb friction at the "
                         f"joints; this identification has the terms {list(terms)} on the "
                         f"{bm.friction.side} side")
    names = parameter_names(arm.n, bm.armature, bm.friction)
    nonneg = tuple(bool(v) for v in nonnegative_extras(names, arm.n))
    boot = bm.data.get("bootstrap") or {}
    source = "fit"
    if not isinstance(boot, dict):
        raise ModelError(f"{where}: key 'bootstrap': expected an object")
    failed = boot.get("failed") or []
    if not isinstance(failed, list):
        raise ModelError(f"{where}: key 'bootstrap.failed': expected a list of replicate numbers")
    kept = _count(boot.get("replicates"), where) - len(failed)
    if boot.get("covariance") is not None and kept <= len(bm.beta):
        # fewer refits than base parameters + 1: their covariance is singular, and draws from it
        # would leave most directions fixed; the fit's covariance is complete
        source = f"fit (the bootstrap's {kept} refits are too few for {len(bm.beta)} base parameters)"
    if boot.get("covariance") is not None and kept > len(bm.beta):
        try:
            cov, correlated = np.array(boot["covariance"], dtype=np.float64), True
        except (TypeError, ValueError):
            cov = np.zeros(0)
        if cov.shape != (len(bm.beta),) * 2:
            raise ModelError(f"{where}: key 'bootstrap.covariance': expected {len(bm.beta)} x {len(bm.beta)} "
                             f"numbers (a list of rows)")
        source = f"bootstrap ({kept} refits)"
    elif bm.covariance is not None:
        cov, correlated = bm.covariance, True
    elif np.all(np.isfinite(bm.std)):
        cov, correlated = np.diag(bm.std**2), False
    else:
        raise ModelError(f"{where}: the base parameters carry no standard deviation (method "
                         f"{bm.data.get('method')!r}); identify with --method wls or consistent")
    if not (np.all(np.isfinite(cov)) and np.allclose(cov, cov.T, rtol=1e-9, atol=0)
            and np.all(np.diag(cov) >= 0)):
        raise ModelError(f"{where}: key 'covariance': expected a symmetric matrix with a diagonal >= 0")
    spread = float(np.sqrt(np.max(np.diag(cov)))) if cov.size else 0.0
    scale = float(np.max(np.abs(bm.beta))) if np.size(bm.beta) else 0.0
    if not spread > 1e-12 * max(scale, 1e-300):
        # nothing to draw from: every plant would be the identified arm, and the metric of the
        # projection (the covariance's inverse) would be infinite (the solvers' scaling fails)
        raise ModelError(f"{where}: key 'covariance' ({source}): the largest standard deviation is {spread:.3g}, "
                         f"zero next to the base parameters (up to {scale:.3g}): there is no spread to draw "
                         "plants from; run the study on the identified model itself (identify -o OUT.toml, "
                         "then montecarlo OUT.toml)")
    L, W = _factor(cov)
    return IdentifiedPlants(prior=model_text(arm), source=os.path.basename(where),
                            method=str(bm.data.get("method")), parameters=_tuple(bm.parameters),
                            factor=_tuple(L), pinv_K=_tuple(np.linalg.pinv(base.K)),
                            armature=bool(bm.armature), friction=bool(bm.friction), correlated=correlated,
                            K=_tuple(base.K), whiten=_tuple(W), nonnegative=nonneg, covariance=source,
                            friction_columns=_friction_columns(names, arm.n))


def _count(value, where: str) -> int:
    if value is None:
        return 0
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 10**9:
        raise ModelError(f"{where}: key 'bootstrap.replicates': expected a count, got {value!r}")
    return value


def _friction_columns(names, n: int) -> tuple:
    """``(viscous, coulomb)``: the columns of ``pi`` holding each joint's coefficient, () if not identified."""
    return tuple(tuple(names.index(f"joint{j + 1}.{t}") for j in range(n)) if f"joint1.{t}" in names else ()
                 for t in ("fv", "fc"))
