"""Drives: motors, gears and couplings between the motors and the joints.

Layer 1 (model).  CONVENTIONS.md, section "Drives":

* motor positions ``q_m = R q + offset_m`` (rad at the motor, m for a linear motor);
* joint torques ``tau = R^T tau_m`` (power balances: ``tau_m . qd_m = tau . qd``);
* ``R`` (n, n) is diagonal with the gear ratios (signs allowed: a motor may turn
  the other way) plus coupling entries, e.g. a wrist where motor 6 also drives
  joint 5: ``R[5, 4]`` (0-based) is the coupling value;
* rotor inertia in joint space is ``R^T diag(Jm) R``; on the diagonal
  ``sum_k R_ki^2 Jm_k``, which is ``G_i^2 Jm_i`` only when R is diagonal;
* a current ``i`` (A) gives ``tau_m = k_t i`` (``k_t`` in N m/A at each motor).

:class:`Transmission` is that map; :class:`~manipdyn.model.friction.Friction` (the
friction law per actuator, joint or motor side) lives in :mod:`manipdyn.model.friction`
and is exported here too.  :func:`arm_drive` builds an arm's drive from its
links (used by :class:`manipdyn.Manipulator` and :class:`manipdyn.URDFArm`).

Every map takes one vector ``(n,)`` or a batch ``(N, n)`` and returns the same shape.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._support import limits
from .._support.errors import ModelError, StateError
from .friction import DEFAULT_SMOOTHING, FRICTION_TERMS, Friction, FrictionTerms, friction_spec, law_parameters

__all__ = ["Transmission", "Friction", "FrictionTerms", "friction_spec", "DEFAULT_SMOOTHING",
           "FRICTION_TERMS", "law_parameters", "arm_drive", "MAX_CONDITION"]

#: largest condition number of ``R`` accepted: joint positions are ``R^-1 (q_m - offset)``,
#: and solving loses about log10(cond R) of float64's 16 digits
MAX_CONDITION = 1e10


def _vector(value, n: int | None, where: str, field: str) -> np.ndarray:
    """``value`` as a read-only finite float (n,) array, or a ModelError naming ``field``."""
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError, RecursionError):
        raise ModelError(f"{where}: '{field}' must be a list of numbers, got {value!r:.80}") from None
    if arr.ndim != 1 or (n is not None and arr.shape != (n,)):
        want = f"({n},)" if n is not None else "(n,)"
        raise ModelError(f"{where}: '{field}' must have shape {want}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{where}: '{field}' must be finite, got {arr.tolist()}")
    limits.check_magnitude(arr, where, field)
    arr.setflags(write=False)
    return arr


def _batch(x, n: int, name: str) -> np.ndarray:
    """``x`` as a float (n,) or (N, n) array, or a StateError naming ``name``."""
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise StateError(f"{name}: expected numbers of shape ({n},) or (N, {n}), got {x!r:.60}") from None
    if a.ndim not in (1, 2) or a.shape[-1] != n:
        raise StateError(f"{name}: expected shape ({n},) or (N, {n}), got {a.shape}")
    return a


@dataclass(frozen=True, eq=False, init=False)
class Transmission:
    """The linear map between motors and joints, ``q_m = R q + offset_m``, ``tau = R^T tau_m``.

    Parameters
    ----------
    R : (n, n)
        Motor rows, joint columns.  Invertible (condition number at most
        :data:`MAX_CONDITION`), with a non-zero diagonal: motor k drives joint k
        through its gear ratio ``R[k, k]`` (sign allowed), and the off-diagonal
        entries are couplings.
    motor_offset : (n,), optional
        ``offset_m``, rad (m) at the motor; zeros by default.
    torque_constant : (n,), optional
        ``k_t``, N m/A (N/A) at each motor; needed by :meth:`motor_torques_from_current` only.

    All arrays are read-only.
    """

    R: np.ndarray
    motor_offset: np.ndarray
    torque_constant: np.ndarray | None

    def __init__(self, R, motor_offset=None, torque_constant=None):
        where = "transmission"
        try:
            R = np.array(R, dtype=np.float64)
        except (TypeError, ValueError, OverflowError, RecursionError):
            raise ModelError(f"{where}: 'R' must be a square matrix of numbers, got {R!r:.80}") from None
        if R.ndim != 2 or R.shape[0] != R.shape[1] or R.shape[0] == 0:
            raise ModelError(f"{where}: 'R' must be a square (n, n) matrix, got shape {R.shape}")
        if not np.all(np.isfinite(R)):
            raise ModelError(f"{where}: 'R' must be finite, got {R.tolist()}")
        limits.check_magnitude(R, where, "R")
        n = R.shape[0]
        zero = np.flatnonzero(np.diag(R) == 0)
        if zero.size:
            raise ModelError(f"{where}: the matrix R has a zero diagonal entry R[{zero[0] + 1}, {zero[0] + 1}] "
                             "(1-based): motor k must drive joint k through its gear ratio R[k, k] != 0")
        cond = np.linalg.cond(R)
        if not cond <= MAX_CONDITION:
            raise ModelError(f"{where}: the matrix R (motors x joints) is singular or nearly so "
                             f"(condition number {cond:.3g} > {MAX_CONDITION:g}): joint positions "
                             f"q = R^-1 (q_m - offset) are undefined; R = {R.tolist()}")
        R.setflags(write=False)
        set_ = object.__setattr__
        set_(self, "R", R)
        off = np.zeros(n) if motor_offset is None else _vector(motor_offset, n, where, "motor_offset")
        off.setflags(write=False)
        set_(self, "motor_offset", off)
        kt = None if torque_constant is None else _vector(torque_constant, n, where, "torque_constant")
        if kt is not None and not np.all((kt > 0) & (kt <= limits.MAX_TORQUE_CONSTANT)):
            # N m/A of a real motor: some 0.01 to 10; 0 makes currents say nothing, a negative one
            # flips a motor (the gear ratio's sign says that), 1e59 overflows the fit's squares
            raise ModelError(f"{where}: 'torque_constant' must be > 0 and at most {limits.MAX_TORQUE_CONSTANT:g} N m/A "
                             f"(manipdyn.limits.MAX_TORQUE_CONSTANT; a motor's direction is the gear ratio's sign), "
                             f"got {kt.tolist()}")
        set_(self, "torque_constant", kt)
        Rinv = np.linalg.inv(R)
        Rinv.setflags(write=False)
        set_(self, "_Rinv", Rinv)
        set_(self, "_diagonal", bool(np.count_nonzero(R - np.diag(np.diag(R))) == 0))

    @classmethod
    def from_gear_ratios(cls, gear_ratio, coupling=(), motor_offset=None, torque_constant=None) -> "Transmission":
        """``R = diag(gear_ratio)`` plus coupling entries.

        ``coupling`` is a list of ``[motor_row, joint_column, value]``, 1-based
        as in model files, each an off-diagonal entry of R (e.g. ``[[6, 5, 32.0]]``:
        motor 6 also turns with joint 5).
        """
        G = _vector(gear_ratio, None, "transmission", "gear_ratio")
        n = G.size
        R = np.diag(G)
        seen = set()
        try:
            entries = list(coupling)
        except TypeError:
            raise ModelError(f"transmission: 'coupling' must be a list of [motor_row, joint_column, value], "
                             f"got {coupling!r:.80}") from None
        for c, entry in enumerate(entries):
            where = f"transmission: coupling[{c}]"
            if not isinstance(entry, (list, tuple)) or len(entry) != 3:
                raise ModelError(f"{where}: expected [motor_row, joint_column, value], got {entry!r:.80}")
            row, col, value = entry
            for name, k in (("motor_row", row), ("joint_column", col)):
                if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= n:
                    raise ModelError(f"{where}: {name} must be an integer 1..{n} (1-based), got {k!r}")
            if row == col:
                raise ModelError(f"{where}: [{row}, {col}] is on the diagonal, which holds the gear ratio; "
                                 "couplings are off-diagonal entries")
            if (row, col) in seen:
                raise ModelError(f"{where}: the entry [{row}, {col}] is given twice")
            seen.add((row, col))
            v = _vector([value], 1, where, "value")[0] if not isinstance(value, bool) else None
            if v is None:
                raise ModelError(f"{where}: value must be a number, got {value!r}")
            R[row - 1, col - 1] = v
        return cls(R, motor_offset=motor_offset, torque_constant=torque_constant)

    # -- properties -----------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of motors (= joints)."""
        return self.R.shape[0]

    @property
    def is_diagonal(self) -> bool:
        """True when no motor is coupled to another joint (R diagonal)."""
        return self._diagonal

    @property
    def gear_ratios(self) -> np.ndarray:
        """The diagonal of R, (n,)."""
        return np.diag(self.R).copy()

    @property
    def coupling(self) -> list:
        """The off-diagonal entries of R as ``[[motor_row, joint_column, value], ...]`` (1-based)."""
        rows, cols = np.nonzero(self.R - np.diag(np.diag(self.R)))
        return [[int(r) + 1, int(c) + 1, float(self.R[r, c])] for r, c in zip(rows, cols)]

    # -- maps -------------------------------------------------------------------------
    def motor_positions(self, q) -> np.ndarray:
        """``q_m = R q + offset_m``: (n,) or (N, n), rad (m) at the motors."""
        return _batch(q, self.n, "q") @ self.R.T + self.motor_offset

    def joint_positions(self, q_m) -> np.ndarray:
        """``q = R^-1 (q_m - offset_m)``: (n,) or (N, n), rad or m."""
        return (_batch(q_m, self.n, "q_m") - self.motor_offset) @ self._Rinv.T

    def motor_velocities(self, qd) -> np.ndarray:
        """``qd_m = R qd``: (n,) or (N, n)."""
        return _batch(qd, self.n, "qd") @ self.R.T

    def joint_velocities(self, qd_m) -> np.ndarray:
        """``qd = R^-1 qd_m``: (n,) or (N, n)."""
        return _batch(qd_m, self.n, "qd_m") @ self._Rinv.T

    def motor_accelerations(self, qdd) -> np.ndarray:
        """``qdd_m = R qdd``: (n,) or (N, n)."""
        return _batch(qdd, self.n, "qdd") @ self.R.T

    def joint_accelerations(self, qdd_m) -> np.ndarray:
        """``qdd = R^-1 qdd_m``: (n,) or (N, n)."""
        return _batch(qdd_m, self.n, "qdd_m") @ self._Rinv.T

    def joint_torques(self, tau_m) -> np.ndarray:
        """``tau = R^T tau_m``: (n,) or (N, n), N m (N) at the joints."""
        return _batch(tau_m, self.n, "tau_m") @ self.R

    def motor_torques(self, tau) -> np.ndarray:
        """``tau_m = R^-T tau``: (n,) or (N, n), N m (N) at the motors."""
        return _batch(tau, self.n, "tau") @ self._Rinv

    def motor_torques_from_current(self, current) -> np.ndarray:
        """``tau_m = k_t i``: (n,) or (N, n), N m at the motors, for currents in A."""
        if self.torque_constant is None:
            raise ModelError("transmission: no torque_constant (k_t, N m/A per motor) is given, so currents "
                             "cannot be turned into torques; give Transmission(..., torque_constant=[...]) or "
                             "the model file's [transmission] torque_constant")
        return _batch(current, self.n, "current") * self.torque_constant

    def rotor_inertia(self, Jm) -> np.ndarray:
        """Rotor inertia in joint space, ``R^T diag(Jm) R``: (n, n), kg m^2 (kg).

        ``Jm`` (n,) holds each motor's rotor inertia on its own shaft.
        """
        Jm = _vector(Jm, self.n, "transmission", "Jm")
        S = self.R.T @ (Jm[:, None] * self.R)
        return 0.5 * (S + S.T)          # exactly symmetric (the two triangles round differently)

    # -- comparison ----------------------------------------------------------------
    def __eq__(self, other):
        if not isinstance(other, Transmission):
            return NotImplemented
        kt_same = (self.torque_constant is None and other.torque_constant is None) or (
            self.torque_constant is not None and other.torque_constant is not None
            and np.array_equal(self.torque_constant, other.torque_constant))
        return (np.array_equal(self.R, other.R) and np.array_equal(self.motor_offset, other.motor_offset)
                and kt_same)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        s = f"Transmission(gear_ratios={self.gear_ratios.tolist()}"
        if not self.is_diagonal:
            s += f", coupling={self.coupling}"
        return s + ")"


