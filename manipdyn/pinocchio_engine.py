"""The fast path: Pinocchio's RNEA, CRBA and ABA on the arm's URDF.

Layer 4 (engines).  Shares no code with the trace form (:mod:`manipdyn.lagrange`).

The model is built from URDF text with ``pinocchio.buildModelFromXML`` (no
temporary files).  Each engine owns its ``pin.Data``: an engine is not meant
to be shared between threads; batch calls use Pinocchio's own thread pool.

Every method takes one state ``(n,)`` or a batch ``(N, n)`` and returns a
new array of the same leading shape (SI units, joint order of the chain).
"""

from __future__ import annotations

import functools
import math
import os

import numpy as np
import pinocchio as pin

from ._state import as_state, check_result, same_batch
from .errors import ModelError, SingularMassMatrixError
from .parameters import with_extra_columns
from .pinocchio_agree import check_same_arm
from .pinocchio_derivatives import PinocchioDerivatives
from .urdf_out import TOOL_LINK, arm_to_urdf

_isfinite = math.isfinite
_F64 = np.dtype(np.float64)  # native byte order: '>f8' is another object
_ND = np.ndarray  # exactly: a masked array's data would reach Pinocchio without its mask
_crba, _rnea, _aba, _gravity = pin.crba, pin.rnea, pin.aba, pin.computeGeneralizedGravity

#: below this many states a batch runs on one thread (thread start-up costs
#: more than it saves on small batches)
PARALLEL_MIN_STATES = 2048


# Single-state calls are the hot path of control loops, so they get shortcuts
# (see ``_install_fast_path``), installed per engine as closures: no method
# frame, no attribute look-ups.  A shortcut is taken only for plain 1-D
# ndarrays of native float64 (``dtype is float64``: a big-endian or any other
# dtype, a subclass such as a masked array, or another rank goes down the
# general path, which converts or refuses it).  Pinocchio itself rejects a
# wrong length (the general path then explains the error), and eigenpy reads
# strided 1-D arrays correctly (tests/test_fast_path_dtypes.py proves both).
#
# Finiteness is read off the answer, which is cheaper than testing the inputs
# (``item`` of one element against ``sum(x.tolist())``): a NaN or inf anywhere in
# (q, qd, qdd) or (q, qd, tau) reaches the first entry of the RNEA/ABA answer,
# because every body's motion is carried through the dense transforms of the
# joints before it and every body's force back through those to joint 1
# (IEEE: 0 * NaN is NaN, 0 * inf is NaN).  D(q) and g(q) do not depend on q_1,
# but q_2..q_n reach D_11 and g_1 (the composite body beyond joint 1), so there
# ``D_11 * q_1`` is tested (a product that overflows only sends the call down
# the general path).  tests/test_fast_path_dtypes.py puts NaN and inf in every
# entry of every argument on DH and URDF arms, revolute and prismatic.  A
# non-finite answer, or any error, sends the call down the general path, which
# names the offending argument.
_FAST_ERRORS = (AttributeError, TypeError, ValueError)


def model_from_urdf(urdf_text: str, gravity, armature=None) -> "pin.Model":
    """Build a fixed-base ``pin.Model`` from URDF text, with the given gravity (m/s^2)."""
    model = pin.buildModelFromXML(urdf_text)
    model.gravity.linear = np.asarray(gravity, dtype=np.float64)
    if armature is not None:
        model.armature = np.asarray(armature, dtype=np.float64)
    return model


def model_for_arm(arm) -> "pin.Model":
    """Pinocchio's model of ``arm``: from the original URDF text when the arm came
    from a file (reduced by locking its off-chain joints at ``pin.neutral``, 0),
    otherwise from the URDF generated from the arm's chain."""
    where = getattr(arm, "source", "") or arm.name or "arm"
    if arm.source_urdf is None:
        model = model_from_urdf(arm_to_urdf(arm), arm.gravity, arm.armature)
        check_same_arm(model, arm, where)
        return model
    try:
        model = pin.buildModelFromXML(arm.source_urdf)
    except (RuntimeError, ValueError) as exc:
        msg = " ".join(str(exc).split())
        raise ModelError(f"{where}: Pinocchio's URDF reader (urdfdom) refuses the file that manipdyn "
                         f"read: {msg}") from None
    if arm.locked_joints:
        ids = []
        for nm in arm.locked_joints:
            if not model.existJointName(nm):
                raise ModelError(f"{where}: Pinocchio's model has no joint {nm!r} to lock")
            ids.append(model.getJointId(nm))
        model = pin.buildReducedModel(model, ids, pin.neutral(model))
    check_same_arm(model, arm, where)  # both readers must read the same arm (joints, order, nq, ...)
    model.gravity.linear = np.array(arm.gravity)
    model.armature = np.array(arm.armature)
    return model


