"""Friction: the law, the columns a regressor asks for, and the joint at rest.

Layer 1 (model).  Three modules, by what they hold:

* :mod:`manipdyn.model.friction_law`: the law :class:`Friction` (its table of terms,
  viscous, Coulomb, asymmetric, offset, Stribeck, sigmoid; the joint or motor side;
  the default smoothing), its torque, derivative, regressor columns and parameters;
* this module: which terms a regressor gets (:class:`FrictionTerms`,
  :func:`friction_spec`), and an arm's law written in those columns
  (:func:`law_parameters`); it is also where the friction names are imported from;
* :mod:`manipdyn.model.friction_rest`: the joint at rest, where the law gives no
  fixed torque but a static band ``[-Fs, Fs]`` (:func:`rest_mask`, :class:`StaticFriction`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._support.errors import ModelError
from .friction_law import DEFAULT_SMOOTHING, FRICTION_TERMS, SIDES, Friction

__all__ = ["Friction", "FrictionTerms", "friction_spec", "law_parameters", "FRICTION_TERMS", "DEFAULT_SMOOTHING", "SIDES"]

@dataclass(frozen=True)
class FrictionTerms:
    """Which linear friction terms a regressor gets, without values.

    ``terms``: some of "viscous", "coulomb", "asymmetric", "offset" (Stribeck and
    sigmoid need their shape parameters: pass a :class:`Friction`); ``side``,
    ``smoothing`` and ``deadband`` as for :class:`Friction`.
    """

    terms: tuple = ("viscous", "coulomb")
    side: str = "joint"
    smoothing: float = DEFAULT_SMOOTHING
    deadband: float = 0.0

    def __post_init__(self):
        terms = (self.terms,) if isinstance(self.terms, str) else tuple(self.terms)
        bad = [t for t in terms if t not in ("viscous", "coulomb", "asymmetric", "offset")]
        if bad:
            raise ModelError(f"friction terms: unknown or shape-needing term(s) {bad}; FrictionTerms takes some of "
                             "viscous, coulomb, asymmetric, offset (Stribeck and sigmoid: pass a Friction)")
        if "coulomb" in terms and "asymmetric" in terms:
            raise ModelError("friction terms: 'coulomb' and 'asymmetric' describe the same torque; give one")
        object.__setattr__(self, "terms", terms)

    def as_friction(self, n: int, *, stribeck_velocity=None, sigmoid_alpha=None) -> Friction:
        """A :class:`Friction` with these terms, all parameters zero; given a ``stribeck_velocity``
        or a ``sigmoid_alpha`` (n,), also that term with those shapes (the sigmoid's shift 0)."""
        z = np.zeros(n)
        kw = {t: z for t in self.terms if t != "asymmetric"}
        kw.update({"coulomb_pos": z, "coulomb_neg": z} if "asymmetric" in self.terms else {})
        kw.update({} if stribeck_velocity is None else {"stribeck_level": z, "stribeck_velocity": stribeck_velocity})
        kw.update({} if sigmoid_alpha is None else {"sigmoid_A": z, "sigmoid_alpha": sigmoid_alpha, "sigmoid_p3": z})
        return Friction(**kw, side=self.side, smoothing=self.smoothing, deadband=self.deadband, n=n)


def friction_spec(friction, n: int) -> Friction | None:
    """What a regressor's ``friction=`` asks for, as a :class:`Friction` (its terms), or None.

    ``False``/``None``: none; ``True``: viscous and Coulomb, joint side, sharp
    sign (the meaning it always had); a :class:`Friction`: its terms and law; a
    :class:`FrictionTerms`, a term name or a list of term names: those terms
    (defaults of :class:`FrictionTerms`).
    """
    if friction is None or friction is False:
        return None
    if friction is True:
        return Friction(viscous=np.zeros(n), coulomb=np.zeros(n), smoothing=0.0)
    if isinstance(friction, Friction):
        if friction.n != n:
            raise ModelError(f"friction: the law is for {friction.n} actuators, the arm has {n} joints")
        return friction
    if isinstance(friction, FrictionTerms):
        return friction.as_friction(n)
    if isinstance(friction, str) or (isinstance(friction, (list, tuple, set, frozenset))
                                     and all(isinstance(t, str) for t in friction)):
        terms = (friction,) if isinstance(friction, str) else [t for t in FRICTION_TERMS if t in friction] + sorted(
            set(friction) - set(FRICTION_TERMS))
        return FrictionTerms(tuple(terms)).as_friction(n)
    raise ModelError(f"friction: expected a bool, a Friction, a FrictionTerms or term names, got {friction!r:.80}")


def law_parameters(model: Friction | None, spec: Friction, transmission=None, where: str = "arm") -> np.ndarray:
    """The parameters of the law ``model`` (an arm's; None: no friction) for the columns of ``spec``.

    ``spec.columns(qd, tr) @ law_parameters(model, spec, tr) == model.torque(qd, tr)`` when
    ``spec`` holds every term of ``model`` (terms it leaves out are not in the
    vector, as friction is not with ``friction=False``).  A law the columns cannot
    describe (another side, smoothing, deadband or shape; asymmetric levels for
    symmetric columns) is a ModelError naming the difference.
    """
    names = spec.parameter_names()
    if model is None:
        return np.zeros(len(names))
    values = {"viscous": [model.viscous], "coulomb": [model.coulomb_pos], "offset": [model.offset],
              "asymmetric": [model.coulomb_pos, model.coulomb_neg], "stribeck": [model.stribeck_level],
              "sigmoid": [model.sigmoid_A]}
    used = [t for t in spec.terms if any(x is not None and np.any(x) for x in values[t])]
    why = model.same_law(spec) if used else ""
    if not why and "coulomb" in used and model.asymmetric and not np.array_equal(model.coulomb_pos, model.coulomb_neg):
        why = "asymmetric Coulomb levels for symmetric 'coulomb' columns (ask for 'asymmetric')"
    if why:
        raise ModelError(f"{where}: the arm's friction law cannot be written in the asked-for friction columns: "
                         f"{why}; ask for friction=arm.friction_model (its own terms and law)")
    kw = {}
    for t in spec.terms:
        xs = [np.zeros(model.n) if x is None else x for x in values[t]]
        if t == "asymmetric":
            kw.update(coulomb_pos=xs[0], coulomb_neg=xs[1])
        elif t == "stribeck":
            kw.update(stribeck_level=xs[0], stribeck_velocity=spec.stribeck_velocity)
        elif t == "sigmoid":
            kw.update(sigmoid_A=xs[0], sigmoid_alpha=spec.sigmoid_alpha, sigmoid_p3=spec.sigmoid_p3)
        else:
            kw[t] = xs[0]
    law = Friction(**kw, side=spec.side, smoothing=spec.smoothing, deadband=spec.deadband,
                   stribeck_exponent=spec.stribeck_exponent, n=model.n)
    return law.parameters(transmission)
