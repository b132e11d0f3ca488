"""Plants drawn from an identification: the arms that the data still allow.

Layer 6 (control: montecarlo).

``manipdyn identify ... --base-json F.json`` (or ``-o F.json``) writes a base model
(:mod:`manipdyn.identification.basemodel`): the prior, the identified base parameters
``beta_hat`` with their covariance ``C`` (``wls`` and ``consistent``; a file with
standard deviations only is read as a diagonal ``C``), and the full parameters
``pi_hat`` with ``K pi_hat = beta_hat``.  :class:`IdentifiedPlants` turns it into the
plants of a Monte-Carlo study (``manipdyn montecarlo MODEL --plants-from F.json``):

1. **Draw.**  Run ``k`` of the study seeded ``s`` draws ``z ~ N(0, I_r)`` from
   ``default_rng(SeedSequence(s, spawn_key=(k, 1)))`` (a stream of its own: the
   run's start offset and torque noise keep theirs, ``spawn_key=(k,)``), and
   ``beta = beta_hat + L z`` with ``L L^T = C`` (Cholesky, or the symmetric square
   root when C is only semidefinite).
2. **To full parameters.**  ``pi = pi_hat + K^+ (beta - beta_hat)``: the smallest
   change (least squares) of the identified full parameters that gives the drawn
   base parameters.  For a ``wls`` identification ``pi_hat`` is the full vector
   closest to the prior, so ``pi`` is too.  What the data cannot see (the
   non-identifiable directions) stays at the identification's choice.
3. **Projection.**  Every link's pseudo-inertia ``J_i`` with an eigenvalue below
   ``EPS / 2`` has it raised to ``EPS = 1e-8`` (its nearest matrix with eigenvalues
   ``>= EPS`` in the Frobenius norm, :func:`manipdyn.identification.sdp.project_physical`),
   and armature and friction coefficients below 0 are set to 0.  A projected draw has
   slightly different base parameters than the Gaussian gave it; the study's report
   says how many draws were moved (``study["plants"]["projected"]``: any, by the J_i
   step, by the drive step).  A ``wls`` identification's ``pi_hat`` is the full vector
   closest to the prior with no sign constraint, and is often not physical itself
   (``identified_parameters_physical``): then every draw is projected.  A
   ``consistent`` identification's ``pi_hat`` is, and draws near it move less.

The plant is the prior's Pinocchio model with body ``i``'s inertia set from
``pi`` (the ten parameters are Pinocchio's dynamic parameters in the URDF link frame),
the armature and the friction from ``pi`` when identified, the prior's otherwise.  The
hand-chosen variations of :class:`Distributions` (payload, link scale, added friction)
do not apply; the start offset and the torque noise do.

Everything a worker needs (``L``, ``K^+``, ``pi_hat``) is computed once on the client
and travels as tuples of floats, so the draws are bit-identical wherever they run.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..._support.errors import ModelError

__all__ = ["IdentifiedPlants", "load_identified", "plant_source"]


def _tuple(a) -> tuple:
    a = np.asarray(a, dtype=np.float64)
    return tuple(_tuple(x) for x in a) if a.ndim > 1 else tuple(float(x) for x in a)


def _factor(cov: np.ndarray) -> np.ndarray:
    """``L`` with ``L L^T = cov``: Cholesky, or ``V sqrt(max(w, 0))`` if cov is only semidefinite."""
    try:
        return np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(0.5 * (cov + cov.T))
        return V * np.sqrt(np.clip(w, 0.0, None))[None, :]


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
        Whether ``pi`` holds armature and (viscous, Coulomb) friction entries.
    correlated : bool
        False when the file had standard deviations only (C diagonal).
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

    @property
    def n(self) -> int:
        from ...check.scale import arm_from_text

        return arm_from_text(*self.prior).n

    def draw_base(self, seed: int, run: int) -> tuple[np.ndarray, np.ndarray]:
        """``(z, pi)`` of run ``run`` before the projection: the standard normal draw (r,) and
        ``pi_hat + K^+ L z`` (p,), whose base parameters are ``beta_hat + L z``."""
        L = np.array(self.factor)
        rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(int(run), 1)))
        z = rng.standard_normal(L.shape[1])
        return z, np.array(self.parameters) + np.array(self.pinv_K) @ (L @ z)

    def draw_parameters(self, seed: int, run: int) -> tuple[np.ndarray, bool]:
        """Full parameters ``pi`` (p,) of run ``run`` of the study seeded ``seed``, after the
        projection, and whether the projection moved them."""
        from ...identification.sdp import EPS, project_physical

        pi = self.draw_base(seed, run)[1]
        out = project_physical(pi, self.n, eps=EPS)        # armature and friction: all >= 0
        return out, not np.array_equal(out, pi)

    def projected(self, seed: int, runs: int) -> dict:
        """How many of runs ``0..runs-1`` had their draw moved by the projection:
        ``{"any": k, "inertia": k_J, "drive": k_f, "shift_sigma_p50": x, "shift_sigma_max": y}``
        (some J_i raised; some armature or friction coefficient raised to 0; the largest change
        of a base parameter by the projection, in its standard deviations, median and max
        over the moved draws)."""
        n, counts, shifts = self.n, {"any": 0, "inertia": 0, "drive": 0}, []
        Lf = np.array(self.factor)
        std = np.sqrt(np.einsum("ij,ij->i", Lf, Lf))
        K = np.linalg.pinv(np.array(self.pinv_K))         # K^+^+ = K
        for k in range(int(runs)):
            raw = self.draw_base(seed, k)[1]
            out, moved = self.draw_parameters(seed, k)
            counts["any"] += moved
            counts["inertia"] += not np.array_equal(out[:10 * n], raw[:10 * n])
            counts["drive"] += not np.array_equal(out[10 * n:], raw[10 * n:])
            if moved:
                shifts.append(float(np.max(np.abs(K @ (out - raw)) / np.maximum(std, 1e-300))))
        counts["shift_sigma_p50"] = float(np.median(shifts)) if shifts else 0.0
        counts["shift_sigma_max"] = float(np.max(shifts)) if shifts else 0.0
        return counts

    def physical(self) -> bool:
        """Whether the identified full parameters themselves have every J_i >= 0 and armature and
        friction >= 0 (a ``wls`` identification often has not: then every draw is projected)."""
        from ...identification.sdp import EPS, project_physical

        pi = np.array(self.parameters)
        return bool(np.array_equal(project_physical(pi, self.n, eps=EPS), pi))

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
            friction = np.vstack([pi[col:col + n], pi[col + n:col + 2 * n]])
        else:
            friction = None if prior.friction is None else np.array(prior.friction, dtype=np.float64)
        plant = Plant(nominal, PinocchioEngine(model, friction=friction, num_threads=1), draw)
        plant.parameters, plant.projected = pi, moved
        return plant

    def to_dict(self, seed: int, runs: int) -> dict:
        """What a study's report says about its plants."""
        return {"source": "identified", "file": self.source, "method": self.method,
                "n_base": len(self.factor), "correlated": self.correlated,
                "projected": self.projected(seed, runs), "runs": int(runs),
                "identified_parameters_physical": self.physical(),
                "projection": "J_i eigenvalues below 5e-9 raised to 1e-8; armature and friction below 0 set to 0"}


