"""MuJoCo as an engine of the cross-check: ``arm.engine("mujoco")`` on the arm's own MJCF.

Layer 3 (engines: mujoco).  :func:`mujoco_engine` compiles the MJCF that
:func:`manipdyn.to_mjcf` writes, with the model's own bodies (``as_published=True``: the engine
answers for the model, not for a completion of it; so a planted error in the writer shows in the cross-check)
and :class:`MujocoEngine` answers :class:`manipdyn.DynamicsEngine` with MuJoCo's own
algorithms: ``mj_fullM`` (D, rotor inertia as joint and tendon ``armature``), ``qfrc_bias``
(``h`` on a copy of the model without gravity, ``g`` at rest), ``mj_inverse`` (tau),
``mj_forward`` (qdd), the ``tool`` site (the tool pose) and ``mj_energyPos`` / ``mj_energyVel``.

What MuJoCo models differently is not passed off as MuJoCo's:

* Constraints are disabled in the engine's copy of the model (``mjDSBL_CONSTRAINT``): joint
  limits and ``frictionloss`` are constraints solved with softness, not the law's sign
  function.  The part of the friction law MuJoCo does not compute as passive damping (Coulomb,
  and the terms MJCF cannot hold) is added to ``tau`` and removed before ``qdd`` from
  manipdyn's law (``MujocoEngine.foreign_friction`` says how large it is, and the
  cross-check's notes say it); viscous friction is MuJoCo's (``qfrc_passive``).
* MuJoCo gives no Christoffel Coriolis matrix, no regressor and only finite-difference
  derivatives: :attr:`MujocoEngine.not_offered` names them, their methods raise
  :class:`~manipdyn.ModelError`, and :func:`manipdyn.crosscheck` leaves them out with a note
  (never compared loosely).
* A link MuJoCo's compiler refuses (no physical body: :func:`manipdyn.formats.losses.nonphysical_inertias`)
  is compiled with a stand-in inertial and then given the model's exact mass, COM and principal
  inertia in the compiled model (``body_mass``, ``body_ipos``, ``body_iquat``, ``body_inertia``),
  which MuJoCo's algorithms take as they are; ``MujocoEngine.notes`` says so.

Shapes: one state (n,) or a batch (N, n); batches are looped in Python over one ``MjData`` per
thread.  Units SI, base frame = MuJoCo's world frame.
"""

from __future__ import annotations

import threading

import numpy as np

from ..._support.errors import ModelError, SingularMassMatrixError
from ..._support.state import as_state, check_result, same_batch
from ...formats.losses import friction_difference, friction_held, nonphysical_inertias
from ...formats.mjcf import TOOL_SITE, arm_to_mjcf, quaternion
from ...model.friction import Friction
from .deps import mujoco_module

__all__ = ["MujocoEngine", "mujoco_engine", "NOT_OFFERED"]

#: the cross-check's quantities MuJoCo does not compute, and why
NOT_OFFERED = {
    "C": "MuJoCo computes C(q, qd) qd (qfrc_bias), not the Christoffel matrix C",
    "Y": "MuJoCo's bodies hold mass, COM and principal inertia, not the linear parameters of tau = Y pi",
    "dtau_dq": "MuJoCo's derivatives of inverse dynamics are finite differences (mjd_inverseFD), "
               "good to about 1e-6, not 1e-10",
    "dtau_dqd": "as dtau_dq (mjd_inverseFD)", "dg_dq": "as dtau_dq (mjd_inverseFD)",
    "dqdd_dq": "MuJoCo's derivatives of forward dynamics are finite differences (mjd_transitionFD)",
    "dqdd_dqd": "as dqdd_dq (mjd_transitionFD)",
    "J": "not asked of MuJoCo here (mj_jacSite exists; the tool pose is compared)",
    "Jdot": "not asked of MuJoCo here",
}


