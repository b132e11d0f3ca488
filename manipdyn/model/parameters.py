"""The arm's inertial parameter vector: the ``pi`` of ``tau = Y(q, qd, qdd) pi``.

Layer 1 (model): the parameters are a view of the model's link inertias.

Layout, shared by both engines' ``regressor`` methods, by
:class:`manipdyn.control.regressor.Regressor` and by
:mod:`manipdyn.identification`:

* ``10 n`` link parameters, link by link, each in Pinocchio's order
  (:data:`manipdyn.model.inertia.LINK_PARAMETERS`)
  ``[m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]``: mass (kg),
  first moments (kg m) and the inertia TENSOR (tensor sign, kg m^2) about the
  ORIGIN of the link's frame in the arm's URDF (:meth:`manipdyn.Arm.chain`).
  For a standard-DH arm that frame is DH frame i moved back by
  ``S_i = Trans_x(a_i) Rot_x(alpha_i)`` (:meth:`manipdyn.Manipulator.urdf_link_offsets`);
  for a modified-DH or URDF arm it is the link frame itself.
* with ``armature=True``: ``n`` reflected rotor inertias ``R_kk^2 J_m,k``, one per
  MOTOR k (kg m^2 or kg; ``G^2 J_m`` for a diagonal transmission), regressor column
  ``R^T e_k (R qdd)_k / R_kk^2`` (:class:`manipdyn.model.drive.Transmission`), which is
  ``qdd_k e_k`` when R is diagonal: the sum of the columns times the parameters is
  the rotor torque ``R^T diag(J_m) R qdd``;
* with ``friction=True``: ``n`` viscous coefficients (column ``qd_j``) then
  ``n`` Coulomb coefficients (column ``sign(qd_j)``): joint side, sharp sign.
  :func:`arm_parameters` refuses ``True`` by name for an arm whose law these columns
  cannot hold (a sigmoid, Stribeck or offset term, motor side, smoothing, asymmetric
  levels), where ``Y @ pi`` would silently miss the friction: ask for
  ``friction=arm.friction_model``, the law's own columns.
  ``friction`` may also name the terms: a :class:`manipdyn.model.drive.Friction` (its
  terms, side, smoothing and shapes), a :class:`manipdyn.model.drive.FrictionTerms` or
  term names ("viscous", "coulomb", "asymmetric", "offset"); blocks of n columns
  in :data:`manipdyn.model.friction_law.FRICTION_TERMS` order, motor-side parameters
  reflected to the joints (:mod:`manipdyn.model.friction`, :func:`manipdyn.model.friction.friction_spec`).

All conversions between a link's pseudo-inertia J and its ten parameters go
through :func:`manipdyn.model.inertia.parameters_from_pseudo_inertia` and
:func:`manipdyn.model.inertia.pseudo_inertia_from_parameters`.
"""

from __future__ import annotations

import numpy as np

from .._support.errors import ModelError
from .friction import friction_spec, law_parameters
from .inertia import LINK_PARAMETERS, parameters_from_pseudo_inertia, pseudo_inertia_from_parameters

__all__ = ["parameter_names", "parameter_count", "arm_parameters", "with_extra_columns", "PARAMETER_BASIS", "stacked_regressor"]

#: ``PARAMETER_BASIS[k]`` (4, 4) is the pseudo-inertia of the unit vector e_k of
#: the 10 parameters: J = sum_k p_k PARAMETER_BASIS[k] (the map is linear).
PARAMETER_BASIS = pseudo_inertia_from_parameters(np.eye(10))
PARAMETER_BASIS.setflags(write=False)


def parameter_count(n: int, armature: bool = False, friction=False) -> int:
    """Length of the parameter vector: ``10 n (+ n armature) (+ 2 n friction=True)``."""
    spec = friction_spec(friction, n)
    return 10 * n + (n if armature else 0) + (0 if spec is None else len(spec.parameter_names()))


def parameter_names(n: int, armature: bool = False, friction=False) -> list[str]:
    """Names in vector order, e.g. ``"link3.mcx"``, ``"joint2.armature"``, ``"joint1.fv"``.

    ``jointk.armature`` is motor k's reflected rotor inertia ``R_kk^2 J_m,k``.
    """
    out = [f"link{i + 1}.{p}" for i in range(n) for p in LINK_PARAMETERS]
    if armature:
        out += [f"joint{i + 1}.armature" for i in range(n)]
    spec = friction_spec(friction, n)
    if spec is not None:
        out += spec.parameter_names()
    return out