def plant_source(study) -> str:
    """One line naming where a study's plants come from (report header, figure title)."""
    p = study.plants
    if p is None:
        d = study.distributions
        return (f"plants: hand-chosen distributions (links x 1 +- {d.link_scale:g}, payload <= "
                f"{d.payload_mass:g} kg, added friction)")
    c = p.projected(study.seed, study.runs)
    return (f"plants: drawn from the identification {p.source} ({p.method}, {len(p.factor)} base "
            f"parameters); projected: {c['any']} of {study.runs} draws (J_i >= 0: {c['inertia']}, "
            f"friction/armature >= 0: {c['drive']}), moving a base parameter by up to "
            f"{c['shift_sigma_p50']:.2g} sigma (median; max {c['shift_sigma_max']:.2g})")


def load_identified(path) -> IdentifiedPlants:
    """Read a base model JSON file (``manipdyn identify --base-json``) as :class:`IdentifiedPlants`.

    Raises :class:`ModelError` naming the file: not a base model, no uncertainty in it
    (an ``ols`` identification), a prior that is not a DH model, or base parameters that
    do not match the prior's (the file was edited or written by another version).
    """
    from ...model.arm import Manipulator
    from ...identification.base import base_parameters
    from ...identification.basemodel import load_base_model
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
    if bm.covariance is not None:
        cov, correlated = bm.covariance, True
    elif np.all(np.isfinite(bm.std)):
        cov, correlated = np.diag(bm.std**2), False
    else:
        raise ModelError(f"{where}: the base parameters carry no standard deviation (method "
                         f"{bm.data.get('method')!r}); identify with --method wls or consistent")
    if not (np.all(np.isfinite(cov)) and np.allclose(cov, cov.T, rtol=1e-9, atol=0)
            and np.all(np.diag(cov) >= 0)):
        raise ModelError(f"{where}: key 'covariance': expected a symmetric matrix with a diagonal >= 0")
    return IdentifiedPlants(prior=model_text(arm), source=os.path.basename(where),
                            method=str(bm.data.get("method")), parameters=_tuple(bm.parameters),
                            factor=_tuple(_factor(cov)), pinv_K=_tuple(np.linalg.pinv(base.K)),
                            armature=bm.armature, friction=bm.friction, correlated=correlated)
