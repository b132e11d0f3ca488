"""The friction law per actuator, joint or motor side, and its regressor columns: :class:`Friction`.

Layer 1 (model).  Friction acts outside the Lagrangian:
``tau = D qdd + h + g + tau_f(qd)``.  A :class:`Friction` holds one law per
actuator, a sum of terms, each linear in its parameters:

=============  ==============================================================  ==========================
term           torque of actuator k at velocity v                              parameters (n each)
=============  ==============================================================  ==========================
viscous        ``Fv v``                                                        ``viscous``
coulomb        ``Fc sigma(v)``                                                 ``coulomb``
asymmetric     ``Fc+ sigma(v)`` for v > 0, ``Fc- sigma(v)`` for v < 0          ``coulomb_pos, coulomb_neg``
offset         ``c`` (constant, always per JOINT)                              ``offset``
stribeck       ``(Fs - Fc) exp(-|v / vs|^delta) sigma(v)``                     ``stribeck_level``
sigmoid        ``A / (1 + exp(-alpha (v + p3))) - A / (1 + exp(-alpha p3))``   ``sigmoid_A``
=============  ==============================================================  ==========================

``sigma(v)`` is the sign, smoothed: ``tanh(v / smoothing)``, or ``sign(v)`` when
``smoothing == 0``; and 0 where ``|v| <= deadband``.  The sigmoid is the
friction model of Gaz, Cognetti, Oliva, Robuffo Giordano and De Luca, "Dynamic
identification of the Franka Emika Panda robot with retrieval of feasible
parameters using penalty-based optimization", IEEE RA-L 4(4), 2019 (it is
neither smoothed nor dead-banded).  Stribeck and sigmoid are nonlinear in
their shape parameters (``stribeck_velocity``, ``stribeck_exponent``;
``sigmoid_alpha``, ``sigmoid_p3``) and linear in their amplitudes, which are
the parameters here.

Side.  ``side="joint"``: ``v = qd`` and the torque is the joint torque.
``side="motor"``: the law acts on the motor velocities ``v = qd_m = R qd``
(rad/s at the motor) and reaches the joints as ``R^T tau_f,m``
(:class:`manipdyn.model.drive.Transmission`); its coefficients are in motor units
(N m s/rad and N m at the motor), ``smoothing`` and ``deadband`` in motor
velocity units.  The offset is a joint torque on either side.

Regressor parameters of a motor-side law are REFLECTED to the joints, so that a
diagonal transmission gives the joint-side numbers: motor k's viscous
parameter is ``R_kk^2 Fv_k`` (column ``R^T e_k (R qd)_k / R_kk^2``), every other
amplitude ``|R_kk| x`` (column ``R^T e_k f_k(qd_m) / |R_kk|``).  With ``R_kk < 0``
the motor's positive direction is the joint's negative one, so a motor-side
``coulomb_pos`` then reflects to the joint's negative-velocity level.

Default smoothing.  :data:`DEFAULT_SMOOTHING` = 0.01 rad/s.  A sharp sign turns
the dither of a joint at rest (a differentiated encoder signal: a 17-bit encoder
behind a 100:1 gear sampled at 1 kHz steps by 5e-4 rad/s; filtered velocities at
rest wander by about 1e-3 rad/s) into full +-Fc torque jumps, which breaks fits
on real logs.  With v_s = 0.01 rad/s that dither stays in tanh's linear zone
(``|sigma| < 0.1``), while at the speeds an identification trajectory runs (above
0.05 rad/s, 5 v_s) ``tanh`` differs from the sign by under 1e-4 (at 0.1 rad/s by
4e-9).  The links' friction (:class:`manipdyn.DHLink`) keeps the sharp sign.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._support import limits
from .._support.errors import ModelError, StateError

__all__ = ["Friction", "FRICTION_TERMS", "DEFAULT_SMOOTHING", "SIDES"]

#: the terms of a friction law, in parameter-vector order
FRICTION_TERMS = ("viscous", "coulomb", "asymmetric", "offset", "stribeck", "sigmoid")
#: where a law acts
SIDES = ("joint", "motor")
#: default ``smoothing`` v_s of the sign, rad/s (m/s): see the module docstring
DEFAULT_SMOOTHING = 0.01

#: parameter names per term (one per actuator each; "offset" is per joint)
_NAMES = {"viscous": ("fv",), "coulomb": ("fc",), "asymmetric": ("fc_pos", "fc_neg"), "offset": ("offset",),
          "stribeck": ("stribeck",), "sigmoid": ("sigmoid_A",)}
_SIGN_TERMS = ("coulomb", "asymmetric", "stribeck")


def _array(value, n, where, field, nonnegative=False, positive=False):
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError, RecursionError):
        raise ModelError(f"{where}: '{field}' must be a list of numbers, got {value!r:.80}") from None
    if a.ndim == 0 and n is not None:
        a = np.full(n, float(a))
    if a.ndim != 1 or a.size == 0 or (n is not None and a.shape != (n,)):
        raise ModelError(f"{where}: '{field}' must have shape ({n if n is not None else 'n'},), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ModelError(f"{where}: '{field}' must be finite, got {a.tolist()}")
    limits.check_magnitude(a, where, field)
    if nonnegative and np.any(a < 0):
        raise ModelError(f"{where}: '{field}' must be >= 0, got {a.tolist()}")
    if positive and np.any(a <= 0):
        raise ModelError(f"{where}: '{field}' must be > 0, got {a.tolist()}")
    a.setflags(write=False)
    return a


def _logistic(x):
    """``1 / (1 + exp(-x))`` without overflow for large ``|x|``."""
    return np.exp(-np.logaddexp(0.0, -x))


def _scalar(value, where, field, positive=False, least=0.0):
    if isinstance(value, bool):
        raise ModelError(f"{where}: '{field}' must be a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ModelError(f"{where}: '{field}' must be a number, got {value!r:.60}") from None
    if not np.isfinite(v) or v < 0 or (positive and v == 0) or 0 < v < least:     # least: 0 or at least that
        raise ModelError(f"{where}: '{field}' must be a finite number {'> 0' if positive else '>= 0'}{least and f' (0, or at least {least:g}: manipdyn.limits.MIN_SMOOTHING)' or ''}, got {v!r}")
    limits.check_magnitude(v, where, field)
    return v


@dataclass(frozen=True, eq=False, init=False)
class Friction:
    """A friction law per actuator (module docstring), immutable and validated.

    Parameters
    ----------
    viscous : (n,), optional
        ``Fv >= 0``, N m s/rad (N s/m) on the law's side.
    coulomb : (n,), optional
        Symmetric Coulomb level ``Fc >= 0``, N m (N).
    coulomb_pos, coulomb_neg : (n,), optional
        Asymmetric levels for v > 0 and v < 0 (both >= 0, both given; not with ``coulomb``).
    offset : (n,), optional
        Constant torque per JOINT (N m), on either side.
    smoothing : float
        ``v_s >= 0`` of ``tanh(v / v_s)``; 0 is the sharp sign (default :data:`DEFAULT_SMOOTHING`).
    deadband : float
        ``|v| <= deadband`` gives no Coulomb (or Stribeck) torque; default 0.
    side : "joint" | "motor"
    stribeck_level, stribeck_velocity : (n,), optional
        ``Fs - Fc`` (N m) and ``vs > 0``; ``stribeck_exponent`` (delta > 0, default 2).
    sigmoid_A, sigmoid_alpha, sigmoid_p3 : (n,), optional
        Gaz et al.'s amplitude (N m), steepness (> 0, s/rad) and shift (rad/s).
    n : int, optional
        Number of actuators, needed only when no array is given (a law with no terms).

    A term is present when its arrays are given (zeros included): :attr:`terms`.
    """

    n: int
    side: str
    smoothing: float
    deadband: float
    viscous: np.ndarray | None
    coulomb_pos: np.ndarray | None
    coulomb_neg: np.ndarray | None
    asymmetric: bool
    offset: np.ndarray | None
    stribeck_level: np.ndarray | None
    stribeck_velocity: np.ndarray | None
    stribeck_exponent: float
    sigmoid_A: np.ndarray | None
    sigmoid_alpha: np.ndarray | None
    sigmoid_p3: np.ndarray | None

    def __init__(self, viscous=None, coulomb=None, *, coulomb_pos=None, coulomb_neg=None, offset=None,
                 smoothing=DEFAULT_SMOOTHING, deadband=0.0, side="joint", stribeck_level=None,
                 stribeck_velocity=None, stribeck_exponent=2.0, sigmoid_A=None, sigmoid_alpha=None,
                 sigmoid_p3=None, n=None):
        w = "friction"
        set_ = object.__setattr__
        if not isinstance(side, str) or side not in SIDES:
            raise ModelError(f"{w}: 'side' must be 'joint' or 'motor', got {side!r}")
        given = {k: v for k, v in dict(viscous=viscous, coulomb=coulomb, coulomb_pos=coulomb_pos,
                                       coulomb_neg=coulomb_neg, offset=offset, stribeck_level=stribeck_level,
                                       stribeck_velocity=stribeck_velocity, sigmoid_A=sigmoid_A,
                                       sigmoid_alpha=sigmoid_alpha, sigmoid_p3=sigmoid_p3).items() if v is not None}
        for k, v in given.items():
            if n is None and np.ndim(v) == 1:
                n = len(v)
        if n is None:
            raise ModelError(f"{w}: give at least one per-actuator array (or n)")
        if coulomb is not None and (coulomb_pos is not None or coulomb_neg is not None):
            raise ModelError(f"{w}: give 'coulomb' (symmetric) or 'coulomb_pos' and 'coulomb_neg', not both")
        if (coulomb_pos is None) != (coulomb_neg is None):
            raise ModelError(f"{w}: 'coulomb_pos' and 'coulomb_neg' go together (levels for v > 0 and v < 0)")
        for a, b in (("stribeck_level", "stribeck_velocity"), ("sigmoid_A", "sigmoid_alpha"),
                     ("sigmoid_A", "sigmoid_p3")):
            if (a in given) != (b in given):
                raise ModelError(f"{w}: '{a}' and '{b}' go together")
        arr = {k: _array(v, n, w, k, nonnegative=k in ("viscous", "coulomb", "coulomb_pos", "coulomb_neg"),
                         positive=k in ("stribeck_velocity", "sigmoid_alpha")) for k, v in given.items()}
        set_(self, "n", int(n))
        set_(self, "side", side)
        set_(self, "smoothing", _scalar(smoothing, w, "smoothing", least=limits.MIN_SMOOTHING))
        set_(self, "deadband", _scalar(deadband, w, "deadband"))
        set_(self, "stribeck_exponent", _scalar(stribeck_exponent, w, "stribeck_exponent", positive=True))
        set_(self, "viscous", arr.get("viscous"))
        set_(self, "asymmetric", coulomb_pos is not None)
        set_(self, "coulomb_pos", arr.get("coulomb", arr.get("coulomb_pos")))
        set_(self, "coulomb_neg", arr.get("coulomb", arr.get("coulomb_neg")))
        for k in ("offset", "stribeck_level", "stribeck_velocity", "sigmoid_A", "sigmoid_alpha", "sigmoid_p3"):
            set_(self, k, arr.get(k))

    # -- what the law holds ------------------------------------------------------------
    @property
    def coulomb(self) -> np.ndarray | None:
        """The symmetric Coulomb level (None for an asymmetric law or none)."""
        return None if self.asymmetric else self.coulomb_pos

    @property
    def terms(self) -> tuple:
        """The terms present, in :data:`FRICTION_TERMS` order."""
        have = {"viscous": self.viscous is not None, "coulomb": self.coulomb is not None,
                "asymmetric": self.asymmetric, "offset": self.offset is not None,
                "stribeck": self.stribeck_level is not None, "sigmoid": self.sigmoid_A is not None}
        return tuple(t for t in FRICTION_TERMS if have[t])

    def viscous_coulomb(self) -> np.ndarray | None:
        """``[viscous, coulomb]`` (2, n) for a law of the links' kind (joint side, sharp
        sign, no deadband, viscous and symmetric Coulomb only), else None."""
        if self.side != "joint" or self.smoothing or self.deadband or set(self.terms) - {"viscous", "coulomb"}:
            return None
        z = np.zeros(self.n)
        return np.array([z if self.viscous is None else self.viscous, z if self.coulomb is None else self.coulomb])

    def _check_terms(self, terms) -> tuple:
        if terms is None:
            return self.terms
        terms = (terms,) if isinstance(terms, str) else tuple(terms)
        bad = [t for t in terms if t not in FRICTION_TERMS]
        if bad:
            raise ModelError(f"friction: unknown term(s) {bad}; expected some of {', '.join(FRICTION_TERMS)}")
        for t, field in (("stribeck", "stribeck_velocity"), ("sigmoid", "sigmoid_alpha")):
            if t in terms and getattr(self, field) is None:
                raise ModelError(f"friction: the term {t!r} needs its shape ('{field}' ...), which this law has not")
        return tuple(t for t in FRICTION_TERMS if t in terms)

    # -- the law on one side ------------------------------------------------------------
    def _sign(self, v):
        s = np.tanh(v / self.smoothing) if self.smoothing else np.sign(v)
        return np.where(np.abs(v) <= self.deadband, 0.0, s) if self.deadband else s

    def _basis(self, term, v) -> list:
        """The functions of v (…, n) that multiply the term's parameters."""
        if term == "viscous":
            return [v]
        if term == "coulomb":
            return [self._sign(v)]
        if term == "asymmetric":
            s = self._sign(v)
            return [np.maximum(s, 0.0), np.minimum(s, 0.0)]
        if term == "stribeck":
            return [np.exp(-np.abs(v / self.stribeck_velocity) ** self.stribeck_exponent) * self._sign(v)]
        if term == "sigmoid":
            a, p3 = self.sigmoid_alpha, self.sigmoid_p3
            return [_logistic(a * (v + p3)) - _logistic(a * p3)]
        return [np.ones_like(v)]                                              # offset

    def _values(self, term) -> list:
        return {"viscous": [self.viscous], "coulomb": [self.coulomb], "asymmetric": [self.coulomb_pos, self.coulomb_neg],
                "offset": [self.offset], "stribeck": [self.stribeck_level], "sigmoid": [self.sigmoid_A]}[term]

    def _R(self, transmission):
        if self.side == "joint":
            return None
        if transmission is None:
            raise ModelError("friction: a motor-side law needs the transmission (qd_m = R qd)")
        if transmission.n != self.n:
            raise ModelError(f"friction: the transmission has {transmission.n} motors, the law {self.n}")
        return transmission.R

    def _velocities(self, qd, transmission):
        qd = np.asarray(qd, dtype=np.float64)
        if qd.ndim not in (1, 2) or qd.shape[-1] != self.n:
            raise StateError(f"qd: expected shape ({self.n},) or (N, {self.n}), got {qd.shape}")
        R = self._R(transmission)
        return qd, R, (qd if R is None else qd @ R.T)

    # -- public -----------------------------------------------------------------
    def torque(self, qd, transmission=None) -> np.ndarray:
        """Friction torque at the joints, (n,) or (N, n), N m (N), for joint velocities ``qd``.

        Motor side: ``R^T tau_f,m(R qd)``; ``transmission`` is needed there only.
        """
        qd, R, v = self._velocities(qd, transmission)
        tau = np.zeros_like(v)
        for t in self.terms:
            if t != "offset":
                for f, x in zip(self._basis(t, v), self._values(t)):
                    tau = tau + x * f
        if R is not None:
            tau = tau @ R
        return tau + self.offset if self.offset is not None else tau

    def derivative(self, qd, transmission=None) -> np.ndarray:
        """``d tau_f / d qd``, (n, n) or (N, n, n).

        Joint side it is diagonal; motor side ``R^T diag(f'(qd_m)) R``.  At a
        kink the value is a convention: the sharp sign's derivative is 0
        everywhere (also at v == 0), the deadband's is 0 inside it, and an
        asymmetric law's at v == 0 is the mean of its two sides.
        """
        qd, R, v = self._velocities(qd, transmission)
        d = np.zeros_like(v)
        if self.viscous is not None:
            d = d + self.viscous
        if self.smoothing and ({"coulomb", "asymmetric", "stribeck"} & set(self.terms)):
            ds = (1.0 - np.tanh(v / self.smoothing) ** 2) / self.smoothing
            if self.deadband:
                ds = np.where(np.abs(v) <= self.deadband, 0.0, ds)
            if self.asymmetric:
                lvl = np.where(v > 0, self.coulomb_pos, np.where(v < 0, self.coulomb_neg,
                                                                 0.5 * (self.coulomb_pos + self.coulomb_neg)))
                d = d + lvl * ds
            elif self.coulomb is not None:
                d = d + self.coulomb * ds
        else:
            ds = np.zeros_like(v)
        if self.stribeck_level is not None:
            vs, e = self.stribeck_velocity, self.stribeck_exponent
            x = np.abs(v / vs)
            ex = np.exp(-x ** e)
            with np.errstate(divide="ignore", invalid="ignore"):
                dex = np.where(v == 0, 0.0, -e * x ** (e - 1) * np.sign(v) / vs * ex)
            d = d + self.stribeck_level * (dex * self._sign(v) + ex * ds)
        if self.sigmoid_A is not None:
            s = _logistic(self.sigmoid_alpha * (v + self.sigmoid_p3))
            d = d + self.sigmoid_A * self.sigmoid_alpha * s * (1.0 - s)
        out = d[..., :, None] * np.eye(self.n)
        return out if R is None else R.T @ out @ R

    def columns(self, qd, transmission=None, terms=None) -> np.ndarray:
        """Regressor columns of the linear parameters: (n, p) or (N, n, p).

        ``columns(qd, tr, terms) @ parameters(tr, terms) == torque(qd, tr)`` when
        ``terms`` are all of :attr:`terms` (default).  Blocks of n columns in
        :data:`FRICTION_TERMS` order (asymmetric: the v > 0 block, then v < 0);
        motor side: reflected parameters (module docstring).
        """
        terms = self._check_terms(terms)
        qd, R, v = self._velocities(qd, transmission)
        eye = np.eye(self.n)
        blocks = []
        for t in terms:
            for f in self._basis(t, v):
                if R is None or t == "offset":
                    blocks.append(f[..., :, None] * eye)
                else:   # column k: R^T e_k f_k / c_k, c_k = R_kk^2 (viscous) or |R_kk|
                    c = np.diag(R) ** 2 if t == "viscous" else np.abs(np.diag(R))
                    blocks.append(R.T * (f / c)[..., None, :])
        if not blocks:
            return np.zeros(qd.shape + (0,))
        return np.concatenate(blocks, axis=-1)

    def parameters(self, transmission=None, terms=None) -> np.ndarray:
        """The linear parameters in regressor units (:meth:`columns`), (p,); absent terms give zeros."""
        terms = self._check_terms(terms)
        R = self._R(transmission)
        out = []
        for t in terms:
            for x in self._values(t):
                x = np.zeros(self.n) if x is None else x
                if R is not None and t != "offset":
                    x = x * (np.diag(R) ** 2 if t == "viscous" else np.abs(np.diag(R)))
                out.append(x)
        return np.concatenate(out) if out else np.zeros(0)

    def parameter_names(self, terms=None) -> list[str]:
        """E.g. ``"joint1.fv"``, ``"motor2.fc_pos"``, ``"joint3.offset"`` (block order of :meth:`columns`)."""
        terms = self._check_terms(terms)
        who = "joint" if self.side == "joint" else "motor"
        return [f"{'joint' if t == 'offset' else who}{i + 1}.{nm}"
                for t in terms for nm in _NAMES[t] for i in range(self.n)]

    def same_law(self, other: "Friction") -> str:
        """Why the columns of ``other`` do not describe this law ("" when they do)."""
        if self.side != other.side:
            return f"side {self.side!r} vs {other.side!r}"
        signs = set(other.terms) & set(_SIGN_TERMS)
        if signs and (self.smoothing, self.deadband) != (other.smoothing, other.deadband):
            return (f"smoothing/deadband {self.smoothing:g}/{self.deadband:g} vs "
                    f"{other.smoothing:g}/{other.deadband:g}")
        for t, have, fields in (("stribeck", self.stribeck_level is not None, ("stribeck_velocity", "stribeck_exponent")),
                                ("sigmoid", self.sigmoid_A is not None, ("sigmoid_alpha", "sigmoid_p3"))):
            if t in other.terms and have and not all(np.array_equal(getattr(self, f), getattr(other, f))
                                                     for f in fields):
                return f"{t} shape ({', '.join(fields)})"
        return ""

    def __eq__(self, other):
        if not isinstance(other, Friction):
            return NotImplemented
        for f in ("n", "side", "smoothing", "deadband", "asymmetric", "stribeck_exponent"):
            if getattr(self, f) != getattr(other, f):
                return False
        for f in ("viscous", "coulomb_pos", "coulomb_neg", "offset", "stribeck_level", "stribeck_velocity",
                  "sigmoid_A", "sigmoid_alpha", "sigmoid_p3"):
            a, b = getattr(self, f), getattr(other, f)
            if (a is None) != (b is None) or (a is not None and not np.array_equal(a, b)):
                return False
        return True

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return (f"Friction({', '.join(self.terms) or 'no terms'}; side={self.side!r}, n={self.n}, "
                f"smoothing={self.smoothing:g}, deadband={self.deadband:g})")
