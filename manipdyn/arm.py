"""The arm: an immutable description of a serial manipulator and its two engines.

``Arm`` is the common base; :class:`Manipulator` is an arm described by a DH
table (the user-facing constructor), and :class:`manipdyn.urdf_in.URDFArm`
an arm read from a URDF chain.  Both expose

* ``arm.lagrange``: the trace-form Lagrange-Euler engine (slow, independent);
* ``arm.pinocchio``: the Pinocchio engine on the arm's URDF (fast);
* ``arm.mass_matrix``, ``arm.coriolis_torque``, ``arm.gravity_torque``,
  ``arm.inverse_dynamics``, ``arm.forward_dynamics``: the fast path.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .errors import ModelError, PhysicalConsistencyWarning, warn_notes
from .kinematics import ChainJoint, DHKinematics, DHLink, rot_x, rot_z, trans

__all__ = ["Arm", "Manipulator"]

#: joint-limit defaults used when a link has no ``qlim``: revolute +-pi rad,
#: prismatic +-1 m.  They bound the states the cross-check draws.
DEFAULT_QLIM = {"revolute": (-math.pi, math.pi), "prismatic": (-1.0, 1.0)}


def _gravity(value, where="gravity") -> np.ndarray:
    try:
        g = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: expected 3 numbers (gx, gy, gz) in m/s^2, got {value!r}") from None
    if g.shape == (4,) and g[3] == 0.0:
        g = g[:3]  # the chapter's homogeneous form [gx, gy, gz, 0]
    if g.shape != (3,):
        raise ModelError(f"{where}: expected 3 numbers (gx, gy, gz) in m/s^2, got shape {g.shape}")
    if not np.all(np.isfinite(g)):
        raise ModelError(f"{where}: must be finite, got {g.tolist()}")
    g = g.copy()
    g.setflags(write=False)
    return g


def joint_letters(joint_types) -> str:
    """``("revolute", "prismatic")`` -> ``"RP"``."""
    return "".join("R" if t == "revolute" else "P" for t in joint_types)


#: the calls that go to Pinocchio when made on the arm itself
_FAST_PATH = ("mass_matrix", "coriolis_torque", "gravity_torque", "inverse_dynamics", "forward_dynamics")


class Arm:
    """Common behaviour of every arm (DH or URDF).  Do not build directly.

    Subclasses set ``name``, ``gravity``, ``source`` and implement
    :meth:`chain` and :meth:`_lagrange_parts`.
    """

    name: str
    gravity: np.ndarray
    source: str = ""
    #: one line per thing worth the user's attention in the description (a
    #: physically impossible link inertia, a value in a suspicious unit, ...)
    notes: tuple = ()

    # -- to be provided by subclasses -------------------------------------
    def chain(self):
        """The arm as a URDF-ready chain: ``(joints, tool)``.

        ``joints`` is a tuple of :class:`ChainJoint` (origins relative to the
        previous URDF link frame, inertias in the URDF link frame) and
        ``tool`` the fixed 4x4 transform from the last URDF link to the tool
        (flange) frame.
        """
        raise NotImplementedError

    def _lagrange_parts(self):
        """``(kinematics, J (n,4,4), armature (n,), friction (2,n))`` for the trace form."""
        raise NotImplementedError

    def trace_form_parts(self):
        """What the trace-form engine is built from: ``(kinematics, J, armature, friction)``.

        ``J`` (n, 4, 4) are the links' pseudo-inertias (eq. 2.20) in the
        frames of :meth:`link_poses`, ``armature`` (n,) the rotor inertias
        ``G^2 Jm`` and ``friction`` (2, n) or None (viscous, Coulomb).
        """
        return self._lagrange_parts()

    def _pinocchio_model(self):
        from .pinocchio_engine import model_from_urdf

        return model_from_urdf(self.to_urdf(), self.gravity, self.armature)

    # -- derived properties ---------------------------------------------------
    @property
    def n(self) -> int:
        """Number of joints (degrees of freedom)."""
        return len(self.joint_types)

    @property
    def joint_letters(self) -> str:
        """The joint types as letters, e.g. ``"RRPRRR"`` (R revolute, P prismatic)."""
        return joint_letters(self.joint_types)

    @property
    def qlim(self) -> np.ndarray:
        """Joint limits (n, 2), rad or m; defaults of :data:`DEFAULT_QLIM` where none given."""
        return self._qlim

    @functools.cached_property
    def lagrange(self):
        """The trace-form Lagrange-Euler engine (chapter II)."""
        from .lagrange import TraceFormEngine

        kin, J, arm, fr = self._lagrange_parts()
        return TraceFormEngine(kin, J, self.gravity, armature=arm, friction=fr)

    @functools.cached_property
    def pinocchio(self):
        """The Pinocchio engine (RNEA, CRBA, ABA) on this arm's URDF."""
        from .pinocchio_engine import PinocchioEngine

        eng = PinocchioEngine(self._pinocchio_model(), friction=self.friction)
        # Bind the fast path straight to the engine: arm.inverse_dynamics(...)
        # then costs one call, not two (the instance attribute shadows the
        # delegating method below, which only runs on the first call).
        for name in _FAST_PATH:
            self.__dict__[name] = getattr(eng, name)
        return eng

    # -- the fast path --------------------------------------------------------
    def mass_matrix(self, q):
        """D(q), (n, n) or (N, n, n), kg m^2: Pinocchio's CRBA."""
        return self.pinocchio.mass_matrix(q)

    def coriolis_torque(self, q, qd):
        """h(q, qd), (n,) or (N, n), N m: Coriolis and centripetal torque."""
        return self.pinocchio.coriolis_torque(q, qd)

    def gravity_torque(self, q):
        """g(q), (n,) or (N, n), N m: the torque that holds the arm still."""
        return self.pinocchio.gravity_torque(q)

    def inverse_dynamics(self, q, qd, qdd):
        """tau = D qdd + h + g (+ friction), (n,) or (N, n): Pinocchio's RNEA."""
        return self.pinocchio.inverse_dynamics(q, qd, qdd)

    def forward_dynamics(self, q, qd, tau):
        """qdd solving D qdd = tau - h - g (- friction), (n,) or (N, n): Pinocchio's ABA."""
        return self.pinocchio.forward_dynamics(q, qd, tau)

    # -- kinematics ---------------------------------------------------------
    def link_poses(self, q) -> np.ndarray:
        """Link frames T_1..T_n in the base frame (eq. 2.7): (n, 4, 4) or (N, n, 4, 4)."""
        return self.lagrange.link_poses(q)

    def fkine(self, q) -> np.ndarray:
        """End (tool) pose in the base frame: (4, 4) or (N, 4, 4)."""
        return self.lagrange.fkine(q)

    def point_in_base(self, q, point, link: int | None = None) -> np.ndarray:
        """A point given in link frame ``link`` (1..n, default n), in the base frame (eq. 2.8).

        ``point`` is (3,) in metres; the result is (3,) or (N, 3) for a batch of q.
        """
        p = np.asarray(point, dtype=np.float64)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(f"point: expected 3 finite numbers (x, y, z) in metres, got {point!r}")
        k = self.n if link is None else int(link)
        if not 1 <= k <= self.n:
            raise ValueError(f"link: expected 1..{self.n}, got {link!r}")
        T = self.link_poses(q)[..., k - 1, :, :]
        return T[..., :3, :3] @ p + T[..., :3, 3]          # r = T_k [p, 1] (eq. 2.8)

    def random_state(self, rng, size=None):
        """Joint positions drawn uniformly within :attr:`qlim`: (n,) or (size, n)."""
        lo, hi = self.qlim[:, 0], self.qlim[:, 1]
        shape = (self.n,) if size is None else (size, self.n)
        return lo + (hi - lo) * rng.random(shape)

    # -- conversion and files -------------------------------------------------
    def to_urdf(self) -> str:
        """This arm as URDF text (built through yourdfpy's objects)."""
        from .urdf_out import arm_to_urdf

        return arm_to_urdf(self)

    def write_urdf(self, path) -> None:
        """Write :meth:`to_urdf` to ``path`` atomically (no partial file on failure)."""
        from ._files import atomic_write_text

        atomic_write_text(path, self.to_urdf())

    def save(self, path) -> None:
        """Write a model file (TOML) that :func:`manipdyn.load` reads back unchanged."""
        from .modelfile import save_model

        save_model(self, path)

    def crosscheck(self, samples: int = 1000, seed: int = 0, **kw):
        """Shortcut for :func:`manipdyn.crosscheck` on this arm."""
        from .check import crosscheck

        return crosscheck(self, samples=samples, seed=seed, **kw)

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r}: {self.n} joints {self.joint_letters}>"


