"""The arm: an immutable description of a serial manipulator.

Layer 1 (model).  ``Arm`` is the common base; :class:`Manipulator` is an arm described by a DH table (the
user-facing constructor), and :class:`URDFArm` an arm read from a URDF chain (built by
:func:`manipdyn.formats.urdf.reader.load_urdf`).  The model knows nothing of files, of how an engine is
built, of the cross-check or of the CLI.  Engines plug in from above through :func:`register_engine`;
each arm builds each engine lazily, on first use, and keeps it:

* ``arm.lagrange``: the trace-form Lagrange-Euler engine (slow, independent);
* ``arm.pinocchio``: the Pinocchio engine on the arm's URDF (fast);
* ``arm.mass_matrix``, ``arm.coriolis_torque``, ``arm.gravity_torque``, ``arm.inverse_dynamics``,
  ``arm.forward_dynamics`` (:mod:`manipdyn.model.arm_calls`, with a tool wrench ``f_tool``),
  ``arm.potential_energy``: the fast path.
"""
from __future__ import annotations

import warnings

import numpy as np

from .._support import limits
from .._support.errors import ModelError, PhysicalConsistencyWarning, warn_notes
from .kinematics import ChainKinematics, DHKinematics
from .drive import arm_drive
from .arm_calls import ArmCalls, as_poses
from .reach import ReachCalls
from .links import ChainJoint, DHLink, as_dh_links, as_gravity, check_name, dh_links_equal, physical_note
from .dh_chain import as_transform, dh_chain, dh_link_offsets
from .registry import (CONVENTIONS, DEFAULT_QLIM, ENGINE_FACTORIES, REQUIRED, SERVICES, Convention, TraceFormData,
                       joint_letters, register_engine, register_service)

__all__ = ["Arm", "Manipulator", "URDFArm", "Convention", "TraceFormData", "register_engine",
           "register_service", "DEFAULT_QLIM", "joint_letters", "as_gravity"]

#: the calls that go to Pinocchio when made on the arm itself
_FAST_PATH = ("mass_matrix", "coriolis_torque", "gravity_torque", "inverse_dynamics", "forward_dynamics")