def arm_drive(n: int, gear_ratio, motor_inertia, viscous, coulomb, transmission=None, friction=None,
              where: str = "arm"):
    """An arm's drive from its links: ``(transmission, friction_model, rotor_inertia, armature, friction)``.

    ``gear_ratio``, ``motor_inertia``, ``viscous``, ``coulomb`` are the links'
    per-joint values (n,).  Defaults: the diagonal transmission of the gear
    ratios, and the links' joint-side viscous and Coulomb friction with a sharp
    sign (None when all are zero).  A given ``transmission`` must have the
    links' gear ratios on its diagonal; a given ``friction`` replaces the links'
    friction, which must then be zero.  Returns the (n, n) rotor inertia
    ``R^T diag(Jm) R``, the (n,) armature ``R_kk^2 Jm_k`` (Pinocchio's diagonal
    case, also the regressor's armature parameters) and the (2, n) viscous and
    Coulomb array of a friction law of the links' kind (None otherwise).
    """
    G = np.asarray(gear_ratio, dtype=np.float64)
    Jm = np.asarray(motor_inertia, dtype=np.float64)
    links_friction = np.array([viscous, coulomb], dtype=np.float64)
    if transmission is None:
        transmission = Transmission(np.diag(G))
    elif not isinstance(transmission, Transmission):
        raise ModelError(f"{where}: 'transmission' must be a manipdyn.model.drive.Transmission, "
                         f"got {type(transmission).__name__}")
    if transmission.n != n:
        raise ModelError(f"{where}: 'transmission' has {transmission.n} motors, the arm {n} joints")
    bad = np.flatnonzero(np.diag(transmission.R) != G)
    if bad.size:
        k = int(bad[0])
        raise ModelError(f"{where}: the transmission's R[{k + 1}, {k + 1}] = {float(transmission.R[k, k])!r} but joint "
                         f"{k + 1}'s gear_ratio is {float(G[k])!r}; the diagonal of R is the links' gear ratios "
                         "(use Transmission.from_gear_ratios([link.gear_ratio ...], coupling=...))")
    if friction is None:
        if np.any(links_friction):
            friction = Friction(viscous=links_friction[0], coulomb=links_friction[1], smoothing=0.0)
    else:
        if not isinstance(friction, Friction):
            raise ModelError(f"{where}: 'friction' must be a manipdyn.model.drive.Friction, got {type(friction).__name__}")
        if friction.n != n:
            raise ModelError(f"{where}: 'friction' is for {friction.n} actuators, the arm has {n} joints")
        if np.any(links_friction):
            raise ModelError(f"{where}: both 'friction' and the links' friction_viscous/friction_coulomb are "
                             "given; give one friction description (put the links' values into the Friction)")
    rotor = transmission.rotor_inertia(Jm)
    rotor.setflags(write=False)
    armature = np.diag(transmission.R) ** 2 * Jm
    armature.setflags(write=False)
    legacy = None if friction is None else friction.viscous_coulomb()
    if legacy is not None:
        legacy.setflags(write=False)
    return transmission, friction, rotor, armature, legacy
