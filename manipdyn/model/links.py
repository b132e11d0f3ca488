"""The links of a serial arm: a DH link, or a joint of a generic (URDF) chain.

Layer 1 (model): each link holds exactly one :class:`~manipdyn.LinkInertia`
(its ``body``) beside its kinematic parameters; both are validated when built
and immutable after.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._support import limits
from .._support.errors import ModelError
from .inertia import LinkInertia, as_vector3
from .kinematics import JOINT_TYPES, dh_modified, dh_standard

__all__ = ["physical_note", "DHLink", "ChainJoint", "as_dh_links", "check_name", "as_gravity", "dh_links_equal"]


def _scalar(value, where: str, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ModelError(f"{where}: field '{name}' must be a finite number, got {value!r:.60}") from None
    if not math.isfinite(v):
        raise ModelError(f"{where}: field '{name}' must be finite, got {v}")
    limits.check_magnitude(v, where, name)
    return v


def as_gravity(value, where="gravity") -> np.ndarray:
    """Gravity as a read-only (3,) float array (m/s^2); the chapter's [gx, gy, gz, 0] accepted."""
    try:
        g = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError, RecursionError):
        raise ModelError(f"{where}: expected 3 numbers (gx, gy, gz) in m/s^2, got {value!r}") from None
    if g.shape == (4,) and g[3] == 0.0:
        g = g[:3]  # the chapter's homogeneous form [gx, gy, gz, 0]
    if g.shape != (3,):
        raise ModelError(f"{where}: expected 3 numbers (gx, gy, gz) in m/s^2, got shape {g.shape}")
    if not np.all(np.isfinite(g)):
        raise ModelError(f"{where}: must be finite, got {g.tolist()}")
    limits.check_range(g, where, "gravity", "acceleration")
    g = g.copy()
    g.setflags(write=False)
    return g


def check_name(value, where: str, field: str = "name") -> str:
    """``value`` as a name: a string without NUL or other characters XML 1.0 cannot hold.

    Names go into URDF files and messages; a NUL would fail deep inside the
    XML writer with a message that names nothing.
    """
    if not isinstance(value, str):
        raise ModelError(f"{where}: field '{field}' must be a string, got {type(value).__name__}")
    if len(value) > limits.MAX_NAME_LENGTH:
        raise limits.over_limit(where, f"the length of field '{field}' ({value[:20]!r}...)", len(value),
                                "MAX_NAME_LENGTH")
    for k, ch in enumerate(value):
        o = ord(ch)
        if (o < 0x20 and ch not in "\t\n\r") or 0xD800 <= o <= 0xDFFF or o in (0xFFFE, 0xFFFF):
            raise ModelError(f"{where}: field '{field}' holds the control character U+{o:04X} at "
                             f"index {k} ({value[:40]!r}); names must be printable text")
    return value


def as_dh_links(links) -> tuple:
    """``links`` as a non-empty tuple of at most ``limits.MAX_JOINTS`` :class:`DHLink`, or a ModelError."""
    try:
        links = tuple(links)
    except TypeError:
        raise ModelError(f"links: expected a sequence of DHLink, got {type(links).__name__}") from None
    if not links:
        raise ModelError("links: an arm needs at least one DHLink, got none")
    if len(links) > limits.MAX_JOINTS:
        raise limits.over_limit("links", "the number of links", len(links), "MAX_JOINTS")
    for i, l in enumerate(links):
        if not isinstance(l, DHLink):
            raise ModelError(f"links[{i}]: expected a DHLink, got {type(l).__name__}")
    return links


def _qlim(value, where: str):
    if value is None:
        return None
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError, RecursionError):
        raise ModelError(f"{where}: field 'qlim' must be (lower, upper), got {value!r:.100}") from None
    if arr.shape != (2,):
        raise ModelError(f"{where}: field 'qlim' must have length 2 (lower, upper), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{where}: field 'qlim' must be finite, got {arr.tolist()}")
    if not arr[0] < arr[1]:
        raise ModelError(f"{where}: field 'qlim' must have lower < upper, got {arr.tolist()}")
    return (float(arr[0]), float(arr[1]))


