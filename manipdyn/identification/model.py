"""The identified arm: a DH arm carrying a parameter vector.

Layer: application (identification).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..arm import Manipulator
from ..errors import ModelError
from ..inertia import LinkInertia, pseudo_inertia_from_parameters, transform_pseudo_inertia
from ..kinematics import transform_inverse
from ..parameters import parameter_count

__all__ = ["arm_with_parameters"]


def arm_with_parameters(arm, pi, armature: bool = False, friction: bool = False,
                        name: str | None = None, strict: bool = False, metadata=None):
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
    metadata : (source, sources, description), optional
        The new arm's citation (:func:`.provenance.model_metadata`); default: the prior's.

    Raises :class:`ModelError` if a link's mass is negative (no file can hold
    that), naming the link.  A link whose identified mass is exactly 0 has no
    centre of mass: its first moments are dropped.
    """
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
    S_inv = transform_inverse(S)                         # eq. 2.2, batched
    J_dh = transform_pseudo_inertia(J_urdf, S_inv)      # URDF link frame -> DH frame i
    col = 10 * n
    arm_vals = fv = fc = None
    if armature:
        arm_vals, col = pi[col:col + n], col + n
    law = None
    if friction is True:
        fv, fc = pi[col:col + n], pi[col + n:col + 2 * n]
    elif friction is not False and friction is not None:
        law = _friction_law(friction, pi[col:], n, arm.transmission)
    elif arm.friction is None and arm.friction_model is not None:
        law = arm.friction_model          # the prior's own law (not the links' kind), kept
    links = []
    for i, l in enumerate(arm.links):
        label = f"link {i + 1}" + (f" ({l.name})" if l.name else "")
        if J_dh[i, 3, 3] < 0:
            raise ModelError(f"{label}: identified mass {J_dh[i, 3, 3]:.6g} kg is negative; "
                             "no model file can hold it (use the 'consistent' method)")
        J = 0.5 * (J_dh[i] + J_dh[i].T)
        if J[3, 3] == 0.0:
            J[:3, 3] = J[3, :3] = 0.0
        kw = dict(body=LinkInertia.from_pseudo_inertia(J, name=label))
        if armature:
            kw["motor_inertia"] = float(arm_vals[i]) / l.gear_ratio**2
        if friction is True:
            kw["friction_viscous"], kw["friction_coulomb"] = float(fv[i]), float(fc[i])
        elif law is not None:
            kw["friction_viscous"], kw["friction_coulomb"] = 0.0, 0.0
        links.append(dataclasses.replace(l, **kw))
    source, sources, description = metadata or (arm.source, arm.sources, arm.description)
    return Manipulator(links, convention=arm.convention, gravity=arm.gravity,
                       name=arm.name if name is None else name, strict=strict,
                       source=source, sources=sources, description=description,
                       transmission=arm.transmission, friction=law)


def _friction_law(friction, values, n, transmission):
    """The :class:`manipdyn.Friction` whose regressor parameters are ``values``.

    Motor-side parameters are reflected (:mod:`manipdyn.friction`): viscous ``R_kk^2 Fv``,
    the other amplitudes ``|R_kk| x``; they are divided back here.
    """
    from ..friction import Friction, friction_spec

    spec = friction_spec(friction, n)
    values = np.asarray(values, dtype=np.float64)
    R = np.diag(transmission.R) if spec.side == "motor" else None
    kw, k = {}, 0
    blocks = {"viscous": ["viscous"], "coulomb": ["coulomb"], "asymmetric": ["coulomb_pos", "coulomb_neg"],
              "offset": ["offset"], "stribeck": ["stribeck_level"], "sigmoid": ["sigmoid_A"]}
    for t in spec.terms:
        for key in blocks[t]:
            x = values[k:k + n].copy()
            k += n
            if R is not None and t != "offset":
                x = x / (R**2 if t == "viscous" else np.abs(R))
            if key != "offset":
                x = np.maximum(x, 0.0) if key not in ("stribeck_level", "sigmoid_A") else x
            kw[key] = x
    if "stribeck" in spec.terms:
        kw["stribeck_velocity"] = spec.stribeck_velocity
    if "sigmoid" in spec.terms:
        kw["sigmoid_alpha"], kw["sigmoid_p3"] = spec.sigmoid_alpha, spec.sigmoid_p3
    return Friction(**kw, side=spec.side, smoothing=spec.smoothing, deadband=spec.deadband,
                    stribeck_exponent=spec.stribeck_exponent, n=n)