def _stand_in(text: str, bodies) -> str:
    """``text`` with the inertials of the body indices ``bodies`` (1-based body ids) replaced by a
    unit stand-in MuJoCo's compiler accepts."""
    from lxml import etree

    root = etree.fromstring(text.encode("utf-8"))
    all_bodies = root.find("worldbody").iter("body")
    for k, body in enumerate(all_bodies, 1):
        if k in bodies:
            inertial = body.find("inertial")
            for attr in ("fullinertia", "diaginertia", "quat"):
                inertial.attrib.pop(attr, None)
            inertial.set("mass", "1")
            inertial.set("diaginertia", "1 1 1")
    return etree.tostring(root, encoding="unicode")


def mujoco_engine(arm) -> "MujocoEngine":
    """The MuJoCo engine of ``arm`` (the factory behind ``arm.engine("mujoco")``)."""
    return MujocoEngine(arm)


class MujocoEngine:
    """MuJoCo's dynamics of ``arm``'s MJCF behind :class:`manipdyn.DynamicsEngine` (module docstring).

    Attributes
    ----------
    mjcf : str
        The MJCF text compiled (``md.to_mjcf(arm, as_published=True)``).
    model : mujoco.MjModel
        The compiled model, constraints disabled (limits and frictionloss).
    notes : list of str
        What of the arm is not MuJoCo's own computation here.
    foreign_friction : (n,)
        Largest friction torque per joint that manipdyn's law adds (N m or N) over the
        cross-check's velocity range; zeros when MuJoCo's damping is the whole law.
    """

    name = "mujoco"
    not_offered = NOT_OFFERED

    def __init__(self, arm):
        mj = self._mj = mujoco_module()
        self.n = arm.n
        self.mjcf = arm_to_mjcf(arm, warn=False, as_published=True)   # the model's own bodies
        bad = nonphysical_inertias(arm)
        text = self.mjcf if not bad else _stand_in(self.mjcf, {k + 1 for k, _name, _why in bad})
        try:
            m = mj.MjModel.from_xml_string(text)
        except ValueError as exc:
            raise ModelError(f"the 'mujoco' engine: MuJoCo refuses the MJCF of {arm.name!r}: "
                             f"{str(exc).splitlines()[0]}") from None
        self.notes = []
        joints, _tool = arm.chain()
        for k, lname, why in bad:
            b = joints[k].body
            I = np.asarray(b.inertia, dtype=np.float64)
            w, V = np.linalg.eigh(0.5 * (I + I.T))
            if np.linalg.det(V) < 0:
                V[:, 0] = -V[:, 0]
            m.body_mass[k + 1] = b.mass
            m.body_ipos[k + 1] = b.com
            m.body_iquat[k + 1] = quaternion(V)
            m.body_inertia[k + 1] = w
            self.notes.append(f"mujoco: link {lname!r} is no physical body ({why}); MuJoCo's compiler refuses it, "
                              "so the engine compiled a stand-in and set the model's exact inertia in the compiled model")
        self._file_model = mj.MjModel.from_xml_string(text)   # constraints as the file has them (simulation)
        for field in ("body_mass", "body_ipos", "body_iquat", "body_inertia"):
            getattr(self._file_model, field)[:] = getattr(m, field)
        mj.mj_setConst(self._file_model, mj.MjData(self._file_model))
        m.opt.disableflags |= int(mj.mjtDisableBit.mjDSBL_CONSTRAINT)
        m.opt.enableflags |= int(mj.mjtEnableBit.mjENBL_ENERGY)
        m0 = mj.MjModel.from_xml_string(text)          # the same model without gravity: h alone
        for field in ("body_mass", "body_ipos", "body_iquat", "body_inertia"):
            getattr(m0, field)[:] = getattr(m, field)
        m0.opt.disableflags = m.opt.disableflags
        m0.opt.gravity[:] = 0.0
        self.model, self._m0 = m, m0
        for mm in (m, m0):
            mm_data = mj.MjData(mm)
            mj.mj_setConst(mm, mm_data)
        self._site = mj.mj_name2id(m, mj.mjtObj.mjOBJ_SITE, TOOL_SITE)
        self._local = threading.local()
        # friction: MuJoCo's passive damping is the viscous part; manipdyn's law adds the rest
        law, self._transmission = arm.friction_model, arm.transmission
        self._foreign = None
        self.foreign_friction = np.zeros(self.n)
        if law is not None:
            held, _words = friction_held(arm, "mjcf")
            fv = held.viscous if held is not None and held.viscous is not None else np.zeros(self.n)
            self._damping_law = Friction(viscous=fv, side=law.side, smoothing=0.0)
            self._law = law
            self.foreign_friction = friction_difference(arm, self._damping_law)
            if np.any(self.foreign_friction):
                self._foreign = law
                self.notes.append(
                    f"mujoco: friction other than viscous ({', '.join(t for t in law.terms if t != 'viscous')}) is "
                    "a constraint (frictionloss) or not held in MuJoCo; the engine adds manipdyn's law for it to tau "
                    f"and qdd (up to {float(self.foreign_friction.max()):.3g} N m), so that part is not compared")

    def simulation_model(self, timestep: float, integrator: str = "RK4"):
        """``(mujoco, model)``: a fresh copy of the compiled MJCF as a MuJoCo user has it (joint
        limits and frictionloss active; exact inertias where the compiler refused the file's), with
        ``opt.timestep`` (s) and ``opt.integrator`` (a ``mjtIntegrator`` name without ``mjINT_``:
        ``"RK4"``, ``"EULER"``, ``"IMPLICIT"``, ``"IMPLICITFAST"``) set."""
        import copy

        mj = self._mj
        names = {"RK4": mj.mjtIntegrator.mjINT_RK4, "EULER": mj.mjtIntegrator.mjINT_EULER,
                 "IMPLICIT": mj.mjtIntegrator.mjINT_IMPLICIT, "IMPLICITFAST": mj.mjtIntegrator.mjINT_IMPLICITFAST}
        key = str(integrator).upper()
        if key not in names:
            raise ModelError(f"integrator: expected one of {', '.join(names)}, got {integrator!r:.40}")
        if not (isinstance(timestep, (int, float)) and timestep > 0):
            raise ModelError(f"timestep: expected a positive number of seconds, got {timestep!r:.40}")
        m = copy.deepcopy(self._file_model)
        m.opt.timestep = float(timestep)
        m.opt.integrator = int(names[key])
        return mj, m

    # -- MuJoCo data, one per thread ----------------------------------------------------
    def _data(self, zero_gravity=False):
        loc = self._local
        if not hasattr(loc, "d"):
            loc.d = self._mj.MjData(self.model)
            loc.d0 = self._mj.MjData(self._m0)
        return (self._m0, loc.d0) if zero_gravity else (self.model, loc.d)

    def _states(self, *named):
        arrs = [as_state(x, nm, self.n) for x, nm in named]
        if len(arrs) > 1 and any(a.shape != arrs[0].shape for a in arrs):
            same_batch(*zip(arrs, (nm for _, nm in named)))
        return arrs

    def _each(self, fn, *arrs):
        """``fn(*rows)`` for each row of the batch (or the single state)."""
        if arrs[0].ndim == 1:
            return fn(*arrs)
        return np.array([fn(*rows) for rows in zip(*arrs)]) if len(arrs[0]) else np.empty((0,))

    def friction_beyond_damping(self, qd):
        """The friction torque of the arm's law beyond what MuJoCo computes as passive damping
        (Coulomb, and the terms MJCF cannot hold): (n,) or (N, n), N m (N); what this engine adds
        to ``tau`` (and the MuJoCo simulator of the whole model, :mod:`manipdyn.control.mjsim`)."""
        if self._foreign is None:
            return np.zeros_like(qd)
        return (self._law.torque(qd, self._transmission)
                - self._damping_law.torque(qd, self._transmission))

    def _position(self, q, zero_gravity=False):
        m, d = self._data(zero_gravity)
        d.qpos[:] = q
        d.qvel[:] = 0.0
        self._mj.mj_fwdPosition(m, d)
        return m, d

    # -- the DynamicsEngine methods ------------------------------------------------------
    def mass_matrix(self, q) -> np.ndarray:
        """D(q) (rotors included: joint and tendon armature): (n, n) or (N, n, n), kg m^2 (``mj_fullM``)."""
        (q,) = self._states((q, "q"))

        def one(qi):
            m, d = self._position(qi)
            M = np.zeros((self.n, self.n))
            self._mj.mj_fullM(m, d, M)
            return M
        return check_result(self._each(one, q).reshape(q.shape[:-1] + (self.n, self.n)), "mass_matrix", q=q)

    def _bias(self, q, qd, zero_gravity):
        def one(qi, qdi):
            m, d = self._data(zero_gravity)
            d.qpos[:] = qi
            d.qvel[:] = qdi
            self._mj.mj_fwdPosition(m, d)
            self._mj.mj_fwdVelocity(m, d)
            return d.qfrc_bias.copy()
        return self._each(one, q, qd).reshape(q.shape)

    def coriolis_torque(self, q, qd) -> np.ndarray:
        """h(q, qd) = C qd: (n,) or (N, n), N m (``qfrc_bias`` of the model without gravity)."""
        q, qd = self._states((q, "q"), (qd, "qd"))
        return check_result(self._bias(q, qd, True), "coriolis_torque", q=q, qd=qd)

    def gravity_torque(self, q) -> np.ndarray:
        """g(q): (n,) or (N, n), N m (``qfrc_bias`` at rest)."""
        (q,) = self._states((q, "q"))
        return check_result(self._bias(q, np.zeros_like(q), False), "gravity_torque", q=q)

    def friction_torque(self, qd) -> np.ndarray:
        """The friction law at the joints: (n,) or (N, n), N m.  The viscous part is MuJoCo's
        damping (``-qfrc_passive``, joint and tendon ``damping``); the rest is manipdyn's law."""
        (qd,) = self._states((qd, "qd"))

        def one(qdi):
            m, d = self._data()
            d.qpos[:] = 0.0
            d.qvel[:] = qdi
            self._mj.mj_fwdPosition(m, d)
            self._mj.mj_fwdVelocity(m, d)
            return -d.qfrc_passive.copy()
        out = self._each(one, qd).reshape(qd.shape) + self.friction_beyond_damping(qd)
        return check_result(out, "friction_torque", qd=qd)

    def dynamics_terms(self, q, qd) -> tuple:
        """``(D, h, g)`` (shapes as above)."""
        return self.mass_matrix(q), self.coriolis_torque(q, qd), self.gravity_torque(q)

    def inverse_dynamics(self, q, qd, qdd) -> np.ndarray:
        """tau = D qdd + h + g + friction: (n,) or (N, n), N m (``mj_inverse``'s ``qfrc_inverse``,
        plus the friction MuJoCo holds as a constraint or not at all, from manipdyn's law)."""
        q, qd, qdd = self._states((q, "q"), (qd, "qd"), (qdd, "qdd"))

        def one(qi, qdi, qddi):
            m, d = self._data()
            d.qpos[:], d.qvel[:], d.qacc[:] = qi, qdi, qddi
            self._mj.mj_inverse(m, d)
            return d.qfrc_inverse.copy()
        out = self._each(one, q, qd, qdd).reshape(q.shape) + self.friction_beyond_damping(qd)
        return check_result(out, "inverse_dynamics", q=q, qd=qd, qdd=qdd)

    def forward_dynamics(self, q, qd, tau) -> np.ndarray:
        """qdd solving D qdd = tau - h - g - friction: (n,) or (N, n) (``mj_forward``'s ``qacc``
        with ``tau`` less manipdyn's part of the friction as ``qfrc_applied``)."""
        q, qd, tau = self._states((q, "q"), (qd, "qd"), (tau, "tau"))
        applied = tau - self.friction_beyond_damping(qd)

        def one(qi, qdi, ti):
            m, d = self._data()
            d.qpos[:], d.qvel[:], d.qfrc_applied[:] = qi, qdi, ti
            d.ctrl[:] = 0.0
            self._mj.mj_forward(m, d)
            return d.qacc.copy()
        qdd = self._each(one, q, qd, applied).reshape(q.shape)
        if not np.all(np.isfinite(qdd)):
            D = self.mass_matrix(q if q.ndim == 2 else q[None])
            raise SingularMassMatrixError.for_mass_matrix(D)
        return qdd

    def kinetic_energy(self, q, qd):
        """K = qd^T D qd / 2 (J), rotors included (``mj_energyVel``); float or (N,)."""
        q, qd = self._states((q, "q"), (qd, "qd"))

        def one(qi, qdi):
            m, d = self._data()
            d.qpos[:], d.qvel[:] = qi, qdi
            self._mj.mj_fwdPosition(m, d)
            self._mj.mj_energyVel(m, d)
            return d.energy[1]
        K = self._each(one, q, qd)
        return float(K) if q.ndim == 1 else np.asarray(K, dtype=np.float64).reshape(q.shape[0])

    def potential_energy(self, q):
        """P = -sum m_i g^T c_i (J), zero at the base origin's height (``mj_energyPos``); float or (N,)."""
        (q,) = self._states((q, "q"))

        def one(qi):
            m, d = self._position(qi)
            self._mj.mj_energyPos(m, d)
            return d.energy[0]
        P = self._each(one, q)
        return float(P) if q.ndim == 1 else np.asarray(P, dtype=np.float64).reshape(q.shape[0])

    def fkine(self, q) -> np.ndarray:
        """The ``tool`` site's pose in the world (base) frame: (4, 4) or (N, 4, 4), metres."""
        (q,) = self._states((q, "q"))

        def one(qi):
            m, d = self._data()
            d.qpos[:] = qi
            self._mj.mj_kinematics(m, d)
            T = np.eye(4)
            T[:3, :3] = d.site_xmat[self._site].reshape(3, 3)
            T[:3, 3] = d.site_xpos[self._site]
            return T
        return check_result(self._each(one, q).reshape(q.shape[:-1] + (4, 4)), "fkine", q=q)

    def friction_derivative(self, qd) -> np.ndarray:
        """``dF/dqd``: (n, n) or (N, n, n).  MuJoCo's damping (joint ``dof_damping`` and tendon
        ``damping R_k R_k^T``) plus the derivative of manipdyn's part of the law."""
        (qd,) = self._states((qd, "qd"))
        m = self.model
        B = np.diag(np.asarray(m.dof_damping, dtype=np.float64))
        for t in range(m.ntendon):
            r = np.zeros(self.n)
            for w in range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t]):
                r[m.wrap_objid[w]] = m.wrap_prm[w]
            B = B + m.tendon_damping[t] * np.outer(r, r)
        out = np.broadcast_to(B, qd.shape[:-1] + (self.n, self.n)).copy()
        if self._foreign is not None:
            out = out + (self._law.derivative(qd, self._transmission)
                         - self._damping_law.derivative(qd, self._transmission))
        return out

    # -- what MuJoCo does not give (NOT_OFFERED) -----------------------------------------
    def _refuse(self, key, method):
        raise ModelError(f"the 'mujoco' engine has no {method}: {NOT_OFFERED[key]}; use arm.pinocchio.{method}")

    def coriolis_matrix(self, q, qd):
        """Not offered (:data:`NOT_OFFERED`): raises :class:`~manipdyn.ModelError`."""
        self._refuse("C", "coriolis_matrix")

    def regressor(self, q, qd, qdd, armature: bool = False, friction=False):
        """Not offered (:data:`NOT_OFFERED`): raises :class:`~manipdyn.ModelError`."""
        self._refuse("Y", "regressor")

    def inverse_dynamics_derivatives(self, q, qd, qdd):
        """Not offered (:data:`NOT_OFFERED`): raises :class:`~manipdyn.ModelError`."""
        self._refuse("dtau_dq", "inverse_dynamics_derivatives")

    def forward_dynamics_derivatives(self, q, qd, tau):
        """Not offered (:data:`NOT_OFFERED`): raises :class:`~manipdyn.ModelError`."""
        self._refuse("dqdd_dq", "forward_dynamics_derivatives")

    def gravity_derivative(self, q):
        """Not offered (:data:`NOT_OFFERED`): raises :class:`~manipdyn.ModelError`."""
        self._refuse("dg_dq", "gravity_derivative")
