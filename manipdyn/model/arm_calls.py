"""What a Robotics Toolbox or Pinocchio user reaches for on the arm itself.

Layer 1 (model), part of :class:`manipdyn.model.arm.Arm`: named poses
(``arm.poses["ready"]``, the Toolbox's ``qr``/``qz``), the tool frame's
geometric Jacobian, its time derivative and manipulability, and the fast path's
``coriolis_matrix``, ``regressor``, ``kinetic_energy`` and ``potential_energy``, and
``inverse_dynamics`` and ``forward_dynamics`` with the wrench ``f_tool`` the environment
applies to the tool (:mod:`manipdyn.model.reach`).  The model computes none of it: each
call goes to an engine (Pinocchio unless ``engine=`` names another), and both engines
answer with the same shapes.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from .._support.errors import ModelError
from .._support.state import as_state
from .reach import as_wrench, check_link, wrench_torque

__all__ = ["ArmCalls", "as_poses", "MANIPULABILITY_AXES"]

#: the rows of the Jacobian :meth:`ArmCalls.manipulability` measures
MANIPULABILITY_AXES = {"all": slice(0, 6), "trans": slice(0, 3), "rot": slice(3, 6)}


def as_poses(poses, n: int, where: str) -> MappingProxyType:
    """Named joint vectors, checked: a read-only ``{name: (n,) read-only array}``.

    Names are identifiers (``ready``, ``zero``, ...); values are n finite numbers
    (rad or m).  They are not checked against the joint limits: a pose is kept as
    its source publishes it (the model file's ``sources.poses`` says which lie outside).
    """
    if poses is None:
        return MappingProxyType({})
    if not isinstance(poses, dict):
        raise ModelError(f"{where}: poses must be a table of name = [{n} joint values], got {type(poses).__name__}")
    out = {}
    for name, q in poses.items():
        if not isinstance(name, str) or not name.isidentifier():
            raise ModelError(f"{where}: pose name {name!r} is not a plain name (letters, digits, _)")
        if isinstance(q, (str, bytes, dict)):
            raise ModelError(f"{where}: pose {name!r}: expected {n} numbers (one per joint), got {q!r:.80}")
        try:
            arr = np.array(q, dtype=np.float64)
        except (TypeError, ValueError, OverflowError):
            raise ModelError(f"{where}: pose {name!r}: expected {n} numbers (one per joint), got {q!r:.80}") from None
        if arr.shape != (n,) or not np.all(np.isfinite(arr)):
            raise ModelError(f"{where}: pose {name!r}: expected {n} finite numbers (one per joint), got {q!r:.80}")
        arr.setflags(write=False)
        out[name] = arr
    return MappingProxyType(out)


class ArmCalls:
    """Mixin of :class:`manipdyn.model.arm.Arm` (see the module docstring)."""

    #: named joint vectors ``{name: (n,)}``, rad or m, from the model file's ``[poses]``
    #: (with their source in ``arm.sources["poses"]``); empty for an arm read from a URDF
    poses = MappingProxyType({})

    def _engine_with(self, engine: str, method: str):
        eng = self.engine(engine)
        if not callable(getattr(eng, method, None)):
            raise ModelError(f"engine: engine {engine!r} offers no {method} (an optional method of "
                             "manipdyn.engines.protocol.JacobianEngine); use engine='pinocchio' or 'lagrange'")
        return getattr(eng, method)

    def link_number(self, link) -> int:
        """``link`` as its number 1..n: a number 1..n, or the name of a link of the chain (the URDF's link
        names of a :class:`manipdyn.URDFArm`, the links' names, else ``link1 .. linkn``, of a
        :class:`manipdyn.Manipulator`); a :class:`ModelError` naming the choices otherwise."""
        if isinstance(link, str):
            names = [j.link_name for j in self.chain()[0]]
            if link in names:
                return names.index(link) + 1
            shown = ", ".join(repr(x) for x in names[:12]) + (", ..." if len(names) > 12 else "")
            raise ModelError(f"link: {link[:80]!r} is not a link of {self.name or 'the arm'}; its links are "
                             f"{shown} (or their numbers 1..{self.n})")
        return check_link(link, self.n)

    def jacobian(self, q, engine: str = "pinocchio", *, frame: str = "world", link=None) -> np.ndarray:
        """Geometric Jacobian of the tool frame (the frame ``fkine`` gives): (6, n) or (N, 6, n).

        ``[v; w] = J qd``: rows 0-2 the linear velocity of the frame's origin (m/s), rows 3-5
        the angular velocity (rad/s).  ``frame="world"``: both in base-frame axes
        (Pinocchio's ``LOCAL_WORLD_ALIGNED``, the Toolbox's ``jacob0``; note: at the frame's
        origin, not Pinocchio's ``WORLD`` point at the base origin); ``frame="tool"``: in the
        frame's own axes (Pinocchio's ``LOCAL``, the Toolbox's ``jacobe``).  ``link=k``
        (1..n, or the link's name, :meth:`link_number`) gives link k's frame instead,
        ``arm.link_poses(q)[k - 1]`` (DH frame k of a :class:`Manipulator`); its columns after k are
        zero.  ``engine="lagrange"`` derives it from the chapter's ``dT/dq`` (eq. 2.5 to 2.8);
        ``md.crosscheck`` compares the two.
        """
        link = None if link is None else self.link_number(link)
        return self._engine_with(engine, "jacobian")(q, frame=frame, link=link)

    def jacobian_dot(self, q, qd, engine: str = "pinocchio", *, link=None) -> np.ndarray:
        """``dJ/dt`` of :meth:`jacobian` along ``qd``: (6, n) or (N, 6, n).

        The tool's acceleration (origin, base axes) is ``J qdd + Jdot qd``: what
        operational-space control needs.  ``link`` (1..n): the rate of link k's Jacobian
        (``jacobian(q, link=k)``, base axes) instead, so its frame's acceleration is
        ``J_k qdd + Jdot_k qd``.
        """
        if link is None:
            return self._engine_with(engine, "jacobian_dot")(q, qd)
        return self._engine_with(engine, "jacobian_dot")(q, qd, link=self.link_number(link))

    def manipulability(self, q, axes: str = "all", engine: str = "pinocchio"):
        """Yoshikawa's manipulability ``sqrt(det(J_a J_a^T))``: float, or (N,) for a batch.

        ``J_a`` holds the rows of :meth:`jacobian` that ``axes`` names: ``"all"`` (6 rows,
        mixed units, as the Toolbox's default), ``"trans"`` (linear, m per rad) or
        ``"rot"``.  It is 0 at a singularity and whenever n is smaller than the rows asked for.
        """
        if not isinstance(axes, str) or axes not in MANIPULABILITY_AXES:
            raise ValueError(f"axes: expected one of {', '.join(MANIPULABILITY_AXES)}, got {axes!r}")
        J = self.jacobian(q, engine=engine)[..., MANIPULABILITY_AXES[axes], :]
        det = np.linalg.det(J @ np.swapaxes(J, -1, -2))
        w = np.sqrt(np.maximum(det, 0.0))        # det(J J^T) >= 0; round-off may give -1e-20
        return float(w) if np.ndim(w) == 0 else w

    def point_in_base(self, q, point, link=None) -> np.ndarray:
        """A point given in link frame ``link`` (1..n or its name, default n), in the base frame (eq. 2.8).

        ``point`` is (3,) in metres; the result is (3,) or (N, 3) for a batch of q.
        """
        p = np.asarray(point, dtype=np.float64)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(f"point: expected 3 finite numbers (x, y, z) in metres, got {point!r}")
        k = self.n if link is None else self.link_number(link)
        T = self.link_poses(q)[..., k - 1, :, :]
        return T[..., :3, :3] @ p + T[..., :3, 3]          # r = T_k [p, 1] (eq. 2.8)

    # -- the fast path (Pinocchio) ------------------------------------------------
    def inverse_dynamics(self, q, qd, qdd, f_tool=None, *, link=None):
        """tau = D qdd + h + g (+ friction) - J^T f_tool, (n,) or (N, n), N m: Pinocchio's RNEA.

        ``f_tool`` (6,) or (N, 6): the wrench ``[force (N); moment (N m)]`` the environment
        applies to the tool, in base-frame axes at the tool origin (``fkine``'s frame);
        ``J`` is :meth:`jacobian` (``frame="world"``).  None (the default) costs nothing.
        ``link`` (1..n or a link's name): the wrench acts on that link instead, at the origin of
        its frame ``arm.link_poses(q)[k - 1]`` (base axes), and ``J`` is ``jacobian(q, link=link)``.
        """
        eng = self._engines.get("pinocchio") or self.engine("pinocchio")
        if f_tool is None:
            if link is not None:
                self.link_number(link)
            return eng.inverse_dynamics(q, qd, qdd)
        return eng.inverse_dynamics(q, qd, qdd) - self._wrench_torque(eng, q, f_tool, link)

    def forward_dynamics(self, q, qd, tau, f_tool=None, *, link=None):
        """qdd solving D qdd = tau + J^T f_tool - h - g (- friction), (n,) or (N, n): Pinocchio's ABA.

        ``f_tool`` and ``link`` as in :meth:`inverse_dynamics`: the wrench the environment applies
        to the tool, or to link ``link``.
        """
        eng = self._engines.get("pinocchio") or self.engine("pinocchio")
        if f_tool is None:
            if link is not None:
                self.link_number(link)
            return eng.forward_dynamics(q, qd, tau)
        tau = as_state(tau, "tau", self.n)
        return eng.forward_dynamics(q, qd, tau + self._wrench_torque(eng, q, f_tool, link))

    def _wrench_torque(self, eng, q, f_tool, link=None):
        """``J(q)^T f_tool`` (n,) or (N, n) by ``eng``: the joint torques with which a wrench on the tool (or
        on link ``link``, at its frame's origin) acts."""
        J = eng.jacobian(q) if link is None else eng.jacobian(q, link=self.link_number(link))
        return wrench_torque(J, as_wrench(f_tool, as_state(q, "q", self.n)))

    def potential_energy(self, q):
        """P = -sum_i m_i g^T c_i (zero at the base origin's height): float or (N,), J (Pinocchio).

        ``-dP/dq`` is minus the gravity torque; the trace form's eq. 2.24 answers the same
        (``arm.lagrange.potential_energy``), and ``md.crosscheck`` compares the two.
        """
        return self.engine("pinocchio").potential_energy(q)

    def coriolis_matrix(self, q, qd) -> np.ndarray:
        """C(q, qd), (n, n) or (N, n, n), N m s: ``C qd = h``, ``dD/dt - 2C`` skew-symmetric (Pinocchio)."""
        return self.engine("pinocchio").coriolis_matrix(q, qd)

    def regressor(self, q, qd, qdd, armature: bool = False, friction: bool = False) -> np.ndarray:
        """Y with ``Y @ arm.parameters(armature, friction) = tau``: (n, p) or (N, n, p) (Pinocchio's
        ``computeJointTorqueRegressor``; 10 columns per link, then armature and friction columns).

        ``friction=True`` is viscous and Coulomb columns (joint side, sharp sign); an arm with
        another law (the bundled panda's sigmoid) needs ``friction=arm.friction_model``, and
        ``arm.parameters(friction=True)`` says so rather than leave its friction out."""
        return self.engine("pinocchio").regressor(q, qd, qdd, armature=armature, friction=friction)

    def kinetic_energy(self, q, qd):
        """K = qd^T D qd / 2, rotors included: float or (N,), J (Pinocchio)."""
        return self.engine("pinocchio").kinetic_energy(q, qd)


