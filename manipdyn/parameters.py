"""The arm's inertial parameter vector: the ``pi`` of ``tau = Y(q, qd, qdd) pi``.

Layout, shared by both engines' ``regressor`` methods, by
:class:`manipdyn.control.regressor.Regressor` and by
:mod:`manipdyn.identification`:

* ``10 n`` link parameters, link by link, each in Pinocchio's order
  (:data:`manipdyn.inertia.LINK_PARAMETERS`)
  ``[m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]``: mass (kg),
  first moments (kg m) and the inertia TENSOR (tensor sign, kg m^2) about the
  ORIGIN of the link's frame in the arm's URDF (:meth:`manipdyn.Arm.chain`).
  For a standard-DH arm that frame is DH frame i moved back by
  ``S_i = Trans_x(a_i) Rot_x(alpha_i)`` (:meth:`manipdyn.Manipulator.urdf_link_offsets`);
  for a modified-DH or URDF arm it is the link frame itself.
* with ``armature=True``: ``n`` reflected rotor inertias ``G^2 J_m``
  (kg m^2 or kg), regressor column ``qdd_j``;
* with ``friction=True``: ``n`` viscous coefficients (column ``qd_j``) then
  ``n`` Coulomb coefficients (column ``sign(qd_j)``).

All conversions between a link's pseudo-inertia J and its ten parameters go
through :func:`manipdyn.inertia.parameters_from_pseudo_inertia` and
:func:`manipdyn.inertia.pseudo_inertia_from_parameters`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .errors import ModelError
from .inertia import (LINK_PARAMETERS, LinkInertia, parameters_from_pseudo_inertia,
                      pseudo_inertia_from_parameters, transform_pseudo_inertia)
from .kinematics import transform_inverse

__all__ = ["parameter_names", "parameter_count", "arm_parameters", "extra_columns",
           "arm_with_parameters", "PARAMETER_BASIS"]

#: ``PARAMETER_BASIS[k]`` (4, 4) is the pseudo-inertia of the unit vector e_k of
#: the 10 parameters: J = sum_k p_k PARAMETER_BASIS[k] (the map is linear).
PARAMETER_BASIS = pseudo_inertia_from_parameters(np.eye(10))
PARAMETER_BASIS.setflags(write=False)


def parameter_count(n: int, armature: bool = False, friction: bool = False) -> int:
    """Length of the parameter vector: ``10 n (+ n armature) (+ 2 n friction)``."""
    return 10 * n + (n if armature else 0) + (2 * n if friction else 0)


def parameter_names(n: int, armature: bool = False, friction: bool = False) -> list[str]:
    """Names in vector order, e.g. ``"link3.mcx"``, ``"joint2.armature"``, ``"joint1.fv"``."""
    out = [f"link{i + 1}.{p}" for i in range(n) for p in LINK_PARAMETERS]
    if armature:
        out += [f"joint{i + 1}.armature" for i in range(n)]
    if friction:
        out += [f"joint{i + 1}.fv" for i in range(n)] + [f"joint{i + 1}.fc" for i in range(n)]
    return out


def arm_parameters(arm, armature: bool = False, friction: bool = False) -> np.ndarray:
    """The parameter vector ``pi`` of ``arm`` (see the module docstring), shape (p,).

    Link parameters come from the pseudo-inertias of :meth:`Arm.chain`'s bodies
    (URDF link frames); armature and friction (zeros when the arm has none)
    are appended when asked for.
    """
    joints, _ = arm.chain()
    parts = [parameters_from_pseudo_inertia(np.array([j.body.J for j in joints])).reshape(-1)]
    if armature:
        parts.append(np.asarray(arm.armature, dtype=np.float64))
    if friction:
        fr = np.zeros((2, arm.n)) if arm.friction is None else np.asarray(arm.friction, dtype=np.float64)
        parts += [fr[0], fr[1]]
    return np.concatenate(parts)


def extra_columns(qd: np.ndarray, qdd: np.ndarray, armature: bool, friction: bool) -> np.ndarray:
    """Regressor columns of armature and friction, (..., n, k) with k = n, 2n, 3n or 0.

    ``qd``, ``qdd`` are (..., n).  Armature: ``diag(qdd)``; friction:
    ``diag(qd)`` then ``diag(sign(qd))``.
    """
    blocks = []
    eye = np.eye(qd.shape[-1])
    if armature:
        blocks.append(qdd[..., :, None] * eye)
    if friction:
        blocks += [qd[..., :, None] * eye, np.sign(qd)[..., :, None] * eye]
    if not blocks:
        return np.zeros(qd.shape + (0,))
    return np.concatenate(blocks, axis=-1)


def arm_with_parameters(arm, pi, armature: bool = False, friction: bool = False,
                        name: str | None = None, strict: bool = False):
    """A copy of the DH arm ``arm`` whose links carry the parameters ``pi``.

    Parameters
    ----------
    arm : manipdyn.Manipulator
        Gives the kinematics, limits, gear ratios and everything not in ``pi``.
    pi : (p,)
        Parameter vector in the layout of this module (URDF link frames).
    armature, friction : bool
        Whether ``pi`` holds armature (set as ``motor_inertia = armature / G^2``
        with the prior's gear ratio G) and friction entries; when False the
        prior's values are kept.
    name : str, optional
        Name of the new arm (default: the prior's).
    strict : bool
        Passed to :class:`Manipulator` (a physically impossible link raises).

    Raises :class:`ModelError` if a link's mass is negative or a massless
    link has first moments (no file can hold that), naming the link.
    """
    from .arm import Manipulator

    if not isinstance(arm, Manipulator):
        raise ModelError(f"arm: writing identified parameters needs a DH arm (a Manipulator), "
                         f"got {type(arm).__name__} {arm.name!r}")
    n = arm.n
    pi = np.asarray(pi, dtype=np.float64)
    expect = parameter_count(n, armature, friction)
    if pi.shape != (expect,):
        raise ValueError(f"pi: expected shape ({expect},) for {n} joints "
                         f"(armature={armature}, friction={friction}), got {pi.shape}")
    J_urdf = pseudo_inertia_from_parameters(pi[:10 * n].reshape(n, 10))
    S = arm.urdf_link_offsets()
    S_inv = np.array([transform_inverse(s) for s in S])
    J_dh = transform_pseudo_inertia(J_urdf, S_inv)      # URDF link frame -> DH frame i
    col = 10 * n
    arm_vals = fv = fc = None
    if armature:
        arm_vals, col = pi[col:col + n], col + n
    if friction:
        fv, fc = pi[col:col + n], pi[col + n:col + 2 * n]
    links = []
    for i, l in enumerate(arm.links):
        label = f"link {i + 1}" + (f" ({l.name})" if l.name else "")
        if J_dh[i, 3, 3] < 0:
            raise ModelError(f"{label}: identified mass {J_dh[i, 3, 3]:.6g} kg is negative; "
                             "no model file can hold it (use the 'consistent' method)")
        J = 0.5 * (J_dh[i] + J_dh[i].T)
        if J[3, 3] == 0.0:
            J[:3, 3] = J[3, :3] = 0.0
        body = LinkInertia.from_pseudo_inertia(J, name=label)
        kw = dict(mass=body.mass, com=body.com, inertia=body.inertia)
        if armature:
            kw["motor_inertia"] = float(arm_vals[i]) / l.gear_ratio**2
        if friction:
            kw["friction_viscous"], kw["friction_coulomb"] = float(fv[i]), float(fc[i])
        links.append(dataclasses.replace(l, **kw))
    return Manipulator(links, convention=arm.convention, gravity=arm.gravity,
                       name=arm.name if name is None else name, strict=strict,
                       source=arm.source, sources=arm.sources, description=arm.description)