class Arm(ArmCalls, ReachCalls):  # jacobian, inverse_dynamics, poses, ...: .arm_calls; inverse_kinematics: .reach
    """Common behaviour of every arm (DH or URDF).  Do not build directly.

    Subclasses set ``name``, ``gravity``, ``source`` and implement
    :meth:`chain` and :meth:`trace_form_data`.
    """

    name: str
    gravity: np.ndarray
    source: str = ""
    notes: tuple = ()  #: one line per physically impossible link, suspicious unit, ...
    #: what an identified model carries from its fit (a JSON-ready dict: data sha256, options, fitted range,
    #: prediction band, ...; :mod:`manipdyn.formats.trust` moves it across the disk), or None
    trust: dict | None = None
    #: the drive (:func:`manipdyn.model.drive.arm_drive`): transmission, friction_model (Friction or None), Jm (n,),
    #: rotor inertia R^T diag(Jm) R (n, n), armature R_kk^2 Jm_k (n,), friction (2, n) of the links' kind or None
    transmission: object
    friction_model: object
    motor_inertia: np.ndarray
    rotor_inertia: np.ndarray

    def __init__(self) -> None:
        self._engines: dict = {}

    # -- to be provided by subclasses -------------------------------------
    def chain(self):
        """The arm as a URDF-ready chain: ``(joints, tool)``.

        ``joints`` is a tuple of :class:`ChainJoint` (origins relative to the
        previous URDF link frame, inertias in the URDF link frame) and
        ``tool`` the fixed 4x4 transform from the last URDF link to the tool
        (flange) frame.
        """
        raise NotImplementedError

    def trace_form_data(self) -> TraceFormData:
        """The kinematics, pseudo-inertias, armature and friction the trace form runs on."""
        raise NotImplementedError

    def urdf_link_offsets(self) -> np.ndarray:
        """``S_i`` (n, 4, 4), ``T_i = L_i S_i``: identity, as a URDF chain's trace form runs in
        its URDF link frames; a standard-DH :class:`Manipulator` overrides it."""
        return np.tile(np.eye(4), (self.n, 1, 1))

    #: URDF text for Pinocchio when the arm came from a file (None: generate it from :meth:`chain`)
    source_urdf: str | None = None
    #: movable joints of the source URDF held at 0 (their subtrees lumped into the chain)
    locked_joints: tuple = ()

    # -- engines ---------------------------------------------------------------
    def engine(self, name: str):
        """The engine ``name`` of this arm (built on first use, then kept)."""
        try:
            return self._engines[name]
        except KeyError:
            pass
        try:
            factory = ENGINE_FACTORIES[name]
        except KeyError:
            raise ModelError(f"engine: no engine {name!r} is registered "
                             f"(registered: {', '.join(sorted(ENGINE_FACTORIES)) or 'none'}); import manipdyn") from None
        self.set_engine(name, eng := factory(self))
        return eng

    def set_engine(self, name: str, engine) -> None:
        """Use ``engine`` as this arm's engine ``name`` from now on.

        For an engine built by hand: a custom Pinocchio model, or a planted
        bug in a mutation test.  It must answer :class:`manipdyn.DynamicsEngine`.
        Pinocchio's checked ``mass_matrix``, ``coriolis_torque``, ``gravity_torque`` are bound on the arm
        itself (a forwarding method cost 0.16 of CRBA's own time, issue 38 item 23).
        """
        self._engines[name] = engine
        if name == "pinocchio":
            for call in ("mass_matrix", "coriolis_torque", "gravity_torque"):
                self.__dict__[call] = getattr(engine, call)

    @property
    def lagrange(self):
        """The trace-form Lagrange-Euler engine (chapter II)."""
        return self.engine("lagrange")

    @property
    def pinocchio(self):
        """The Pinocchio engine (RNEA, CRBA, ABA) on this arm's URDF."""
        return self.engine("pinocchio")

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

    def parameters(self, armature: bool = False, friction: bool = False) -> np.ndarray:
        """``pi`` with ``engine.regressor(q, qd, qdd, armature, friction) @ pi = tau`` (:mod:`manipdyn.model.parameters`)."""
        from .parameters import arm_parameters
        return arm_parameters(self, armature=armature, friction=friction)

    # -- the fast path --------------------------------------------------------
    def mass_matrix(self, q):
        """D(q), (n, n) or (N, n, n), kg m^2: Pinocchio's CRBA."""
        eng = self._engines.get("pinocchio") or self.engine("pinocchio")
        return eng.mass_matrix(q)

    def coriolis_torque(self, q, qd):
        """h(q, qd), (n,) or (N, n), N m: Coriolis and centripetal torque."""
        eng = self._engines.get("pinocchio") or self.engine("pinocchio")
        return eng.coriolis_torque(q, qd)

    def gravity_torque(self, q):
        """g(q), (n,) or (N, n), N m: the torque that holds the arm still."""
        eng = self._engines.get("pinocchio") or self.engine("pinocchio")
        return eng.gravity_torque(q)

    def linearize(self, q, qd, tau, dt=None, engine="pinocchio"): return SERVICES["linearize"](self, q, qd, tau, dt, engine)

    def with_payload(self, mass: float, com=(0.0, 0.0, 0.0), inertia=None, name=None) -> "Arm":
        """A new arm of the same kind (DH or URDF) carrying a payload fixed at the tool: ``mass`` kg, ``com``
        (3,) m in the tool frame; ``inertia`` (3, 3), (6,) ``[ixx, iyy, izz, ixy, ixz, iyz]`` or (3,) kg m^2
        about that COM, tool axes (default 0)
        (:func:`manipdyn.model.variants.with_payload`; ``name`` default ``"<arm>+<mass>kg"``)."""
        return SERVICES["with_payload"](self, mass, com, inertia, name)

    # -- kinematics ---------------------------------------------------------
    def link_poses(self, q) -> np.ndarray:
        """Link frames T_1..T_n in the base frame (eq. 2.7): (n, 4, 4) or (N, n, 4, 4)."""
        return self.lagrange.link_poses(q)

    def fkine(self, q) -> np.ndarray:
        """Pose of the tool frame in the base frame: ``T`` (4, 4) or (N, 4, 4), metres, with
        ``p_base = T @ [p_tool, 1]``.  The tool frame is DH frame n (``T_n`` of eq. 2.7; the
        ``tool`` link of the generated URDF) for a :class:`Manipulator`, or ``base T_n tool`` when
        it has a ``base`` (then in the world) or a ``tool`` transform, and the tip link
        (``arm.tip``) for a :class:`URDFArm` (loaded without ``tip=``: the last moving link, and
        ``arm.notes`` names the fixed frames beyond it that were passed over, e.g. ``tool0``);
        :meth:`jacobian` is this frame's."""
        return self.lagrange.fkine(q)

    def random_state(self, rng, size=None):
        """Joint positions drawn uniformly within :attr:`qlim`: (n,) or (size, n)."""
        lo, hi = self.qlim[:, 0], self.qlim[:, 1]
        shape = (self.n,) if size is None else (size, self.n)
        return lo + (hi - lo) * rng.random(shape)

    # -- deprecated conveniences (the model knows nothing of files) -------------
    def _service(self, name: str, replacement: str):
        warnings.warn(f"arm.{name}(...) is deprecated; use {replacement}", DeprecationWarning, stacklevel=3)
        return SERVICES[name]

    def to_urdf(self) -> str:
        """Deprecated: use :func:`manipdyn.to_urdf` (``md.to_urdf(arm)``)."""
        return self._service("to_urdf", "md.to_urdf(arm)")(self)

    def write_urdf(self, path) -> None:
        """Deprecated: use :func:`manipdyn.write_urdf` (``md.write_urdf(arm, path)``)."""
        return self._service("write_urdf", "md.write_urdf(arm, path)")(self, path)

    def save(self, path) -> None:
        """Deprecated: use :func:`manipdyn.save` (``md.save(arm, path)``)."""
        return self._service("save", "md.save(arm, path)")(self, path)

    def crosscheck(self, samples: int = 1000, seed: int = 0, **kw):
        """Deprecated: use :func:`manipdyn.crosscheck` (``md.crosscheck(arm, ...)``)."""
        return self._service("crosscheck", "md.crosscheck(arm, ...)")(self, samples=samples, seed=seed, **kw)

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r}: {self.n} joints {self.joint_letters}>"