class Manipulator(Arm):
    """A serial arm described by Denavit-Hartenberg links.

    Parameters
    ----------
    links : sequence of :class:`DHLink`
        From the base outwards; link i's inertia is given in DH frame i.
    convention : "standard" | "modified"
        Standard (distal, eq. 2.3) or modified (Craig) DH.  Required to be
        one of the two; there is no silent guess.
    gravity : (3,)
        Acceleration of gravity in the base frame (m/s^2); the chapter's
        homogeneous ``[gx, gy, gz, 0]`` is accepted too.
    name : str
        Arm name (used for the URDF robot name and in reports).
    strict : bool
        If True, a physically impossible link inertia raises
        :class:`ModelError` instead of warning
        (:class:`PhysicalConsistencyWarning`).
    source : str
        Citation of the data (model files require it for bundled arms).
    sources : dict, optional
        Citations per group of values (``kinematics``, ``inertia``,
        ``corrections``, ...), as in model files.
    description : str
        Free text, kept by model files.
    """

    def __init__(self, links, convention: str = "standard", gravity=(0.0, 0.0, -9.81),
                 name: str = "", strict: bool = False, source: str = "", sources=None,
                 description: str = ""):
        if convention not in ("standard", "modified"):
            raise ModelError(f"convention: must be 'standard' or 'modified', got {convention!r}")
        links = tuple(links)
        if not links:
            raise ModelError("links: an arm needs at least one DHLink, got none")
        for i, l in enumerate(links):
            if not isinstance(l, DHLink):
                raise ModelError(f"links[{i}]: expected a DHLink, got {type(l).__name__}")
        self.links = links
        self.convention = convention
        self.gravity = _gravity(gravity)
        self.name = str(name)
        self.source = str(source)
        self.sources = dict(sources or {})
        self.description = str(description)
        self.strict = bool(strict)
        self.joint_types = tuple(l.joint for l in links)
        self._qlim = np.array([l.qlim if l.qlim is not None else DEFAULT_QLIM[l.joint] for l in links])
        self._qlim.setflags(write=False)
        self.armature = np.array([l.armature for l in links])
        self.armature.setflags(write=False)
        fr = np.array([[l.friction_viscous for l in links], [l.friction_coulomb for l in links]])
        self.friction = fr if np.any(fr) else None
        notes = []
        for i, l in enumerate(links):
            label = f"link {i + 1}" + (f" ({l.name})" if l.name else "")
            _refuse_negative_moment(l.body.inertia, f"{self.name or 'arm'}: {label}")
            try:
                l.body.check_physical(strict=True, where=f"{self.name or 'arm'}: {label}")
            except ModelError as exc:
                if self.strict:
                    raise
                notes.append(str(exc))
        self.notes = tuple(notes)
        warn_notes(self.name or "arm", notes, PhysicalConsistencyWarning)

    def __eq__(self, other):
        if not isinstance(other, Manipulator):
            return NotImplemented
        return (self.convention == other.convention and self.name == other.name
                and self.source == other.source and self.sources == other.sources
                and self.description == other.description
                and np.array_equal(self.gravity, other.gravity)
                and len(self.links) == len(other.links)
                and all(_dh_equal(a, b) for a, b in zip(self.links, other.links)))

    __hash__ = None  # type: ignore[assignment]

    def _lagrange_parts(self):
        kin = DHKinematics(self.links, self.convention)
        J = np.array([l.body.J for l in self.links])
        return kin, J, self.armature, self.friction

    def link_names(self) -> list[str]:
        return [l.name or f"link{i + 1}" for i, l in enumerate(self.links)]

    def chain(self):
        """The DH arm as a URDF-ready chain (see :meth:`Arm.chain`).

        Standard DH: joint i turns about z of frame i-1, so its URDF frame is
        ``T_{i-1} Rz(theta_i) Tz(d_i)``, and DH frame i is that frame (after
        the motion) times ``S_i = Tx(a_i) Rx(alpha_i)``; ``S_i`` moves into the
        next joint's origin, and ``S_n`` into the tool joint.  Modified DH:
        the URDF link frame IS DH frame i.  The fixed offsets theta and d go
        into the origins, so URDF joint positions are the DH joint variables q.
        """
        joints = []
        prev_S = np.eye(4)
        names = self.link_names()
        offsets = self.urdf_link_offsets()
        for i, l in enumerate(self.links):
            S = offsets[i]
            if self.convention == "standard":
                origin = prev_S @ rot_z(l.theta) @ trans(0, 0, l.d)
            else:
                origin = rot_x(l.alpha) @ trans(l.a, 0, 0) @ rot_z(l.theta) @ trans(0, 0, l.d)
            body = l.body.transformed(S)  # frame-i data into the URDF link frame
            joints.append(ChainJoint(
                name=f"joint{i + 1}", joint=l.joint, origin=origin, axis=(0.0, 0.0, 1.0),
                body=body, qlim=tuple(self._qlim[i]), armature=l.armature,
                friction_viscous=l.friction_viscous, friction_coulomb=l.friction_coulomb,
                link_name=names[i],
            ))
            prev_S = S
        return tuple(joints), prev_S

    def urdf_link_offsets(self) -> np.ndarray:
        """``S_i`` (n, 4, 4): DH frame i = URDF link i frame @ S_i (identity for modified DH)."""
        if self.convention == "modified":
            return np.tile(np.eye(4), (self.n, 1, 1))
        return np.array([trans(l.a, 0, 0) @ rot_x(l.alpha) for l in self.links])


def _refuse_negative_moment(I: np.ndarray, where: str) -> None:
    """A DH link (model file or Python) with a clearly negative principal moment is refused,
    as a negative mass is.  (URDF files keep loading with a note: vendors publish such
    bodies, e.g. Tiago's antenna link, and the files are used as they are.)"""
    if not np.any(I):
        return
    low = float(np.linalg.eigvalsh(I)[0])
    if low < -1e-9 * float(np.max(np.abs(I))):   # the tolerance of LinkInertia.consistency_problems
        raise ModelError(f"{where}: field 'inertia' has a negative principal moment of inertia "
                         f"{low:.6g} kg m^2; no body has one, as no body has a negative mass")


def _dh_equal(a: DHLink, b: DHLink) -> bool:
    return all(
        np.array_equal(np.asarray(getattr(a, f)), np.asarray(getattr(b, f)))
        for f in ("joint", "a", "alpha", "d", "theta", "mass", "com", "inertia", "qlim",
                  "motor_inertia", "gear_ratio", "friction_viscous", "friction_coulomb", "name")
    )
