"""The fast path: Pinocchio's RNEA, CRBA and ABA on the arm's URDF.

Layer 3 (engines: pinocchio).  Shares no code with the trace form (:mod:`manipdyn.engines.lagrange.engine`).

The model is built from URDF text with ``pinocchio.buildModelFromXML`` (no
temporary files).  Each engine owns its ``pin.Data``: an engine is not meant
to be shared between threads; batch calls use Pinocchio's own thread pool.

Every method takes one state ``(n,)`` or a batch ``(N, n)`` and returns a
new array of the same leading shape (SI units, joint order of the chain).

Drives (:mod:`manipdyn.model.drive`).  Pinocchio's ``model.armature`` is diagonal
only: it holds the diagonal of the rotor inertia ``R^T diag(Jm) R``, and with a
coupled transmission this engine adds the off-diagonal rest ``O`` itself: to D
(CRBA), to tau (``+ O qdd`` after RNEA), to the kinetic energy
(``+ qd^T O qd / 2``); forward dynamics then cannot use ABA, whose articulated
inertias know only the diagonal, and solves ``(CRBA + O) qdd = tau - rnea(q, qd, 0)
- friction`` instead (Cholesky of the full D).  The friction law is the model's
(:meth:`manipdyn.model.drive.Friction.torque`).  An arm with neither (diagonal R,
friction of the links' kind) runs exactly the code it always ran.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np
import pinocchio as pin

from ..._support.state import as_state, check_result, same_batch
from ..._support.errors import ModelError, SingularMassMatrixError
from ...model.parameters import with_extra_columns
from .fast import UncheckedView, install_fast_path
from .derivatives import OneStateFriction, PinocchioDerivatives, install_derivative_shortcuts
from .jacobian import PinocchioJacobian
from .threads import ThreadChoice
from .urdf_model import model_for_arm, model_from_urdf
from ...formats.urdf.writer import tool_link

_isfinite = math.isfinite
_clock = time.perf_counter
_crba, _rnea, _aba, _gravity = pin.crba, pin.rnea, pin.aba, pin.computeGeneralizedGravity

#: below this many states a batch runs on one thread (thread start-up costs
#: more than it saves on small batches)
PARALLEL_MIN_STATES = 2048

#: the process in which a batch call first ran on several threads: Pinocchio's
#: ``*InParallel`` calls start GNU OpenMP's thread pool there, and a process forked
#: from it inherits a pool whose threads did not survive the fork, so its next
#: parallel region waits for them forever (measured: a 4096-state batch in a child
#: forked after the parent ran one never returns).  A forked child therefore runs
#: its batches on one thread (a team of one never touches the pool); the numbers
#: are the same either way.
_POOL_PID = [None]

__all__ = ["PinocchioEngine", "pinocchio_engine", "model_for_arm", "model_from_urdf", "ThreadChoice",
           "PARALLEL_MIN_STATES"]


def pinocchio_engine(arm) -> "PinocchioEngine":
    """The Pinocchio engine of ``arm`` (the factory behind ``arm.pinocchio``)."""
    tool = arm.tool_frame if arm.source_urdf is not None else tool_link(arm)
    coupling = None
    if not arm.transmission.is_diagonal:
        coupling = arm.rotor_inertia - np.diag(np.diag(arm.rotor_inertia))
    eng = PinocchioEngine(model_for_arm(arm), friction=arm.friction_model, tool_frame=tool,
                          transmission=arm.transmission, rotor_coupling=coupling)
    eng.link_offsets = arm.urdf_link_offsets()      # link k's Jacobian at T_k = L_k S_k (.jacobian)
    return eng


def _threads() -> int:
    return max(1, min(len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1), 8))


class PinocchioEngine(PinocchioDerivatives, PinocchioJacobian):  # .derivatives, .jacobian
    """Pinocchio dynamics with the same methods and shapes as ``arm.lagrange``.

    Parameters
    ----------
    model : pin.Model
        A fixed-base model whose ``nq == nv == n`` (revolute and prismatic joints).
    friction : (2, n), Friction or None
        Viscous and Coulomb coefficients (joint side, sharp sign), or a friction
        law (:class:`manipdyn.model.drive.Friction`), applied outside the Lagrangian.
    num_threads : int or None
        Threads for batch calls (default: the CPUs available, at most 8, used only while
        they measure faster than one thread, :class:`ThreadChoice`; a number given here, or
        set later, is used as given).
    tool_frame : str or None
        The URDF frame whose pose :meth:`fkine` gives (default: the last frame of the model).
    transmission : Transmission or None
        Motors to joints: for a motor-side friction law and the regressor's
        armature columns of a coupled drive.
    rotor_coupling : (n, n) or None
        The off-diagonal part of the rotor inertia ``R^T diag(Jm) R`` (zero
        diagonal), which ``model.armature`` cannot hold (module docstring).

    Attributes
    ----------
    thread_choice : ThreadChoice
        The measured cost per state of this engine's batches on one thread and on
        :attr:`num_threads` (when the count was not given).
    """

    name = "pinocchio"

    def __init__(self, model, friction=None, num_threads=None, tool_frame: str | None = None,
                 transmission=None, rotor_coupling=None):
        self.model = model
        self.tool_frame = tool_frame if tool_frame is not None else model.frames[model.nframes - 1].name
        self.data = model.createData()
        self.n = model.nv
        # a gravity-free twin: h(q, qd) = rnea(q, qd, 0) without gravity, one call
        self._model0 = model.copy()
        self._model0.gravity.linear = np.zeros(3)
        self._data0 = self._model0.createData()
        self._zeros = np.zeros(self.n)
        self.transmission = transmission
        self.friction_model = self._law = None
        if friction is not None and hasattr(friction, "viscous_coulomb"):
            self.friction_model = friction
            legacy = friction.viscous_coulomb()
            if legacy is None:
                friction.torque(self._zeros, transmission)     # a motor-side law without R fails here
                self._law = friction
            friction = legacy
        self.friction = None
        if friction is not None and np.any(friction):
            self.friction = np.asarray(friction, dtype=np.float64)
        self._O = None
        if rotor_coupling is not None and np.any(rotor_coupling):
            O = np.array(rotor_coupling, dtype=np.float64)
            if O.shape != (self.n, self.n) or np.any(np.diag(O)) or not np.array_equal(O, O.T):
                raise ModelError(f"rotor_coupling: expected a symmetric ({self.n}, {self.n}) matrix with a zero "
                                 "diagonal (the diagonal is model.armature)")
            O.setflags(write=False)
            self._O = O
        self._num_threads = num_threads or _threads()
        self._explicit_threads = bool(num_threads)
        self.thread_choice = ThreadChoice()
        self._pool = self._pool0 = None
        # the friction at one state, shared by the derivative shortcuts, the unchecked calls and
        # the general path's single states (the same bits on all three)
        self._friction_one = None if self._law is None and self.friction is None else OneStateFriction(self)
        self.unchecked = UncheckedView(self, install_derivative_shortcuts(self))
        install_fast_path(self)

    @property
    def gravity(self) -> np.ndarray:
        return np.array(self.model.gravity.linear)

    @property
    def num_threads(self) -> int:
        """Threads used by batch calls (``rneaInParallel``, ``abaInParallel``)."""
        return self._num_threads

    @num_threads.setter
    def num_threads(self, value: int) -> None:
        value = int(value)
        if value < 1:
            raise ValueError(f"num_threads: expected a positive integer, got {value}")
        if value != self._num_threads:
            self._num_threads = value
            self._pool = self._pool0 = None  # a pool holds one Data per thread: rebuild
        self._explicit_threads = True

    def _get_pool(self):
        if self._pool is None:
            self._pool = pin.ModelPool(self.model, self._num_threads)
        return self._pool

    def _get_pool0(self):
        """Pool of the gravity-free twin model (batch h = rnea(q, qd, 0) without gravity)."""
        if self._pool0 is None:
            self._pool0 = pin.ModelPool(self._model0, self._num_threads)
        return self._pool0

    def _rnea_batch(self, pool, q, qd, qdd) -> np.ndarray:
        return self._parallel(pin.rneaInParallel, len(q), pool, q.T, qd.T, qdd.T).T.reshape(q.shape)

    def _batch_threads(self, N: int) -> int:
        """Threads for a batch of ``N`` states: 1 below :data:`PARALLEL_MIN_STATES` or in a forked
        child (``_POOL_PID``); :attr:`num_threads` when it was given; else, by default, the faster
        of one thread and :attr:`num_threads` as this engine measured them (:attr:`thread_choice`)."""
        if N < PARALLEL_MIN_STATES or self._num_threads == 1:
            return 1
        pid = os.getpid()
        if _POOL_PID[0] is None:
            _POOL_PID[0] = pid
        elif _POOL_PID[0] != pid:      # forked from the process that started the pool (see _POOL_PID)
            return 1
        return self._num_threads if self._explicit_threads else self.thread_choice.pick(self._num_threads)

    def _parallel(self, call, N: int, *args) -> np.ndarray:
        """``call(threads, *args)`` with the threads of :meth:`_batch_threads`, timed for the choice."""
        threads = self._batch_threads(N)
        if N < PARALLEL_MIN_STATES or self._explicit_threads:
            return call(threads, *args)
        t0 = _clock()
        out = call(threads, *args)
        self.thread_choice.record(threads, (_clock() - t0) / N)
        return out

    def _friction(self, qd):
        if self._law is not None:
            return self._law.torque(qd, self.transmission)
        if self.friction is None:
            return 0.0
        return self.friction[0] * qd + self.friction[1] * np.sign(qd)

    @property
    def drive_extras(self) -> bool:
        """True with coupled rotors or a friction law beyond the links' kind (the general path adds them)."""
        return self._O is not None or self._law is not None

    def _forward_coupled(self, q, qd, tau):
        """qdd from the full D = CRBA + O (ABA knows only the diagonal armature), (B, n)."""
        zeros = np.zeros(q.shape)
        D = np.array([pin.crba(self.model, self.data, qi) for qi in q]) + self._O
        rhs = tau - self._rnea_batch(self._get_pool(), q, qd, zeros)
        try:
            return np.linalg.solve(D, rhs[..., None])[..., 0]
        except np.linalg.LinAlgError:
            raise SingularMassMatrixError.for_mass_matrix(D) from None

    # -- public API ---------------------------------------------------------
    def mass_matrix(self, q) -> np.ndarray:
        """Inertia matrix D(q) by CRBA, (n, n) or (N, n, n); full and symmetric."""
        q = as_state(q, "q", self.n)
        if q.ndim == 1:
            D = _crba(self.model, self.data, q)
            return check_result(D if self._O is None else D + self._O, "mass_matrix", q=q)
        m, d = self.model, self.data
        D = np.array([pin.crba(m, d, qi) for qi in q]).reshape(len(q), self.n, self.n)
        return check_result(D if self._O is None else D + self._O, "mass_matrix", q=q)

    def coriolis_torque(self, q, qd) -> np.ndarray:
        """Coriolis and centripetal torque h(q, qd), (n,) or (N, n) (no friction)."""
        q = as_state(q, "q", self.n)
        qd = as_state(qd, "qd", self.n)
        if q.ndim == 1 and qd.ndim == 1:
            return check_result(_rnea(self._model0, self._data0, q, qd, self._zeros), "coriolis_torque",
                                q=q, qd=qd)
        same_batch((q, "q"), (qd, "qd"))
        return check_result(self._rnea_batch(self._get_pool0(), q, qd, np.zeros(q.shape)),
                            "coriolis_torque", q=q, qd=qd)

    def gravity_torque(self, q) -> np.ndarray:
        """Gravity torque g(q): the torque that holds the arm still, (n,) or (N, n)."""
        q = as_state(q, "q", self.n)
        if q.ndim == 1:
            return check_result(_gravity(self.model, self.data, q), "gravity_torque", q=q)
        zeros = np.zeros(q.shape)
        g = self._rnea_batch(self._get_pool(), q, zeros, zeros)  # g(q) = rnea(q, 0, 0)
        return check_result(g, "gravity_torque", q=q)

    def friction_torque(self, qd) -> np.ndarray:
        """Joint friction ``Fv qd + Fc sign(qd)`` (zero if none)."""
        qd = as_state(qd, "qd", self.n)
        return check_result(np.zeros_like(qd) + self._friction(qd), "friction_torque", qd=qd)

    def dynamics_terms(self, q, qd):
        """``(D, h, g)`` for one state or a batch."""
        return self.mass_matrix(q), self.coriolis_torque(q, qd), self.gravity_torque(q)

    def inverse_dynamics(self, q, qd, qdd) -> np.ndarray:
        """Joint torques by RNEA, ``tau = D qdd + h + g`` (+ friction), (n,) or (N, n)."""
        q = as_state(q, "q", self.n)
        qd = as_state(qd, "qd", self.n)
        qdd = as_state(qdd, "qdd", self.n)
        if q.ndim == 1 and qd.ndim == 1 and qdd.ndim == 1:
            tau = _rnea(self.model, self.data, q, qd, qdd)
        else:
            same_batch((q, "q"), (qd, "qd"), (qdd, "qdd"))
            tau = self._rnea_batch(self._get_pool(), q, qd, qdd)
        if self._O is not None:
            tau = tau + qdd @ self._O
        if self.friction is not None or self._law is not None:
            tau = tau + self._friction(qd)
        return check_result(tau, "inverse_dynamics", q=q, qd=qd, qdd=qdd)

    def forward_dynamics(self, q, qd, tau) -> np.ndarray:
        """Joint accelerations by ABA, solving ``D qdd = tau - h - g`` (- friction)."""
        q = as_state(q, "q", self.n)
        qd = as_state(qd, "qd", self.n)
        tau = as_state(tau, "tau", self.n)
        if self.friction is not None or self._law is not None:
            tau = tau - self._friction(qd)
        if self._O is not None:
            same_batch((q, "q"), (qd, "qd"), (tau, "tau"))
            single = q.ndim == 1
            qdd = self._forward_coupled(*(np.atleast_2d(x) for x in (q, qd, tau)))
            qdd = qdd[0] if single else qdd
        elif q.ndim == 1 and qd.ndim == 1 and tau.ndim == 1:
            qdd = _aba(self.model, self.data, q, qd, tau)
        else:
            same_batch((q, "q"), (qd, "qd"), (tau, "tau"))
            qdd = self._parallel(pin.abaInParallel, len(q), self._get_pool(), q.T, qd.T, tau.T).T.reshape(q.shape)
        if not _isfinite(np.add.reduce(qdd.reshape(-1))):
            # finite inputs, non-finite accelerations: either ABA divided by a
            # zero articulated inertia (D(q) singular: say so), or the inputs
            # were large enough to overflow (return it: the caller decides)
            D = self.mass_matrix(q if q.ndim == 2 else q[None])
            w = np.linalg.eigvalsh(D)
            if np.any(w[:, 0] <= 1e-12 * np.maximum(1.0, np.abs(w[:, -1]))):
                raise SingularMassMatrixError.for_mass_matrix(D)
        return check_result(qdd, "forward_dynamics", q=q, qd=qd, tau=tau)

    def regressor(self, q, qd, qdd, armature: bool = False, friction: bool = False) -> np.ndarray:
        """Inverse-dynamics regressor ``Y`` with ``Y @ pi = tau``, (n, p) or (N, n, p).

        The link columns are ``pin.computeJointTorqueRegressor`` (10 per body,
        Pinocchio's order, about the joint frame = the URDF link frame, with
        the model's gravity); ``armature`` appends n columns ``diag(qdd)`` and
        ``friction`` 2n columns ``diag(qd)``, ``diag(sign(qd))`` (layout:
        :mod:`manipdyn.model.parameters`).  A batch is a loop over states.
        """
        q = as_state(q, "q", self.n)
        qd = as_state(qd, "qd", self.n)
        qdd = as_state(qdd, "qdd", self.n)
        same_batch((q, "q"), (qd, "qd"), (qdd, "qdd"))
        m, d = self.model, self.data
        reg = pin.computeJointTorqueRegressor
        if q.ndim == 1:
            Y = reg(m, d, q, qd, qdd).copy()
        else:
            Y = np.empty((len(q), self.n, 10 * self.n))
            for k in range(len(q)):
                Y[k] = reg(m, d, q[k], qd[k], qdd[k])
        return with_extra_columns(Y, qd, qdd, armature, friction, self.transmission)

    def kinetic_energy(self, q, qd):
        """Kinetic energy (J), rotors included; scalar or (N,)."""
        q = as_state(q, "q", self.n)
        qd = as_state(qd, "qd", self.n)
        same_batch((q, "q"), (qd, "qd"))
        O = self._O
        if q.ndim == 1:
            K = float(pin.computeKineticEnergy(self.model, self.data, q, qd))
            K += 0.0 if O is None else 0.5 * float(qd @ O @ qd)           # the coupled rotors
            return float(check_result(np.array([K]), "kinetic_energy", q=q, qd=qd)[0])
        m, d = self.model, self.data
        K = np.array([pin.computeKineticEnergy(m, d, qi, vi) for qi, vi in zip(q, qd)])
        if O is not None:
            K = K + 0.5 * np.einsum("bi,ij,bj->b", qd, O, qd)
        return check_result(K, "kinetic_energy", q=q, qd=qd)

    def potential_energy(self, q):
        """Potential energy (J), zero at the base origin height; scalar or (N,)."""
        q = as_state(q, "q", self.n)
        if q.ndim == 1:
            P = float(pin.computePotentialEnergy(self.model, self.data, q))
            return float(check_result(np.array([P]), "potential_energy", q=q)[0])
        m, d = self.model, self.data
        P = np.array([pin.computePotentialEnergy(m, d, qi) for qi in q])
        return check_result(P, "potential_energy", q=q)

    def frame_placement(self, q, frame: str) -> np.ndarray:
        """Pose (4, 4) or (N, 4, 4) of a named URDF frame (link) in the base frame."""
        q = as_state(q, "q", self.n)
        if not isinstance(frame, str):
            raise ModelError(f"frame: expected a frame (link) name, got {type(frame).__name__}")
        fid = self.model.getFrameId(frame)
        if fid >= self.model.nframes:
            names = [f.name for f in self.model.frames]
            raise ModelError(f"frame: {frame!r} is not a frame of the model; frames are "
                             f"{', '.join(repr(n) for n in names[:20])}{' ...' if len(names) > 20 else ''}")
        m, d = self.model, self.data

        def one(qi):
            pin.framesForwardKinematics(m, d, qi)
            return d.oMf[fid].homogeneous.copy()

        if q.ndim == 1:
            return check_result(one(q), "frame_placement", q=q)
        return check_result(np.array([one(qi) for qi in q]), "frame_placement", q=q)

    def fkine(self, q) -> np.ndarray:
        """Pose of the tool frame (``self.tool_frame``: the generated URDF's ``tool`` link, DH frame n, or a
        URDF arm's tip link) in the base frame: (4, 4) or (N, 4, 4)."""
        return self.frame_placement(q, self.tool_frame)

    # -- Coriolis matrix ---------------------------------------------------------
    def coriolis_matrix(self, q, qd) -> np.ndarray:
        """Coriolis matrix ``C(q, qd)`` by ``pin.computeCoriolisMatrix``, (n, n) or (N, n, n).

        ``C qd = h`` and ``dD/dt - 2C`` is skew-symmetric (armature adds nothing).
        A copy of ``data.C`` (the next call overwrites it).
        """
        q = as_state(q, "q", self.n)
        qd = as_state(qd, "qd", self.n)
        m, d = self.model, self.data
        if q.ndim == 1 and qd.ndim == 1:
            return check_result(pin.computeCoriolisMatrix(m, d, q, qd).copy(), "coriolis_matrix", q=q, qd=qd)
        same_batch((q, "q"), (qd, "qd"))
        C = np.array([pin.computeCoriolisMatrix(m, d, qi, vi).copy()
                      for qi, vi in zip(q, qd)]).reshape(len(q), self.n, self.n)
        return check_result(C, "coriolis_matrix", q=q, qd=qd)