class Manipulator(Arm):
    """A serial arm described by Denavit-Hartenberg links.

    Parameters
    ----------
    links : sequence of :class:`DHLink`
        From the base outwards; link i's inertia is given in DH frame i.
    convention : "standard" | "modified"
        Standard (distal, eq. 2.3) or modified (Craig) DH.  Required: there
        is no silent guess, and leaving it out raises ``TypeError``.
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
    transmission : Transmission, optional
        Motors to joints; its diagonal must be the links' gear ratios (default:
        ``diag(gear_ratio)``).
    friction : Friction, optional
        The friction law; default: the links' viscous and Coulomb friction,
        joint side, sharp sign (then the links' friction must be zero).
    poses : dict, optional
        Named joint vectors ``{"ready": (n,), ...}`` (rad or m), kept as ``arm.poses``.
    base : (4, 4), optional
        The pose of the arm's base (the frame the DH table starts from) in the world, a rigid
        homogeneous transform (metres), as the Robotics Toolbox's ``base``: every link frame,
        :meth:`fkine` and the Jacobians are in the world, and ``gravity`` is given in the world.
        Default the identity.
    tool : (4, 4), optional
        The tool frame in DH frame n (the Toolbox's ``tool``): :meth:`fkine`, ``jacobian``
        and ``f_tool`` are this frame's.  Default the identity.
    """

    def __init__(self, links, convention: Convention = REQUIRED, gravity=(0.0, 0.0, -9.81),
                 name: str = "", strict: bool = False, source: str = "", sources=None,
                 description: str = "", transmission=None, friction=None, poses=None, base=None, tool=None):
        super().__init__()
        if convention is REQUIRED:
            raise TypeError("Manipulator: the argument 'convention' is required: 'standard' (distal DH, "
                            "eq. 2.3) or 'modified' (Craig's proximal DH); there is no default")
        if not isinstance(convention, str) or convention not in CONVENTIONS:
            raise ModelError(f"convention: must be 'standard' or 'modified', got {convention!r}")
        self.links = links = as_dh_links(links)
        self.convention = convention
        self.base, self.tool = as_transform(base, "base"), as_transform(tool, "tool")
        self.gravity = as_gravity(gravity)
        self.name = check_name(str(name), "Manipulator", "name")
        self.source = str(source)
        self.sources = dict(sources or {})
        self.description = str(description)
        self.strict = bool(strict)
        self.joint_types = tuple(l.joint for l in links)
        self._qlim = np.array([l.qlim if l.qlim is not None else DEFAULT_QLIM[l.joint] for l in links])
        self._qlim.setflags(write=False)
        self.poses = as_poses(poses, self.n, f"{self.name or 'Manipulator'}: poses")
        self.motor_inertia = np.array([l.motor_inertia for l in links])
        self.motor_inertia.setflags(write=False)
        self.transmission, self.friction_model, self.rotor_inertia, self.armature, self.friction = arm_drive(
            self.n, [l.gear_ratio for l in links], self.motor_inertia, [l.friction_viscous for l in links],
            [l.friction_coulomb for l in links], transmission, friction, self.name or "arm")
        notes = (physical_note(l.body, f"{self.name or 'arm'}: link {i + 1}" + (f" ({l.name})" if l.name else ""),
                               self.strict) for i, l in enumerate(links))
        self.notes = tuple(n for n in notes if n)
        warn_notes(self.name or "arm", self.notes, PhysicalConsistencyWarning)

    def __eq__(self, other):
        if not isinstance(other, Manipulator):
            return NotImplemented
        return (self.convention == other.convention and self.name == other.name
                and self.source == other.source and self.sources == other.sources
                and self.description == other.description
                and np.array_equal(self.gravity, other.gravity)
                and np.array_equal(self.base, other.base) and np.array_equal(self.tool, other.tool)
                and len(self.links) == len(other.links) and self.transmission == other.transmission
                and self.poses.keys() == other.poses.keys()
                and all(np.array_equal(v, other.poses[k]) for k, v in self.poses.items())
                and (self.friction_model == other.friction_model) is True
                and all(dh_links_equal(a, b) for a, b in zip(self.links, other.links)))

    __hash__ = None  # type: ignore[assignment]

    def trace_form_data(self) -> TraceFormData:
        """DH kinematics (eq. 2.3 or Craig's) and each link's J in its DH frame (eq. 2.21)."""
        kin = DHKinematics(self.links, self.convention, self.base, self.tool)
        J = np.array([l.body.J for l in self.links])
        return TraceFormData(kin, J, self.armature, self.friction_model)

    @property
    def joint_names(self) -> tuple:
        """Joint names in the generated URDF: ``joint1 .. jointn``."""
        return tuple(f"joint{i + 1}" for i in range(self.n))

    def link_names(self) -> list[str]:
        return [l.name or f"link{i + 1}" for i, l in enumerate(self.links)]

    def chain(self):
        """The DH arm as a URDF-ready chain (see :meth:`Arm.chain`; :func:`manipdyn.model.dh_chain.dh_chain`)."""
        return dh_chain(self.links, self.convention, self._qlim, self.link_names(), self.urdf_link_offsets(),
                        self.base, self.tool)

    def urdf_link_offsets(self) -> np.ndarray:
        """``S_i`` (n, 4, 4): DH frame i = URDF link i frame @ S_i (identity for modified DH)."""
        return dh_link_offsets(self.links, self.convention)