def _check_actuator(where, motor_inertia, gear_ratio, friction_viscous, friction_coulomb):
    jm = _scalar(motor_inertia, where, "motor_inertia")
    if jm < 0:
        raise ModelError(f"{where}: field 'motor_inertia' must be >= 0 kg m^2, got {jm}")
    g = _scalar(gear_ratio, where, "gear_ratio")
    if g == 0:
        raise ModelError(f"{where}: field 'gear_ratio' must be non-zero, got {g}")
    if abs(g) ** 2 * jm > limits.MAX_MAGNITUDE:
        raise ModelError(f"{where}: the reflected rotor inertia gear_ratio^2 * motor_inertia = "
                         f"{abs(g) ** 2 * jm:g} is over {limits.MAX_MAGNITUDE:g} (manipdyn.limits.MAX_MAGNITUDE)")
    fv = _scalar(friction_viscous, where, "friction_viscous")
    fc = _scalar(friction_coulomb, where, "friction_coulomb")
    if fv < 0 or fc < 0:
        raise ModelError(f"{where}: friction coefficients must be >= 0, got viscous={fv}, coulomb={fc}")
    return jm, g, fv, fc


def physical_note(body: LinkInertia, where: str, strict: bool = False) -> str | None:
    """The one-line note on a physically impossible body (None when it is consistent);
    with ``strict``, a :class:`ModelError` instead."""
    try:
        body.check_physical(strict=True, where=where)
    except ModelError as exc:
        if strict:
            raise
        return str(exc)
    return None


def _refuse_negative_moment(I: np.ndarray, where: str) -> None:
    """A DH link (model file or Python) with a clearly negative principal moment is refused,
    as a negative mass is.  (URDF files keep loading with a note: vendors publish such
    bodies, e.g. Tiago's antenna link, and the files are used as they are.)"""
    if not np.any(I):
        return
    low = float(np.linalg.eigvalsh(I)[0])
    # the tolerance of LinkInertia.consistency_problems, and never below MuJoCo's mjMINVAL (1e-15 kg m^2):
    # a massless body's zero tensor rebuilt through sums (diag(0, 1e-19, -1e-19)) is rounding, not a body
    if low < -max(1e-9 * float(np.max(np.abs(I))), 1e-15):
        raise ModelError(f"{where}: field 'inertia' has a negative principal moment of inertia "
                         f"{low:.6g} kg m^2; no body has one, as no body has a negative mass")