def pinocchio_engine(arm) -> "PinocchioEngine":
    """The Pinocchio engine of ``arm`` (the factory behind ``arm.pinocchio``)."""
    tool = arm.tool_frame if arm.source_urdf is not None else TOOL_LINK
    return PinocchioEngine(model_for_arm(arm), friction=arm.friction, tool_frame=tool)


def _threads() -> int:
    return max(1, min(len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1), 8))


class PinocchioEngine(PinocchioDerivatives):  # derivatives: manipdyn.pinocchio_derivatives
    """Pinocchio dynamics with the same methods and shapes as ``arm.lagrange``.

    Parameters
    ----------
    model : pin.Model
        A fixed-base model whose ``nq == nv == n`` (revolute and prismatic joints).
    friction : (2, n) or None
        Viscous and Coulomb coefficients applied outside the Lagrangian, the
        same way as in the trace-form engine.
    num_threads : int or None
        Threads for batch calls (default: the CPUs available, at most 8).
    tool_frame : str or None
        The URDF frame whose pose :meth:`fkine` gives (default: the last frame of the model).
    """

    name = "pinocchio"

    def __init__(self, model, friction=None, num_threads=None, tool_frame: str | None = None):
        self.model = model
        self.tool_frame = tool_frame if tool_frame is not None else model.frames[model.nframes - 1].name
        self.data = model.createData()
        self.n = model.nv
        # a gravity-free twin: h(q, qd) = rnea(q, qd, 0) without gravity, one call
        self._model0 = model.copy()
        self._model0.gravity.linear = np.zeros(3)
        self._data0 = self._model0.createData()
        self._zeros = np.zeros(self.n)
        self.friction = None
        if friction is not None and np.any(friction):
            self.friction = np.asarray(friction, dtype=np.float64)
        self._num_threads = num_threads or _threads()
        self._pool = self._pool0 = None
        self.unchecked = UncheckedView(self)
        _install_fast_path(self)

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
        return pin.rneaInParallel(self._batch_threads(len(q)), pool, q.T, qd.T, qdd.T).T.reshape(q.shape)

    def _batch_threads(self, N: int) -> int:
        return self._num_threads if N >= PARALLEL_MIN_STATES else 1

    def _friction(self, qd):
        if self.friction is None:
            return 0.0
        return self.friction[0] * qd + self.friction[1] * np.sign(qd)

    # -- public API ---------------------------------------------------------
    def mass_matrix(self, q) -> np.ndarray:
        """Inertia matrix D(q) by CRBA, (n, n) or (N, n, n); full and symmetric."""
        q = as_state(q, "q", self.n)
        if q.ndim == 1:
            return check_result(_crba(self.model, self.data, q), "mass_matrix", q=q)
        m, d = self.model, self.data
        D = np.array([pin.crba(m, d, qi) for qi in q]).reshape(len(q), self.n, self.n)
        return check_result(D, "mass_matrix", q=q)

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
        if self.friction is not None:
            tau = tau + self._friction(qd)
        return check_result(tau, "inverse_dynamics", q=q, qd=qd, qdd=qdd)

    def forward_dynamics(self, q, qd, tau) -> np.ndarray:
        """Joint accelerations by ABA, solving ``D qdd = tau - h - g`` (- friction)."""
        q = as_state(q, "q", self.n)
        qd = as_state(qd, "qd", self.n)
        tau = as_state(tau, "tau", self.n)
        if self.friction is not None:
            tau = tau - self._friction(qd)
        if q.ndim == 1 and qd.ndim == 1 and tau.ndim == 1:
            qdd = _aba(self.model, self.data, q, qd, tau)
        else:
            same_batch((q, "q"), (qd, "qd"), (tau, "tau"))
            qdd = pin.abaInParallel(self._batch_threads(len(q)), self._get_pool(),
                                    q.T, qd.T, tau.T).T.reshape(q.shape)
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
        :mod:`manipdyn.parameters`).  A batch is a loop over states.
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
        return with_extra_columns(Y, qd, qdd, armature, friction)

    def kinetic_energy(self, q, qd):
        """Kinetic energy (J), rotors included; scalar or (N,)."""
        q = as_state(q, "q", self.n)
        qd = as_state(qd, "qd", self.n)
        same_batch((q, "q"), (qd, "qd"))
        if q.ndim == 1:
            K = float(pin.computeKineticEnergy(self.model, self.data, q, qd))
            return float(check_result(np.array([K]), "kinetic_energy", q=q, qd=qd)[0])
        m, d = self.model, self.data
        K = np.array([pin.computeKineticEnergy(m, d, qi, vi) for qi, vi in zip(q, qd)])
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
        """The tool frame's pose in the base frame: (4, 4) or (N, 4, 4)."""
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