class URDFArm(Arm):
    """A serial arm read from a URDF file; build it with :func:`manipdyn.formats.urdf.reader.load_urdf`.

    Attributes
    ----------
    name, gravity, source : as for every :class:`Arm`
    joint_names : tuple of str
        Chain joints, root to tip (the order of q).
    joint_types : tuple of "revolute" | "prismatic"
        ``continuous`` joints are revolute joints without limits.
    link_names : tuple of str
        The child link of each chain joint.
    root, tip : str
        Root link (the fixed base frame) and the link whose pose :meth:`fkine` gives.
    locked_joints : tuple of str
        Movable joints off the chain, held at 0 (their subtrees are lumped).
    urdf_text : str
        The original text.
    source_urdf : str
        The text Pinocchio reads: the original, with ``continuous`` joints
        written as revolute (:func:`manipdyn.formats.urdf.reader.pinocchio_text`).
    armature : (n,)
        ``R_kk^2 Jm_k``; zeros unless ``motor_inertia=`` is given (URDF has no rotor inertia).
    friction : (2, n) or None
        Viscous (``damping``) and Coulomb (``friction``) coefficients of ``<dynamics>``.
    transmission : Transmission
        Identity by default (URDF has no gears); ``transmission=`` gives one.
    friction_model : Friction or None
        ``<dynamics>`` as a joint-side sharp-sign law, or the ``friction=`` given
        (which replaces ``<dynamics>``).
    """

    def __init__(self, *, name, gravity, source, urdf_text, pin_text, root, tip, joints, tool,
                 locked, members, path=None, transmission=None, friction=None, motor_inertia=None):
        super().__init__()
        self.name = check_name(str(name), "URDFArm", "name")
        self.gravity = as_gravity(gravity)
        self.source = source
        self.urdf_text = urdf_text
        self.source_urdf = pin_text
        self.path = path
        self.root = root
        self.tip = tip
        self._joints = joints
        tool = np.array(tool, dtype=np.float64)
        tool.setflags(write=False)
        self._tool = tool
        self.locked_joints = tuple(locked)
        self.lumped_links = tuple(tuple(m) for m in members)
        self.joint_names = tuple(j.name for j in joints)
        self.link_names = tuple(j.link_name for j in joints)
        self.joint_types = tuple(j.joint for j in joints)
        self._qlim = np.array([j.qlim for j in joints], dtype=np.float64)
        self._qlim.setflags(write=False)
        n = len(joints)
        self.custom_drive = (transmission is not None or friction is not None
                             or motor_inertia is not None)  #: not from the URDF text
        self.motor_inertia = (np.zeros(n) if motor_inertia is None
                              else np.array(motor_inertia, dtype=np.float64).reshape(n))
        self.motor_inertia.setflags(write=False)
        G = np.ones(n) if transmission is None else np.diag(getattr(transmission, "R", np.eye(n)))
        fr = np.zeros((2, n)) if friction is not None else [[j.friction_viscous for j in joints],
                                                              [j.friction_coulomb for j in joints]]
        self.transmission, self.friction_model, self.rotor_inertia, self.armature, self.friction = arm_drive(
            n, G, self.motor_inertia, fr[0], fr[1], transmission, friction, self.name or "arm")

    @property
    def tool_frame(self) -> str:
        """Name of the frame whose pose :meth:`fkine` gives, in Pinocchio's model: the tip link."""
        return self.tip

    # -- Arm interface --------------------------------------------------------
    def chain(self):
        """``(joints, tool)``: the chain joints and the fixed transform last link -> tip."""
        return self._joints, self._tool.copy()

    def trace_form_data(self) -> TraceFormData:
        """The chain's kinematics (any axes) and each body's J in its URDF link frame."""
        kin = ChainKinematics(self._joints, self._tool)
        J = np.array([j.body.J for j in self._joints])
        return TraceFormData(kin, J, self.armature, self.friction_model)

    # -- comparison and display -------------------------------------------------
    def __eq__(self, other):
        if not isinstance(other, URDFArm):
            return NotImplemented
        return (self.urdf_text == other.urdf_text and self.tip == other.tip
                and self.name == other.name and np.array_equal(self.gravity, other.gravity))

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        kinds = joint_letters(self.joint_types)
        s = f"<URDFArm {self.name!r}: {self.n} joints {kinds}, {self.root!r} -> {self.tip!r}"
        if self.locked_joints:
            s += f", {len(self.locked_joints)} locked"
        return s + f" ({self.source})>"