@dataclass(frozen=True, eq=False, init=False)
class DHLink:
    """One Denavit-Hartenberg link with its inertia, immutable once built.

    Parameters
    ----------
    joint : "revolute" | "prismatic"
    a, alpha, d, theta : float
        DH parameters (m, rad).  For the modified (Craig) convention ``a`` and
        ``alpha`` are ``a_{n-1}`` and ``alpha_{n-1}``, the parameters written on
        row n of a Craig table.  Fixed offsets: a revolute joint has
        ``theta_n = q_n + theta``; a prismatic joint has ``d_n = q_n + d``.
    body : LinkInertia, optional
        The link's mass properties in DH frame n (the link holds exactly one).
    mass, com, inertia : optional
        Shorthand for ``body``: kg; centre of mass in frame n (m); tensor about
        the centre of mass, frame-n axes, tensor sign (kg m^2), 3x3 or three
        diagonal values.  Given with ``body``, they replace those parts of it
        (this is what ``dataclasses.replace(link, mass=...)`` does).
    qlim : (lower, upper) or None
        Joint limits (rad or m).
    motor_inertia, gear_ratio : float
        Rotor inertia ``Jm`` (kg m^2, motor side) and gear ratio ``G``; the
        reflected inertia ``G^2 Jm`` is added to ``D``'s diagonal.
    friction_viscous, friction_coulomb : float
        Joint friction ``tau_f = Fv qd + Fc sign(qd)`` (N m s/rad, N m), applied
        outside the Lagrangian.
    name : str
        Optional link name, used in messages and in the URDF.
    """

    joint: str
    a: float
    alpha: float
    d: float
    theta: float
    body: LinkInertia
    qlim: object
    motor_inertia: float
    gear_ratio: float
    friction_viscous: float
    friction_coulomb: float
    name: str

    def __init__(self, joint: str = "revolute", a: float = 0.0, alpha: float = 0.0, d: float = 0.0,
                 theta: float = 0.0, body: LinkInertia | None = None, *, mass=None, com=None,
                 inertia=None, qlim=None, motor_inertia: float = 0.0, gear_ratio: float = 1.0,
                 friction_viscous: float = 0.0, friction_coulomb: float = 0.0, name: str = ""):
        name = check_name(str(name), "DHLink", "name")
        where = f"link '{name}'" if name else "DHLink"
        if not isinstance(joint, str) or joint not in JOINT_TYPES:
            raise ModelError(f"{where}: field 'joint' must be 'revolute' or 'prismatic', got {joint!r}")
        set_ = object.__setattr__
        set_(self, "joint", joint)
        set_(self, "name", name)
        for f, v in (("a", a), ("alpha", alpha), ("d", d), ("theta", theta)):
            set_(self, f, _scalar(v, where, f))
            limits.check_range(getattr(self, f), where, f, "angle" if f in ("alpha", "theta") else "length")
        if body is not None and not isinstance(body, LinkInertia):
            raise ModelError(f"{where}: field 'body' must be a LinkInertia, got {type(body).__name__}")
        base = body if body is not None else LinkInertia(name=where)
        if body is None or mass is not None or com is not None or inertia is not None:
            body = LinkInertia(base.mass if mass is None else mass, base.com if com is None else com,
                               base.inertia if inertia is None else inertia, name=where)
        _refuse_negative_moment(body.inertia, where)
        set_(self, "body", body)
        set_(self, "qlim", _qlim(qlim, where))
        if self.qlim is not None:
            limits.check_range(self.qlim, where, "qlim", "length" if joint == "prismatic" else "angle")
        jm, g, fv, fc = _check_actuator(where, motor_inertia, gear_ratio, friction_viscous, friction_coulomb)
        set_(self, "motor_inertia", jm)
        set_(self, "gear_ratio", g)
        set_(self, "friction_viscous", fv)
        set_(self, "friction_coulomb", fc)

    @property
    def mass(self) -> float:
        """Link mass, kg (of ``body``)."""
        return self.body.mass

    @property
    def com(self) -> np.ndarray:
        """Centre of mass in DH frame n, (3,), m (of ``body``)."""
        return self.body.com

    @property
    def inertia(self) -> np.ndarray:
        """Tensor about the centre of mass, frame-n axes, (3, 3), kg m^2 (of ``body``)."""
        return self.body.inertia

    @property
    def armature(self) -> float:
        """Reflected rotor inertia ``G^2 Jm`` (kg m^2 or kg)."""
        return self.gear_ratio**2 * self.motor_inertia

    def A(self, q, convention: str = "standard") -> np.ndarray:
        """The link transform A_n(q) (eq. 2.3/2.4, or Craig's), shape ``q.shape + (4, 4)``."""
        if convention not in ("standard", "modified"):
            raise ModelError(f"convention: must be 'standard' or 'modified', got {convention!r}")
        q = np.asarray(q, dtype=np.float64)
        if self.joint == "revolute":
            th, d = q + self.theta, self.d
        else:
            th, d = self.theta, q + self.d
        f = dh_standard if convention == "standard" else dh_modified
        return f(th, d, self.a, self.alpha)

    def __repr__(self) -> str:
        parts = [f"joint={self.joint!r}", f"a={self.a!r}", f"alpha={self.alpha!r}",
                 f"d={self.d!r}", f"theta={self.theta!r}", f"mass={self.mass!r}"]
        if self.mass:
            parts += [f"com={self.com.tolist()!r}", f"inertia={self.inertia.tolist()!r}"]
        if self.qlim is not None:
            parts.append(f"qlim={self.qlim!r}")
        if self.motor_inertia:
            parts += [f"motor_inertia={self.motor_inertia!r}", f"gear_ratio={self.gear_ratio!r}"]
        if self.name:
            parts.append(f"name={self.name!r}")
        return "DHLink(" + ", ".join(parts) + ")"