def _install_fast_path(eng: PinocchioEngine) -> None:
    """Shadow the five dynamics methods of ``eng`` by closures with a single-state shortcut.

    Each closure falls back to the class's method (the general path) for
    anything but plain native-float64 ndarrays with finite values (module
    comment above ``_FAST_ERRORS``).  Same names, signatures and docstrings.
    """
    cls = type(eng)
    model, data, model0, data0, zeros = eng.model, eng.data, eng._model0, eng._data0, eng._zeros
    ND, F64, isf, errors = _ND, _F64, _isfinite, _FAST_ERRORS
    crba, rnea, aba, grav = _crba, _rnea, _aba, _gravity
    g_mass, g_cor, g_grav, g_id, g_fd = (getattr(cls, nm).__get__(eng) for nm in (
        "mass_matrix", "coriolis_torque", "gravity_torque", "inverse_dynamics", "forward_dynamics"))

    def state_only(call, model, data, general):
        # D and g do not depend on q_1: q_1's finiteness is read off the product
        def f(q):
            try:
                if type(q) is ND and q.dtype is F64 and q.ndim == 1:
                    r = call(model, data, q)
                    # q_2..q_n non-finite -> r_1 non-finite; q_1 (no effect on D or g) by the product
                    if isf(r.item(0) * q.item(0)):
                        return r
            except errors:
                pass
            return general(q)
        return f

    def three_states(call, model, data, general):
        # RNEA / ABA: a NaN or inf in any argument reaches the first output
        def f(q, qd, x):
            try:
                if (type(q) is type(qd) is type(x) is ND and q.dtype is qd.dtype is x.dtype is F64
                        and q.ndim == qd.ndim == x.ndim == 1):
                    r = call(model, data, q, qd, x)
                    if isf(r.item(0)):
                        return r
            except errors:
                pass
            return general(q, qd, x)
        return f

    def coriolis_torque(q, qd):
        try:
            if (type(q) is type(qd) is ND and q.dtype is qd.dtype is F64
                    and q.ndim == qd.ndim == 1):
                h = rnea(model0, data0, q, qd, zeros)
                if isf(h.item(0)):
                    return h
        except errors:
            pass
        return g_cor(q, qd)

    mass_matrix = state_only(crba, model, data, g_mass)
    gravity_torque = state_only(grav, model, data, g_grav)
    inverse_dynamics = three_states(rnea, model, data, g_id)
    forward_dynamics = three_states(aba, model, data, g_fd)

    fast = {"mass_matrix": mass_matrix, "coriolis_torque": coriolis_torque,
            "gravity_torque": gravity_torque}
    if eng.friction is None:  # with friction, the general path adds it
        fast.update(inverse_dynamics=inverse_dynamics, forward_dynamics=forward_dynamics)
    for name, fn in fast.items():
        fn.__doc__ = getattr(cls, name).__doc__
        fn.__qualname__ = f"{cls.__name__}.{name}"
        eng.__dict__[name] = fn


class UncheckedView:
    """``engine.unchecked``: the same single-state calls with no validation at all.

    For hot loops that have validated their inputs once (like MuJoCo's
    ``skip_checks``).  Each attribute is Pinocchio's function with the model
    and data bound (``functools.partial``), so a call costs what the raw
    ``pin.rnea`` / ``pin.crba`` costs.  The contract is the caller's:

    * one state at a time, ``(n,)`` ndarrays of native float64 (a big-endian
      or integer array is NOT converted: the answer may be silently wrong);
    * NaN and inf are not detected and propagate into the answer;
    * a wrong size raises Pinocchio's own error (not a :class:`StateError`);
    * the returned array is new (caller-owned), as with the checked path.

    Attributes: ``mass_matrix(q)``, ``coriolis_torque(q, qd)``,
    ``gravity_torque(q)``, ``inverse_dynamics(q, qd, qdd)``,
    ``forward_dynamics(q, qd, tau)``, with the engine's friction applied as
    in the checked path.
    """

    def __init__(self, eng: PinocchioEngine):
        model, data, model0, data0, zeros = eng.model, eng.data, eng._model0, eng._data0, eng._zeros
        self.n = eng.n
        self.mass_matrix = functools.partial(_crba, model, data)
        self.gravity_torque = functools.partial(_gravity, model, data)

        def coriolis_torque(q, qd):
            return _rnea(model0, data0, q, qd, zeros)

        self.coriolis_torque = coriolis_torque
        fr = eng.friction
        if fr is None:
            self.inverse_dynamics = functools.partial(_rnea, model, data)
            self.forward_dynamics = functools.partial(_aba, model, data)
        else:
            fv, fc = fr[0].copy(), fr[1].copy()
            sign = np.sign

            def inverse_dynamics(q, qd, qdd):
                return _rnea(model, data, q, qd, qdd) + (fv * qd + fc * sign(qd))

            def forward_dynamics(q, qd, tau):
                return _aba(model, data, q, qd, tau - (fv * qd + fc * sign(qd)))

            self.inverse_dynamics = inverse_dynamics
            self.forward_dynamics = forward_dynamics

    def __repr__(self) -> str:
        return f"<unchecked Pinocchio calls, {self.n} joints>"
