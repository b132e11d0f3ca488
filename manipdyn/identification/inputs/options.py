"""The options of an identification, checked and turned into what :func:`.fit` takes.

Layer 5 (identification).

:func:`manipdyn.identification.identify` and ``manipdyn identify`` take the same
options under the same names (``friction_terms`` is ``--friction-terms``).  This
module checks them and builds from them the friction spec (:func:`friction_option`),
the plausibility bounds (:func:`bounds_option`) and the prior-weight value
(:func:`prior_weight_option`); :func:`check_limits` refuses positions far outside a
model's joint limits.  A bad option raises :class:`OptionError`, a
:class:`~manipdyn.ModelError` whose message names the keyword argument
(``mass_bound: ...``) and whose :meth:`OptionError.cli_message` names the
command-line option (``--mass-bound: ...``).
"""

from __future__ import annotations

import math

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError

__all__ = ["OptionError", "brace_safe", "friction_option", "bounds_option", "prior_weight_option", "check_limits",
           "START_STRIBECK_VELOCITY", "START_SIGMOID_ALPHA", "SHAPED"]

#: where variable projection starts the shapes, at the joint (motor k: scaled by ``|R_kk|``)
START_STRIBECK_VELOCITY = 0.1   # rad/s
START_SIGMOID_ALPHA = 10.0      # s/rad
#: the friction terms with a nonlinear shape (fitted by :mod:`.varpro`)
SHAPED = ("stribeck", "sigmoid")


class OptionError(ModelError):
    """A bad option: ``str()`` names keyword arguments, :meth:`cli_message` command-line options.

    ``template`` holds ``{}`` where an option's name goes; ``options`` are the keyword names.
    """

    def __init__(self, template: str, *options: str):
        self.template, self.options = template, tuple(options)
        super().__init__(template.format(*options))

    def cli_message(self) -> str:
        """The message with ``--name-with-dashes`` for every option named."""
        return self.template.format(*("--" + o.replace("_", "-") for o in self.options))


def brace_safe(text: str) -> str:
    """``text`` safe inside a template (its braces doubled)."""
    return text.replace("{", "{{").replace("}", "}}")


def _given(pairs):
    return [name for name, value in pairs if value is not None]


def bounds_option(arm, method: str, mass_bound=None, com_bound=None, total_mass_bound=None,
                  no_bounds: bool = False):
    """The :class:`~manipdyn.identification.estimation.bounds.Bounds` of ``consistent`` from the options, or None.

    ``mass_bound`` (fraction), ``com_bound`` (m), ``total_mass_bound`` (fraction) default to
    :meth:`Bounds.plausible`'s; ``no_bounds`` drops them.  Only ``consistent`` takes bounds.
    """
    from ..estimation.sdp import PLAUSIBLE_COM, PLAUSIBLE_MASS, PLAUSIBLE_TOTAL, Bounds

    given = _given((("mass_bound", mass_bound), ("com_bound", com_bound), ("total_mass_bound", total_mass_bound)))
    if method != "consistent":
        if given or no_bounds:
            raise OptionError("{}: only with {} consistent", (given or ["no_bounds"])[0], "method")
        return None
    if no_bounds:
        if given:
            raise OptionError("{}: not with {}", given[0], "no_bounds")
        return None
    for opt, v, top in (("mass_bound", mass_bound, 1e6), ("com_bound", com_bound, limits.MAX_LENGTH)):
        if v is not None and not (0 <= v <= top):
            raise OptionError("{}: expected a number in [0, " + f"{top:g}], got {v}", opt)
    if total_mass_bound is not None and not 0 <= total_mass_bound < 1:
        raise OptionError("{}: expected a fraction in [0, 1), got " + f"{total_mass_bound}", "total_mass_bound")
    return Bounds.plausible(
        arm, mass=PLAUSIBLE_MASS if mass_bound is None else mass_bound,
        com=PLAUSIBLE_COM if com_bound is None else com_bound,
        total=PLAUSIBLE_TOTAL if total_mass_bound is None else total_mass_bound)


