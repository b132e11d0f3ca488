"""Rigid-body inertia of one link and its pseudo-inertia matrix (eq. 2.20, 2.21).

Layer 1 (model): every conversion between inertia conventions lives here.

Conventions (see CONVENTIONS.md):

* ``inertia`` is the inertia TENSOR about the centre of mass, in the link
  frame's axes, with the tensor sign: ``I_xy = -integral(x y dm)``.  This is
  what URDF's ``<inertia ixy=...>`` and most libraries mean.
* The chapter's eq. 2.21 writes ``I_xy = +integral(x y dm)`` about the frame
  ORIGIN.  :func:`pseudo_inertia_from_chapter_terms` (and
  :meth:`LinkInertia.from_chapter_terms`, which calls it) is the one door
  between the two conventions.
* The pseudo-inertia ``J = integral(r r^T dm)``, ``r = [x, y, z, 1]``, is a
  symmetric 4x4 matrix ``[[S, m c], [m c^T, m]]`` with ``S`` the second moment
  about the frame origin.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from .._support import limits
from .._support.errors import ModelError, PhysicalConsistencyWarning

__all__ = [
    "LinkInertia", "as_vector3", "as_tensor3", "LINK_PARAMETERS",
    "tensor_from_second_moment", "second_moment_from_tensor",
    "inertia_about_origin_from_com", "inertia_about_com_from_origin",
    "pseudo_inertia_from_tensor", "tensor_from_pseudo_inertia",
    "pseudo_inertia_from_chapter_terms", "chapter_terms_from_pseudo_inertia",
    "transform_pseudo_inertia", "parameters_from_pseudo_inertia", "pseudo_inertia_from_parameters",
]

# Relative tolerance on the smallest eigenvalue of J (and on the triangle
# inequalities) before a body is called physically impossible: a few ulps of
# the body's own scale, so that rounding in published tables is not flagged.
_PSD_RTOL = 1e-9
#: largest ratio of the largest principal moment to the sum of the other two that
#: float64 pseudo-inertias hold (see :meth:`LinkInertia.check_representable`):
#: the rounding ``1e-16 * 1e6`` stays 1e-10 relative to the moments that matter
REPRESENTABLE_RATIO = 1e6


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64, copy=True)
    a.setflags(write=False)
    return a


def _as_float_array(value, where: str, field_name: str, expected: str) -> np.ndarray:
    """``value`` as a float array, or a ModelError naming the field and the ``expected`` form."""
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError, RecursionError):
        raise ModelError(f"{where}: field '{field_name}' must be {expected}, got {value!r:.200}") from None


def as_vector3(value, where: str, field_name: str) -> np.ndarray:
    """Return ``value`` as a finite float 3-vector or raise ModelError naming it."""
    arr = _as_float_array(value, where, field_name, "3 numbers (x, y, z)")
    if arr.shape != (3,):
        raise ModelError(
            f"{where}: field '{field_name}' must have length 3 (x, y, z), got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{where}: field '{field_name}' must be finite, got {arr.tolist()}")
    limits.check_magnitude(arr, where, field_name)
    return arr


def as_tensor3(value, where: str, field_name: str = "inertia") -> np.ndarray:
    """Return an inertia tensor as a symmetric 3x3 array.

    Accepted forms: a 3x3 matrix, or a 3-vector ``(Ixx, Iyy, Izz)`` meaning a
    diagonal tensor.  A 6-vector is refused on purpose: its element order is
    ambiguous between libraries (a known source of silent errors); pass a 3x3
    matrix instead.
    """
    arr = _as_float_array(value, where, field_name, "a 3x3 matrix or 3 diagonal values")
    if arr.shape == (3,):
        arr = np.diag(arr)
    elif arr.shape == (6,):
        raise ModelError(
            f"{where}: field '{field_name}' got 6 values; their order is ambiguous "
            "(ixx, iyy, izz, ixy, ixz, iyz or ixx, ixy, ixz, ...), give a 3x3 matrix"
        )
    elif arr.shape != (3, 3):
        raise ModelError(
            f"{where}: field '{field_name}' must be a 3x3 matrix or 3 diagonal values, "
            f"got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{where}: field '{field_name}' must be finite, got {arr.tolist()}")
    limits.check_magnitude(arr, where, field_name, " kg m^2")
    limits.check_range(arr, where, field_name, "inertia")
    scale = max(1e-300, float(np.max(np.abs(arr))))
    if np.max(np.abs(arr - arr.T)) > 1e-12 * scale:
        raise ModelError(
            f"{where}: field '{field_name}' must be symmetric, got {arr.tolist()}"
        )
    return 0.5 * (arr + arr.T)


# -- the crossings between conventions: one function each ------------------
#
# Every conversion between the tensor form and the pseudo-inertia J, between
# the chapter's product-of-inertia sign and the tensor sign, between moments
# about the centre of mass and about the frame origin, between frames, and
# between J and the 10 standard parameters lives here and nowhere else.  The
# two primitives are the pair of linear maps between a second moment S and an
# inertia tensor I about the same point: I = tr(S) E - S, S = tr(I)/2 E - I.

def tensor_from_second_moment(S) -> np.ndarray:
    """Inertia tensor about a point from the second moment about it: ``I = tr(S) E - S``.

    ``S = integral(r r^T dm)`` (3, 3) or (..., 3, 3), kg m^2; the tensor has the
    tensor sign (``I_xy = -integral(x y dm)``).
    """
    S = np.asarray(S, dtype=np.float64)
    tr = np.trace(S, axis1=-2, axis2=-1)[..., None, None]
    return tr * np.eye(3) - S


def second_moment_from_tensor(I) -> np.ndarray:
    """Second moment ``S = integral(r r^T dm)`` from an inertia tensor about the same point.

    ``S = tr(I)/2 E - I``: the inverse of :func:`tensor_from_second_moment`.
    (3, 3) or (..., 3, 3), kg m^2.
    """
    I = np.asarray(I, dtype=np.float64)
    tr = np.trace(I, axis1=-2, axis2=-1)[..., None, None]
    return 0.5 * tr * np.eye(3) - I


def inertia_about_origin_from_com(mass: float, com, inertia_com) -> np.ndarray:
    """Tensor about the frame origin from the tensor about the COM (parallel axis), (3, 3), kg m^2.

    ``I_O = I_C + m (c^T c E - c c^T)``, ``com`` in metres in the same frame.
    """
    c = np.asarray(com, dtype=np.float64)
    return np.asarray(inertia_com, dtype=np.float64) + mass * (float(c @ c) * np.eye(3) - np.outer(c, c))


def inertia_about_com_from_origin(mass: float, com, inertia_origin) -> np.ndarray:
    """Tensor about the COM from the tensor about the frame origin: the inverse of
    :func:`inertia_about_origin_from_com`, (3, 3), kg m^2."""
    c = np.asarray(com, dtype=np.float64)
    return np.asarray(inertia_origin, dtype=np.float64) - mass * (float(c @ c) * np.eye(3) - np.outer(c, c))


def pseudo_inertia_from_tensor(mass: float, com, inertia_com) -> np.ndarray:
    """Pseudo-inertia J (4, 4) of eq. 2.20 from mass (kg), COM (m) and tensor about the COM.

    ``J = [[S_O, m c], [m c^T, m]]`` with ``S_O`` the second moment about the
    frame origin: ``S_O = S_C + m c c^T`` and ``S_C`` from the tensor by
    :func:`second_moment_from_tensor`.
    """
    c = np.asarray(com, dtype=np.float64)
    J = np.empty((4, 4))
    J[:3, :3] = second_moment_from_tensor(inertia_com) + mass * np.outer(c, c)
    J[:3, 3] = J[3, :3] = mass * c
    J[3, 3] = mass
    return J


def tensor_from_pseudo_inertia(J, name: str = "link"):
    """``(mass, com, inertia_com)`` from a pseudo-inertia J (4, 4): the inverse of
    :func:`pseudo_inertia_from_tensor`.

    A massless J must have no first moments (no body has them); a massless J
    with second moments is returned as mass 0 with that inertia (it is then
    flagged by :meth:`LinkInertia.consistency_problems`).
    """
    J = np.asarray(J, dtype=np.float64)
    m = float(J[3, 3])
    S = J[:3, :3]
    if m > 0:
        c = J[:3, 3] / m
        S_c = S - m * np.outer(c, c)
    elif np.any(J[:3, 3]):
        raise ModelError(
            f"{name}: pseudo-inertia J has first moments m*c = {J[:3, 3].tolist()} "
            "but mass 0; no body has that"
        )
    else:
        c = np.zeros(3)
        S_c = S
    return m, c, tensor_from_second_moment(S_c)


def pseudo_inertia_from_chapter_terms(m, mx, my, mz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz) -> np.ndarray:
    """J (4, 4) from the terms of the chapter's eq. 2.21 (all about the frame ORIGIN).

    ``Ixx = integral(y^2 + z^2) dm`` etc.; the products use the chapter's sign,
    ``Ixy = +integral(x y dm)`` (the opposite of the tensor sign); ``mx = m x_bar``.
    """
    return np.array(
        [
            [(-Ixx + Iyy + Izz) / 2, Ixy, Ixz, mx],
            [Ixy, (Ixx - Iyy + Izz) / 2, Iyz, my],
            [Ixz, Iyz, (Ixx + Iyy - Izz) / 2, mz],
            [mx, my, mz, m],
        ],
        dtype=np.float64,
    )


def chapter_terms_from_pseudo_inertia(J) -> dict:
    """The ten terms of eq. 2.21 (chapter sign, about the frame origin) from J (4, 4).

    Returns a dict with keys ``m, mx, my, mz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz``;
    the inverse of :func:`pseudo_inertia_from_chapter_terms`.
    """
    J = np.asarray(J, dtype=np.float64)
    S = J[:3, :3]
    d = np.diag(tensor_from_second_moment(S))
    return {"m": float(J[3, 3]), "mx": float(J[0, 3]), "my": float(J[1, 3]), "mz": float(J[2, 3]),
            "Ixx": float(d[0]), "Iyy": float(d[1]), "Izz": float(d[2]),
            "Ixy": float(S[0, 1]), "Ixz": float(S[0, 2]), "Iyz": float(S[1, 2])}


def transform_pseudo_inertia(J, X) -> np.ndarray:
    """Express a pseudo-inertia in another frame: ``J' = X J X^T`` (4, 4) or (..., 4, 4).

    ``X`` (4x4 homogeneous) maps a point's coordinates in J's frame to the new
    frame.  Pseudo-inertias of bodies in one frame add: this is how bodies are
    lumped.
    """
    X = np.asarray(X, dtype=np.float64)
    return X @ np.asarray(J, dtype=np.float64) @ np.swapaxes(X, -1, -2)


#: deprecated name of :func:`transform_pseudo_inertia`
spatial_transform_pseudo_inertia = transform_pseudo_inertia

#: names of the 10 standard parameters of one body, in Pinocchio's order
#: (``pin.Inertia.toDynamicParameters``)
LINK_PARAMETERS = ("m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")


def parameters_from_pseudo_inertia(J) -> np.ndarray:
    """The 10 standard parameters (Pinocchio's order) of J: (4, 4) -> (10,), (..., 4, 4) -> (..., 10).

    ``[m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]`` with the
    tensor ``I`` (tensor sign) about the ORIGIN of J's frame:
    ``I = tensor_from_second_moment(J[:3, :3])``.
    """
    J = np.asarray(J, dtype=np.float64)
    I = tensor_from_second_moment(J[..., :3, :3])
    return np.stack([J[..., 3, 3], J[..., 0, 3], J[..., 1, 3], J[..., 2, 3],
                     I[..., 0, 0], I[..., 0, 1], I[..., 1, 1], I[..., 0, 2], I[..., 1, 2], I[..., 2, 2]],
                    axis=-1)


def pseudo_inertia_from_parameters(p) -> np.ndarray:
    """J from the 10 standard parameters: (10,) -> (4, 4), (..., 10) -> (..., 4, 4).

    The inverse of :func:`parameters_from_pseudo_inertia`.
    """
    p = np.asarray(p, dtype=np.float64)
    if p.shape[-1:] != (10,):
        raise ValueError(f"p: expected 10 parameters per body (last axis), got shape {p.shape}")
    ixx, ixy, iyy, ixz, iyz, izz = (p[..., k] for k in range(4, 10))
    I = np.stack([np.stack([ixx, ixy, ixz], -1), np.stack([ixy, iyy, iyz], -1),
                  np.stack([ixz, iyz, izz], -1)], -2)
    J = np.empty(p.shape[:-1] + (4, 4))
    J[..., :3, :3] = second_moment_from_tensor(I)
    J[..., :3, 3] = J[..., 3, :3] = p[..., 1:4]
    J[..., 3, 3] = p[..., 0]
    return J


@dataclass(frozen=True, eq=False)
class LinkInertia:
    """Mass properties of one rigid link, immutable once built.

    Parameters
    ----------
    mass : float
        Mass in kg, ``>= 0``.
    com : (3,) array_like
        Centre of mass in metres, in the link frame.
    inertia : (3, 3) array_like or (3,)
        Inertia tensor about the centre of mass, in kg m^2, link-frame axes,
        tensor sign (``I_xy = -integral(x y dm)``).  Three values mean a
        diagonal tensor.
    name : str
        Used in error messages only.
    """

    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    name: str = "link"

    def __post_init__(self) -> None:
        where = self.name
        try:
            m = float(self.mass)
        except (TypeError, ValueError, OverflowError):
            raise ModelError(f"{where}: field 'mass' must be a number in kg, got {self.mass!r:.60}") from None
        if not math.isfinite(m):
            raise ModelError(f"{where}: field 'mass' must be finite, got {m}")
        limits.check_magnitude(m, where, "mass", " kg")
        limits.check_range(m, where, "mass", "mass")
        if m < 0:
            raise ModelError(f"{where}: field 'mass' must be >= 0 kg, got {m}")
        object.__setattr__(self, "mass", m)
        com = as_vector3(self.com, where, "com")
        limits.check_range(com, where, "com", "length")
        object.__setattr__(self, "com", _readonly(com))
        object.__setattr__(self, "inertia", _readonly(as_tensor3(self.inertia, where, "inertia")))

    # -- conversions -------------------------------------------------------
    @property
    def J(self) -> np.ndarray:
        """Pseudo-inertia of eq. 2.20/2.21, (4, 4), in the link frame (a new array)."""
        return pseudo_inertia_from_tensor(self.mass, self.com, self.inertia)

    @classmethod
    def from_pseudo_inertia(cls, J, name: str = "link") -> "LinkInertia":
        """Build from a pseudo-inertia J (4x4, symmetric, eq. 2.20)."""
        J = np.asarray(J, dtype=np.float64)
        if J.shape != (4, 4):
            raise ModelError(f"{name}: pseudo-inertia J must be 4x4, got shape {J.shape}")
        if not np.all(np.isfinite(J)):
            raise ModelError(f"{name}: pseudo-inertia J must be finite")
        scale = max(1e-300, float(np.max(np.abs(J))))
        if np.max(np.abs(J - J.T)) > 1e-12 * scale:
            raise ModelError(f"{name}: pseudo-inertia J must be symmetric")
        J = 0.5 * (J + J.T)
        m, c, I_c = tensor_from_pseudo_inertia(J, name)
        return cls(mass=m, com=c, inertia=I_c, name=name)

    @classmethod
    def from_chapter_terms(
        cls,
        m: float,
        mx: float, my: float, mz: float,
        Ixx: float, Iyy: float, Izz: float,
        Ixy: float, Ixz: float, Iyz: float,
        name: str = "link",
    ) -> "LinkInertia":
        """Build from the terms of the chapter's eq. 2.21.

        All moments are about the link frame's ORIGIN (eq. 2.20 integrates
        ``r r^T`` with ``r`` from that origin).  ``Ixx = integral(y^2 + z^2) dm``
        and so on; the products use the chapter's sign, ``Ixy = +integral(x y dm)``,
        the opposite of the tensor sign.  ``mx = m * x_bar`` etc. are first moments.
        """
        J = pseudo_inertia_from_chapter_terms(m, mx, my, mz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz)
        return cls.from_pseudo_inertia(J, name=name)

    def inertia_about_origin(self) -> np.ndarray:
        """Inertia tensor (tensor sign) about the link frame's origin, (3, 3), kg m^2."""
        return inertia_about_origin_from_com(self.mass, self.com, self.inertia)

    def transformed(self, X) -> "LinkInertia":
        """The same body described in another frame.

        ``X`` (4x4, a rigid transform) maps coordinates in this body's frame
        to the new frame: ``c' = R c + p``, ``I_C' = R I_C R^T``.
        """
        X = np.asarray(X, dtype=np.float64)
        R = X[:3, :3]
        return LinkInertia(self.mass, R @ self.com + X[:3, 3], R @ self.inertia @ R.T, name=self.name)

    # -- physical consistency ---------------------------------------------
    def consistency_problems(self) -> list[str]:
        """Conditions under which no real rigid body has these mass properties.

        Empty when J (eq. 2.20) is positive semidefinite.  Each entry names the
        broken condition, e.g. ``"triangle inequality Ixx + Iyy >= Izz broken"``.
        """
        problems: list[str] = []
        I = self.inertia
        scale = max(float(np.max(np.abs(I))), 1e-300)
        if self.mass == 0.0:
            if np.max(np.abs(I)) > 0:
                problems.append("rotational inertia on a massless link (mass = 0, inertia != 0)")
            return problems
        try:
            principal = np.linalg.eigvalsh(I)
        except np.linalg.LinAlgError:  # cannot happen within limits.MAX_MAGNITUDE; never leak it
            return [f"the inertia tensor's principal moments cannot be computed ({I.tolist()})"]
        tol = _PSD_RTOL * scale
        if principal[0] < -tol:
            problems.append(f"negative principal moment of inertia {principal[0]:.6g} kg m^2")
        names = ("Ixx", "Iyy", "Izz")
        # Triangle inequality on the principal moments (with m > 0, equivalent to S >= 0).
        p = np.sort(principal)
        if p[0] + p[1] < p[2] - tol:
            n_before = len(problems)
            # Report in the axes the user wrote when the tensor is diagonal
            # (to within the same relative tolerance, whatever the body's size).
            if np.max(np.abs(I - np.diag(np.diag(I)))) <= tol:
                d = np.diag(I)
                for k in range(3):
                    i, j = sorted(((k + 1) % 3, (k + 2) % 3))
                    if d[i] + d[j] < d[k] - tol:
                        problems.append(
                            f"triangle inequality {names[i]} + {names[j]} >= {names[k]} broken "
                            f"({d[i]:.6g} + {d[j]:.6g} < {d[k]:.6g})"
                        )
            if len(problems) == n_before:
                problems.append(
                    "triangle inequality of the principal moments broken "
                    f"({p[0]:.6g} + {p[1]:.6g} < {p[2]:.6g})"
                )
        return problems

    def check_representable(self, where: str | None = None) -> None:
        """Raise :class:`ModelError` if float64 cannot hold this tensor in a pseudo-inertia.

        The pseudo-inertia stores ``S = tr(I)/2 E - I + m c c^T`` (eq. 2.21):
        every moment then carries a rounding error of about ``1e-16 tr(I)``.
        For a real body the largest principal moment is at most the sum of the
        other two, so that error stays relative to the moments that matter.
        A tensor whose largest principal moment exceeds the sum of the other
        two (or 1 kg m^2, the cross-check's absolute floor, if that is more)
        by more than :data:`REPRESENTABLE_RATIO` (a typo in an exponent,
        ``ixx="7e27"``) is not a rigid body, and its small moments are lost in
        that rounding: the trace form and Pinocchio would then describe
        different arms.  Refused even without ``strict``, naming the link.
        """
        I = self.inertia
        try:
            lam = np.abs(np.linalg.eigvalsh(I))
        except np.linalg.LinAlgError:
            lam = np.abs(np.diag(I))
        lam = np.sort(lam)
        # 1 kg m^2 floor: the cross-check's own absolute floor (errors relative to max(1, |D|))
        if lam[2] > REPRESENTABLE_RATIO * max(lam[0] + lam[1], 1.0):
            raise ModelError(
                f"{where or self.name}: inertia with principal moments {lam[2]:.6g}, {lam[1]:.6g}, "
                f"{lam[0]:.6g} kg m^2: the largest exceeds the sum of the other two by over "
                f"{REPRESENTABLE_RATIO:g} times; no rigid body has it, and float64 cannot hold the small "
                "moments beside it (the two engines would disagree). Check the units and exponents"
            )

    def check_physical(self, strict: bool = False, where: str | None = None) -> bool:
        """Warn (or raise with ``strict=True``) if the body is physically impossible.

        Returns True when the body is physically consistent.
        """
        problems = self.consistency_problems()
        if not problems:
            return True
        msg = f"{where or self.name}: physically impossible inertia: " + "; ".join(problems)
        self.check_representable(where)
        if strict:
            raise ModelError(msg)
        warnings.warn(msg, PhysicalConsistencyWarning, stacklevel=3)
        return False

    def __repr__(self) -> str:
        return (
            f"LinkInertia(mass={self.mass!r}, com={self.com.tolist()!r}, "
            f"inertia={self.inertia.tolist()!r}, name={self.name!r})"
        )

    def __eq__(self, other) -> bool:
        if not isinstance(other, LinkInertia):
            return NotImplemented
        return (
            self.mass == other.mass
            and np.array_equal(self.com, other.com)
            and np.array_equal(self.inertia, other.inertia)
        )

    __hash__ = None  # type: ignore[assignment]
