"""The one interface both dynamics engines answer: :class:`DynamicsEngine`.

Layer 3 (engines).  ``arm.lagrange`` (:mod:`manipdyn.engines.lagrange.engine`, the trace
form of chapter II) and ``arm.pinocchio`` (:mod:`manipdyn.engines.pinocchio.engine`)
share no code; they share this protocol, so the cross-check, the tests and
the benchmarks treat them alike.  A new engine implements these methods,
registers a factory with :func:`manipdyn.model.arm.register_engine`, and is then
``arm.engine("name")``.

Shapes: every method takes one state ``(n,)`` or a batch ``(N, n)`` (each
argument the same) and returns arrays with the same leading shape.  Units SI:
rad or m, N m or N, kg m^2, J; frames: the arm's base frame.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["DynamicsEngine", "ENGINE_METHODS", "OPTIONAL_ENGINE_METHODS", "JacobianEngine", "not_offered"]

#: the methods of :class:`DynamicsEngine`, in one place for tests and tools
ENGINE_METHODS = ("mass_matrix", "coriolis_torque", "gravity_torque", "friction_torque",
                  "dynamics_terms", "inverse_dynamics", "forward_dynamics", "kinetic_energy",
                  "potential_energy", "coriolis_matrix", "fkine", "regressor",
                  "inverse_dynamics_derivatives", "forward_dynamics_derivatives", "gravity_derivative",
                  "friction_derivative")
#: methods an engine MAY offer (:class:`JacobianEngine`): both Python engines do; an engine that
#: computes dynamics only (generated C) leaves them out, and ``md.crosscheck`` then compares them
#: between the engines that have them and says in its notes what it left out
OPTIONAL_ENGINE_METHODS = ("jacobian", "jacobian_dot")


@runtime_checkable
class DynamicsEngine(Protocol):
    """Dynamics of one arm: ``tau = D(q) qdd + h(q, qd) + g(q) + friction(qd)``."""

    #: engine name, ``"lagrange"`` or ``"pinocchio"``
    name: str
    #: number of joints
    n: int

    def mass_matrix(self, q) -> np.ndarray:
        """D(q): (n, n) or (N, n, n), kg m^2, symmetric positive definite (rotors ``R^T diag(Jm) R`` included)."""
        ...

    def coriolis_torque(self, q, qd) -> np.ndarray:
        """h(q, qd) = C(q, qd) qd: (n,) or (N, n), N m (Coriolis and centripetal)."""
        ...

    def gravity_torque(self, q) -> np.ndarray:
        """g(q): (n,) or (N, n), N m, the torque that holds the arm still."""
        ...

    def friction_torque(self, qd) -> np.ndarray:
        """The friction law at the joints (``Fv qd + Fc sign(qd)`` for the links' kind;
        :class:`manipdyn.model.drive.Friction`, motor side mapped by ``R^T``): (n,) or (N, n), N m."""
        ...

    def dynamics_terms(self, q, qd) -> tuple:
        """``(D, h, g)`` at once (shapes as above)."""
        ...

    def inverse_dynamics(self, q, qd, qdd) -> np.ndarray:
        """tau = D qdd + h + g + friction: (n,) or (N, n), N m."""
        ...

    def forward_dynamics(self, q, qd, tau) -> np.ndarray:
        """qdd solving D qdd = tau - h - g - friction: (n,) or (N, n), rad/s^2 or m/s^2."""
        ...

    def kinetic_energy(self, q, qd):
        """K = qd^T D qd / 2: float or (N,), J."""
        ...

    def potential_energy(self, q):
        """P = -sum m_i g^T c_i (zero at the base origin height): float or (N,), J."""
        ...

    def coriolis_matrix(self, q, qd) -> np.ndarray:
        """C(q, qd) with C qd = h and dD/dt - 2C skew-symmetric: (n, n) or (N, n, n)."""
        ...

    def fkine(self, q) -> np.ndarray:
        """The tool (end) frame's pose in the base frame: (4, 4) or (N, 4, 4), metres."""
        ...

    def regressor(self, q, qd, qdd, armature: bool = False, friction: bool = False) -> np.ndarray:
        """Y with ``Y @ arm.parameters(armature, friction) = tau``: (n, p) or (N, n, p).

        10 columns per link (Pinocchio's order, about the URDF link frame's
        origin), then n armature and 2n friction columns when asked for
        (:mod:`manipdyn.model.parameters`).
        """
        ...

    # -- derivatives (index [..., i, m] = d out_i / d in_m) ----------------------------
    def inverse_dynamics_derivatives(self, q, qd, qdd) -> tuple:
        """``(dtau_dq, dtau_dqd)``: each (n, n) or (N, n, n); friction included.

        ``dtau/dqdd`` is :meth:`mass_matrix`.
        """
        ...

    def forward_dynamics_derivatives(self, q, qd, tau) -> tuple:
        """``(dqdd_dq, dqdd_dqd, dqdd_dtau)``: each (n, n) or (N, n, n); ``dqdd_dtau = D^-1``."""
        ...

    def gravity_derivative(self, q) -> np.ndarray:
        """``dg/dq``: (n, n) or (N, n, n), N m/rad, symmetric."""
        ...

    def friction_derivative(self, qd) -> np.ndarray:
        """``dF/dqd`` of the friction law: (n, n) or (N, n, n); what a non-smooth law returns
        where it has no derivative is the engine's to document."""
        ...


@runtime_checkable
class JacobianEngine(Protocol):
    """The optional kinematic part of an engine (:data:`OPTIONAL_ENGINE_METHODS`).

    The tool frame is the one :meth:`DynamicsEngine.fkine` gives.  Same shapes on every engine.
    """

    def jacobian(self, q, frame: str = "world", link=None) -> np.ndarray:
        """Geometric Jacobian of the tool frame: (6, n) or (N, 6, n).  Rows 0-2: linear velocity of
        the tool origin, rows 3-5: angular velocity, both in base-frame axes (Pinocchio's
        ``LOCAL_WORLD_ALIGNED``), or in the frame's own axes with ``frame="tool"`` (``LOCAL``);
        ``link=k`` (1..n): link k's frame (:meth:`manipdyn.Arm.link_poses`) instead of the tool's;
        ``[v; w] = J qd``, SI units."""
        ...

    def jacobian_dot(self, q, qd, link=None) -> np.ndarray:
        """``dJ/dt`` along ``qd``: (6, n) or (N, 6, n); the tool's acceleration is ``J qdd + Jdot qd``
        (link ``link``'s, 1..n, when given)."""
        ...


def not_offered(E) -> dict:
    """The cross-check's quantities (``"C"``, ``"Y"``, ``"dtau_dq"`` ...) engine ``E`` does not
    compute, and why: its optional attribute ``not_offered`` (a dict), e.g. MuJoCo's Christoffel
    matrix and regressor.  :func:`manipdyn.crosscheck` leaves them out with a note, never
    compares them loosely, and does not count them as a failed condition."""
    return dict(getattr(E, "not_offered", None) or {})