@dataclass(frozen=True, eq=False)
class ChainJoint:
    """One joint of a generic serial chain (a URDF chain).

    The child link frame is ``L_j = L_{j-1} @ origin @ M(q_j)`` with ``M`` a
    rotation about (revolute) or a translation along (prismatic) the unit
    ``axis``, expressed in the joint frame.  ``body`` is the child link's
    inertia in the child link frame.
    """

    name: str
    joint: str
    origin: np.ndarray
    axis: np.ndarray
    body: LinkInertia
    qlim: tuple | None = None
    armature: float = 0.0
    friction_viscous: float = 0.0
    friction_coulomb: float = 0.0
    effort: float | None = None
    velocity: float | None = None
    link_name: str = ""

    def __post_init__(self) -> None:
        where = f"joint '{self.name}'"
        if not isinstance(self.joint, str) or self.joint not in JOINT_TYPES:
            raise ModelError(f"{where}: type must be 'revolute' or 'prismatic', got {self.joint!r}")
        try:
            T = np.array(self.origin, dtype=np.float64)
        except (TypeError, ValueError, OverflowError, RecursionError):
            raise ModelError(f"{where}: origin must be a finite 4x4 transform") from None
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise ModelError(f"{where}: origin must be a finite 4x4 transform")
        limits.check_magnitude(T, where, "origin", " m")
        T.setflags(write=False)
        object.__setattr__(self, "origin", T)
        if not isinstance(self.body, LinkInertia):
            raise ModelError(f"{where}: body must be a LinkInertia, got {type(self.body).__name__}")
        ax = as_vector3(self.axis, where, "axis")
        nrm = float(np.linalg.norm(ax))
        if not nrm >= 1e-9:  # a tinier axis loses digits when normalised (its squares underflow)
            raise ModelError(f"{where}: axis must be a direction of length >= 1e-9, got {ax.tolist()}")
        ax = ax / nrm
        ax.setflags(write=False)
        object.__setattr__(self, "axis", ax)
        object.__setattr__(self, "qlim", _qlim(self.qlim, where))
        if self.qlim is not None:
            limits.check_range(self.qlim, where, "qlim", "length" if self.joint == "prismatic" else "angle")
        for f in ("effort", "velocity"):
            v = getattr(self, f)
            if v is not None:
                v = _scalar(v, where, f)
                if v < 0:
                    raise ModelError(f"{where}: field '{f}' must be >= 0 (a limit's magnitude), got {v}")
                object.__setattr__(self, f, v)
        for f in ("armature", "friction_viscous", "friction_coulomb"):
            v = _scalar(getattr(self, f), where, f)
            if v < 0:
                raise ModelError(f"{where}: field '{f}' must be >= 0, got {v}")
            object.__setattr__(self, f, v)
        object.__setattr__(self, "name", check_name(self.name, where, "name"))


def dh_links_equal(a: "DHLink", b: "DHLink") -> bool:
    """True when two DH links hold the same numbers and name (every field compared exactly)."""
    return all(
        np.array_equal(np.asarray(getattr(a, f)), np.asarray(getattr(b, f)))
        for f in ("joint", "a", "alpha", "d", "theta", "mass", "com", "inertia", "qlim",
                  "motor_inertia", "gear_ratio", "friction_viscous", "friction_coulomb", "name")
    )