def friction_option(arm, friction: bool = False, friction_terms=None, friction_side=None,
                    smoothing=None, stribeck_velocity=None, sigmoid_alpha=None):
    """What :func:`.fit` takes as ``friction=`` from the options.

    ``friction``: viscous and sharp Coulomb (True; on the motors with ``friction_side="motor"``).
    ``friction_terms``: names separated by commas (or a sequence) of
    :data:`manipdyn.model.friction_law.FRICTION_TERMS`, on ``friction_side`` ("joint" or "motor"; None:
    the joint side here, :mod:`.choices` chooses it from the log first), Coulomb smoothed as ``tanh(v / smoothing)`` (rad/s, default
    :data:`manipdyn.model.friction_law.DEFAULT_SMOOTHING`); with a Stribeck or sigmoid term, a
    :class:`manipdyn.Friction` holding the shapes' starting values (``stribeck_velocity``
    rad/s, ``sigmoid_alpha`` s/rad, on the law's side).
    """
    from ...model.friction import DEFAULT_SMOOTHING, FRICTION_TERMS, FrictionTerms

    if friction_side not in (None, "joint", "motor"):
        raise OptionError("{}: expected 'joint' or 'motor', got " + brace_safe(repr(friction_side)), "friction_side")
    shape_opts = _given((("stribeck_velocity", stribeck_velocity), ("sigmoid_alpha", sigmoid_alpha)))
    if friction_terms is None:
        if smoothing is not None or shape_opts:
            raise OptionError("{}: only with {}", (shape_opts or ["smoothing"])[0], "friction_terms")
        if friction_side is not None and not friction:
            raise OptionError("{}: only with {} or {}", "friction_side", "friction", "friction_terms")
        if friction and friction_side == "motor":     # viscous + sharp Coulomb at the motors
            return FrictionTerms(("viscous", "coulomb"), side="motor", smoothing=0.0)
        return bool(friction)
    if friction:
        raise OptionError("{}: give either {} (viscous + sharp Coulomb) or {}", "friction_terms", "friction",
                          "friction_terms")
    v = DEFAULT_SMOOTHING if smoothing is None else smoothing
    if not 0 <= v < float("inf"):
        raise OptionError("{}: expected a finite velocity >= 0, got " + f"{v}", "smoothing")
    if 0 < v < limits.MIN_SMOOTHING:
        raise OptionError("{}: expected 0 (a sharp sign) or a velocity of at least " + f"{limits.MIN_SMOOTHING:g} rad/s "
                          f"(below it tanh(v / smoothing) is the sign, and 1 / smoothing overflows), got {v!r}",
                          "smoothing")
    if isinstance(friction_terms, str):
        terms = tuple(t.strip() for t in friction_terms.split(","))
    else:
        terms = tuple(str(t).strip() for t in friction_terms)
    bad = [t for t in terms if t not in FRICTION_TERMS]
    if not terms or bad:
        raise OptionError("{}: unknown term(s) " + brace_safe(f"{bad or [friction_terms]}") + "; expected some of "
                          f"{', '.join(FRICTION_TERMS)}, separated by commas", "friction_terms")
    twice = sorted({t for t in terms if terms.count(t) > 1})
    if twice:
        raise OptionError("{}: " + brace_safe(", ".join(twice)) + " given twice", "friction_terms")
    shaped = [t for t in terms if t in SHAPED]
    for opt, term in (("stribeck_velocity", "stribeck"), ("sigmoid_alpha", "sigmoid")):
        if opt in shape_opts and term not in shaped:
            raise OptionError("{}: only with a " + term + " term in {}", opt, "friction_terms")
    friction_side = friction_side or "joint"
    linear = FrictionTerms(tuple(t for t in terms if t not in SHAPED), side=friction_side, smoothing=v)
    if not shaped:
        return linear
    for opt, x in (("stribeck_velocity", stribeck_velocity), ("sigmoid_alpha", sigmoid_alpha)):
        if x is not None and not 0 < x < float("inf"):
            raise OptionError("{}: expected a finite number > 0, got " + f"{x}", opt)
    scale = np.ones(arm.n)
    if friction_side == "motor":
        scale = np.abs(np.diag(np.asarray(arm.transmission.R, dtype=np.float64)))
    shapes = {}
    if "stribeck" in shaped:
        shapes["stribeck_velocity"] = (np.full(arm.n, stribeck_velocity) if stribeck_velocity is not None
                                       else START_STRIBECK_VELOCITY * scale)
    if "sigmoid" in shaped:
        shapes["sigmoid_alpha"] = (np.full(arm.n, sigmoid_alpha) if sigmoid_alpha is not None
                                   else START_SIGMOID_ALPHA / scale)
    return linear.as_friction(arm.n, **shapes)


def prior_weight_option(value, method: str):
    """``prior_weight`` as a float >= 0 or ``"auto"`` (a number given as text is read); None (the default) is
    ``"auto"`` for the consistent method and 0 for the others."""
    if value is None:
        return "auto" if method == "consistent" else 0.0
    if isinstance(value, str) and value != "auto":
        try:
            value = float(value)
        except ValueError:
            raise OptionError("{}: expected a number >= 0 or 'auto', got " + brace_safe(repr(value)), "prior_weight") from None
    if value != "auto":
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < math.inf:
            raise OptionError("{}: expected a finite number >= 0, got " + f"{value}", "prior_weight")
        if value > limits.MAX_PRIOR_WEIGHT:
            raise OptionError("{}: expected a number in [0, " + f"{limits.MAX_PRIOR_WEIGHT:g}] "
                              "(manipdyn.limits.MAX_PRIOR_WEIGHT) or 'auto', got " + f"{value:g}", "prior_weight")
        value = float(value)
    if value and method != "consistent":
        raise OptionError("{}: only with {} consistent", "prior_weight", "method")
    return value


def check_limits(data, arm, deg: bool) -> None:
    """Refuse positions far outside the model's joint limits (degrees read as radians, another
    model's zero): over 5 % of the samples beyond a limit by more than 10 % of the joint's range."""
    lim = np.asarray(arm.qlim, dtype=np.float64)
    span = lim[:, 1] - lim[:, 0]
    out = (data.q < lim[:, 0] - 0.1 * span) | (data.q > lim[:, 1] + 0.1 * span)
    frac = out.mean(axis=0)
    bad = np.flatnonzero(frac > 0.05)
    if bad.size:
        j = int(bad[0])
        hint = "" if deg else "; positions in degrees? add --deg"
        where = f"{data.source}: " if getattr(data, "source", None) else ""
        raise ModelError(f"{where}q{j + 1}: {100 * frac[j]:.0f} % of the samples lie outside the model's joint "
                         f"limits [{lim[j, 0]:g}, {lim[j, 1]:g}] rad (by more than 10 % of the range){hint}")