def arm_parameters(arm, armature: bool = False, friction=False) -> np.ndarray:
    """The parameter vector ``pi`` of ``arm`` (see the module docstring), shape (p,).

    Link parameters come from the pseudo-inertias of :meth:`Arm.chain`'s bodies
    (URDF link frames); armature and friction (zeros when the arm has none)
    are appended when asked for.  Friction columns that cannot describe the
    arm's friction law (another side, smoothing, ...) are a ModelError
    (:func:`manipdyn.model.friction.law_parameters`).
    """
    joints, _ = arm.chain()
    parts = [parameters_from_pseudo_inertia(np.array([j.body.J for j in joints])).reshape(-1)]
    if armature:
        parts.append(np.asarray(arm.armature, dtype=np.float64))
    spec = friction_spec(friction, arm.n)
    if spec is not None:
        law = arm.friction_model
        if friction is True and law is not None:      # True is the whole law: no term may be left out
            left = [t for t in law.terms if t not in spec.terms and t != "asymmetric" and _has_term(law, t)]
            if left:
                raise ModelError(f"friction: {arm.name or 'the arm'}'s friction law has {' and '.join(left)} "
                                 "term(s) that friction=True's viscous and Coulomb columns cannot hold (Y @ pi "
                                 "would miss them); ask for friction=arm.friction_model (its own terms and law) "
                                 "in both arm.regressor and arm.parameters")
        parts.append(law_parameters(law, spec, arm.transmission, arm.name or "arm"))
    return np.concatenate(parts)


def _has_term(law, term: str) -> bool:
    """True when the friction law's ``term`` has a nonzero coefficient."""
    fields = {"viscous": ("viscous",), "coulomb": ("coulomb_pos", "coulomb_neg"), "offset": ("offset",),
              "stribeck": ("stribeck_level",), "sigmoid": ("sigmoid_A",)}.get(term, ())
    return any(getattr(law, f, None) is not None and np.any(getattr(law, f)) for f in fields) or not fields


def with_extra_columns(Y: np.ndarray, qd: np.ndarray, qdd: np.ndarray, armature: bool,
                       friction=False, transmission=None) -> np.ndarray:
    """The link regressor ``Y`` (..., n, 10n) with the armature and friction columns appended.

    ``qd``, ``qdd`` are (..., n).  Armature: ``diag(qdd)`` (n columns), or with a
    coupled ``transmission`` (R not diagonal) column k ``R^T e_k (R qdd)_k / R_kk^2``;
    friction: ``diag(qd)`` then ``diag(sign(qd))`` (2n) for ``True``, or the
    columns of a friction spec (module docstring).  ``Y`` itself when neither
    is asked for.
    """
    blocks = []
    eye = np.eye(qd.shape[-1])
    if armature:
        if transmission is None or transmission.is_diagonal:
            blocks.append(qdd[..., :, None] * eye)
        else:
            R = transmission.R
            blocks.append(R.T * ((qdd @ R.T) / np.diag(R) ** 2)[..., None, :])
    if friction is True:
        blocks += [qd[..., :, None] * eye, np.sign(qd)[..., :, None] * eye]
    elif friction is not False and friction is not None:
        spec = friction_spec(friction, qd.shape[-1])
        blocks.append(spec.columns(qd, transmission))
    return np.concatenate([Y] + blocks, axis=-1) if blocks else Y


def stacked_regressor(arm, samples: int = 200, seed: int = 0, armature=False, friction=False,
                      engine: str = "lagrange") -> np.ndarray:
    """The regressor over ``samples`` seeded random states, stacked: (samples n, p).

    The states (q uniform in the joint limits, qd in +-2, qdd in +-5) are those of base-parameter finding
    and of :func:`manipdyn.model.completion.complete_parameters` ("the model's states")."""
    rng = np.random.default_rng(seed)
    q = arm.random_state(rng, samples)
    qd = rng.uniform(-2.0, 2.0, q.shape)
    qdd = rng.uniform(-5.0, 5.0, q.shape)
    Y = getattr(arm, engine).regressor(q, qd, qdd, armature=armature, friction=friction)
    return Y.reshape(-1, Y.shape[-1])
