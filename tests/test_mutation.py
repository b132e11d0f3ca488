"""Mutation tests: the cross-check has teeth.

Each test corrupts the URDF that the Pinocchio engine is built from, in one of
the ways converters have been known to go wrong, and asserts that
``crosscheck`` reports the disagreement (and that the clean URDF passes).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from lxml import etree

import manipdyn as md
from manipdyn.engines.pinocchio.engine import PinocchioEngine, model_from_urdf

SAMPLES = 50


def _arm():
    """Standard-DH arm with full (non-diagonal) inertia tensors and offset COMs."""
    rng = np.random.default_rng(7)
    links = []
    for i in range(4):
        A = rng.normal(size=(3, 3))
        R, _ = np.linalg.qr(A)
        I = R @ np.diag(rng.uniform([0.02, 0.03, 0.04], [0.03, 0.04, 0.05])) @ R.T
        links.append(md.DHLink(a=0.2 + 0.05 * i, alpha=(-1) ** i * 0.9, d=0.1, theta=0.3 * i,
                               mass=2.0 - 0.3 * i, com=rng.uniform(-0.1, 0.1, 3), inertia=I))
    return md.Manipulator(links, convention="standard", name="mutant")


def _with_urdf(arm, text):
    arm.set_engine("pinocchio", PinocchioEngine(model_from_urdf(text, arm.gravity, arm.armature),
                                                tool_frame="tool"))
    return arm


def _mutate(text, fn):
    root = etree.fromstring(text.encode())
    fn(root)
    return etree.tostring(root).decode()


def test_clean_urdf_passes():
    assert md.crosscheck(_arm(), samples=SAMPLES).ok


def test_flipped_product_of_inertia_is_caught():
    def flip(root):
        el = root.find("link[@name='link2']/inertial/inertia")
        el.set("ixy", repr(-float(el.get("ixy"))))

    arm = _with_urdf(_arm(), _mutate(md.to_urdf(_arm()), flip))
    report = md.crosscheck(arm, samples=SAMPLES)
    assert not report.ok
    assert not report["D"].ok and not report["tau"].ok


def test_com_in_wrong_frame_is_caught():
    """COM written in DH frame i coordinates instead of the URDF link frame."""
    base = _arm()

    def wrong(root):
        for i, l in enumerate(base.links):
            el = root.find(f"link[@name='link{i + 1}']/inertial/origin")
            el.set("xyz", " ".join(repr(float(c)) for c in l.com))

    report = md.crosscheck(_with_urdf(_arm(), _mutate(md.to_urdf(base), wrong)), samples=SAMPLES)
    assert not report.ok
    assert not report["g"].ok and not report["D"].ok


def test_inertia_about_origin_instead_of_com_is_caught():
    base = _arm()
    joints, _ = base.chain()

    def about_origin(root):
        for i, j in enumerate(joints):
            el = root.find(f"link[@name='link{i + 1}']/inertial/inertia")
            I = j.body.inertia_about_origin()
            for key, (r, c) in {"ixx": (0, 0), "iyy": (1, 1), "izz": (2, 2),
                                "ixy": (0, 1), "ixz": (0, 2), "iyz": (1, 2)}.items():
                el.set(key, repr(float(I[r, c])))

    report = md.crosscheck(_with_urdf(_arm(), _mutate(md.to_urdf(base), about_origin)), samples=SAMPLES)
    assert not report.ok
    assert not report["D"].ok
    assert report["g"].ok  # gravity depends on mass and COM only: the check localises the bug


def test_flipped_joint_axis_is_caught():
    def flip(root):
        el = root.find("joint[@name='joint2']/axis")
        el.set("xyz", "0.0 0.0 -1.0")

    report = md.crosscheck(_with_urdf(_arm(), _mutate(md.to_urdf(_arm()), flip)), samples=SAMPLES)
    assert not report.ok
    assert not report["fk"].ok


def test_nan_from_an_engine_is_a_disagreement():
    """A NaN never passes as agreement."""
    arm = _arm()
    eng = arm.pinocchio
    real = eng.gravity_torque

    class Broken:
        def __getattr__(self, name):
            return getattr(eng, name)

        def gravity_torque(self, q):
            g = np.array(real(q), dtype=float)
            g[..., 0] = np.nan
            return g

    arm.set_engine("pinocchio", Broken())
    report = md.crosscheck(arm, samples=10)
    assert not report["g"].ok and math.isinf(report["g"].max_rel)


# -- the regressor: a planted bug in either engine's Y is caught -------------------

def test_trace_form_regressor_in_dh_frames_is_caught():
    """The trace-form regressor with its parameters about DH frame i instead of
    the URDF link frame (the offsets S_i forgotten): tau, D, g still agree."""
    from manipdyn.engines.lagrange.engine import TraceFormEngine

    arm = _arm()
    kin, J, armature, friction = arm.trace_form_data()
    arm.set_engine("lagrange", TraceFormEngine(kin, J, arm.gravity, armature=armature,
                                               friction=friction, link_offsets=None))
    report = md.crosscheck(arm, samples=SAMPLES)
    assert not report["Y"].ok
    assert report["tau"].ok and report["D"].ok


def test_pinocchio_regressor_with_swapped_products_of_inertia_is_caught():
    """Pinocchio's columns read in another library's order (Ixy and Ixz swapped)."""
    arm = _arm()
    eng = arm.pinocchio
    real = eng.regressor

    class Swapped:
        def __getattr__(self, name):
            return getattr(eng, name)

        def regressor(self, q, qd, qdd, **kw):
            Y = real(q, qd, qdd, **kw)
            cols = np.arange(Y.shape[-1])
            for p in range(arm.n):
                cols[10 * p + 5], cols[10 * p + 7] = 10 * p + 7, 10 * p + 5
            return Y[..., cols]

    arm.set_engine("pinocchio", Swapped())
    report = md.crosscheck(arm, samples=SAMPLES)
    assert not report["Y"].ok
    assert report["tau"].ok


# -- drives: a planted bug in the coupled rotor inertia or the motor-side friction -----

def _coupled_arm():
    from manipdyn.model.drive import Friction, Transmission

    base = _arm()
    links = [dataclasses.replace(l, motor_inertia=1e-4 * (i + 1), gear_ratio=(-1) ** i * (20.0 + 10 * i))
             for i, l in enumerate(base.links)]
    tr = Transmission.from_gear_ratios([l.gear_ratio for l in links], coupling=[[4, 3, 15.0], [2, 1, -8.0]])
    law = Friction(viscous=[1e-3] * 4, coulomb_pos=[0.02] * 4, coulomb_neg=[0.03] * 4, side="motor", smoothing=0.2)
    return md.Manipulator(links, "standard", transmission=tr, friction=law, name="coupled mutant")


def _with_pinocchio(arm, **kw):
    from manipdyn.engines.pinocchio.engine import model_for_arm

    args = dict(friction=arm.friction_model, transmission=arm.transmission, tool_frame="tool",
                rotor_coupling=arm.rotor_inertia - np.diag(np.diag(arm.rotor_inertia)))
    args.update(kw)
    eng = PinocchioEngine(model_for_arm(arm), **args)
    eng.link_offsets = arm.urdf_link_offsets()      # as the engine's factory does (link k's Jacobian at T_k)
    arm.set_engine("pinocchio", eng)
    return arm


def test_clean_coupled_drive_passes():
    arm = _with_pinocchio(_coupled_arm())
    assert md.crosscheck(arm, samples=SAMPLES).ok


def test_forgotten_rotor_coupling_is_caught():
    """Only Pinocchio's diagonal model.armature: the off-diagonal rotor inertia is lost."""
    report = md.crosscheck(_with_pinocchio(_coupled_arm(), rotor_coupling=None), samples=SAMPLES)
    assert not report["D"].ok and not report["tau"].ok and not report["K"].ok
    assert report["g"].ok and report["h"].ok


def test_rotor_inertia_as_r_jm_rt_is_caught():
    """R diag(Jm) R^T instead of R^T diag(Jm) R (the transpose slip)."""
    arm = _coupled_arm()
    R, Jm = arm.transmission.R, arm.motor_inertia
    wrong = R @ np.diag(Jm) @ R.T
    wrong = 0.5 * (wrong + wrong.T)          # exactly symmetric, as the engine requires
    report = md.crosscheck(_with_pinocchio(arm, rotor_coupling=wrong - np.diag(np.diag(wrong))), samples=SAMPLES)
    assert not report["D"].ok and not report["tau"].ok


def test_motor_side_friction_mapped_by_r_instead_of_rt_is_caught():
    """The law evaluated at R^T qd and mapped back by R: friction torques wrong, inertia right."""
    from manipdyn.model.drive import Transmission

    arm = _coupled_arm()
    report = md.crosscheck(_with_pinocchio(arm, transmission=Transmission(arm.transmission.R.T)), samples=SAMPLES)
    assert not report["tau"].ok
    assert report["D"].ok and report["h"].ok and report["g"].ok
# -- derivatives: a planted bug in either engine's derivatives is caught ---------------

DERIVATIVES = ("dtau_dq", "dtau_dqd", "dqdd_dq", "dqdd_dqd", "dg_dq")


def _friction_arm():
    import dataclasses

    base = _arm()
    links = [dataclasses.replace(link, friction_viscous=0.4 + 0.3 * i, friction_coulomb=0.2)
             for i, link in enumerate(base.links)]
    return md.Manipulator(links, convention="standard", name="mutant-friction")


def test_clean_derivatives_pass():
    for arm in (_arm(), _friction_arm()):
        report = md.crosscheck(arm, samples=SAMPLES)
        assert all(report[k].ok for k in DERIVATIVES), report


def test_trace_form_jacobian_transposed_is_caught():
    """dtau/dq returned as [m, i] instead of [i, m] (the classic Jacobian-layout slip)."""
    from manipdyn.engines.lagrange.engine import TraceFormEngine

    class Transposed(TraceFormEngine):
        def _rigid_jacobians(self, *args):
            dq, dqd = super()._rigid_jacobians(*args)
            return dq.swapaxes(1, 2), dqd

    arm = _arm()
    kin, J, armature, friction = arm.trace_form_data()
    arm.set_engine("lagrange", Transposed(kin, J, arm.gravity, armature=armature, friction=friction,
                                          link_offsets=arm.urdf_link_offsets()))
    report = md.crosscheck(arm, samples=SAMPLES)
    assert not report["dtau_dq"].ok and not report["dqdd_dq"].ok
    assert report["dtau_dqd"].ok and report["dg_dq"].ok and report["tau"].ok


def test_trace_form_gravity_hessian_half_is_caught():
    """dg/dq with only its upper triangle (the symmetric half forgotten)."""
    from manipdyn.engines.lagrange.engine import TraceFormEngine

    class Half(TraceFormEngine):
        def _gravity_jacobian(self, Delta, cbar):
            return np.triu(super()._gravity_jacobian(Delta, cbar))

    arm = _arm()
    kin, J, armature, friction = arm.trace_form_data()
    arm.set_engine("lagrange", Half(kin, J, arm.gravity, armature=armature, friction=friction,
                                    link_offsets=arm.urdf_link_offsets()))
    report = md.crosscheck(arm, samples=SAMPLES)
    assert not report["dg_dq"].ok
    assert report["dtau_dq"].ok and report["g"].ok


def test_trace_form_friction_forgotten_is_caught():
    from manipdyn.engines.lagrange.engine import TraceFormEngine

    class NoFriction(TraceFormEngine):
        def _friction_jacobian(self, qd):
            return None

    arm = _friction_arm()
    kin, J, armature, friction = arm.trace_form_data()
    arm.set_engine("lagrange", NoFriction(kin, J, arm.gravity, armature=armature, friction=friction,
                                          link_offsets=arm.urdf_link_offsets()))
    report = md.crosscheck(arm, samples=SAMPLES)
    assert not report["dtau_dqd"].ok and not report["dqdd_dqd"].ok
    assert report["dtau_dq"].ok and report["tau"].ok


def test_pinocchio_gravity_left_out_of_dtau_dq_is_caught():
    """RNEA derivatives taken on a gravity-free model (h's derivative only)."""
    import pinocchio as pin

    arm = _arm()
    eng = arm.pinocchio
    m0 = eng.model.copy()
    m0.gravity.linear = np.zeros(3)
    d0 = m0.createData()

    class NoGravity:
        def __getattr__(self, name):
            return getattr(eng, name)

        def inverse_dynamics_derivatives(self, q, qd, qdd):
            out = [[x.copy() for x in pin.computeRNEADerivatives(m0, d0, a, b, c)] for a, b, c in zip(q, qd, qdd)]
            return np.array([o[0] for o in out]), np.array([o[1] for o in out])

    arm.set_engine("pinocchio", NoGravity())
    report = md.crosscheck(arm, samples=SAMPLES)
    assert not report["dtau_dq"].ok
    assert report["dtau_dqd"].ok and report["dg_dq"].ok


def test_pinocchio_aba_derivatives_without_friction_correction_are_caught():
    """ABA derivatives at tau - F(qd) but without ``- Minv dF/dqd``."""
    import pinocchio as pin

    arm = _friction_arm()
    eng = arm.pinocchio
    fv, fc = arm.friction

    class Uncorrected:
        def __getattr__(self, name):
            return getattr(eng, name)

        def forward_dynamics_derivatives(self, q, qd, tau):
            out = [[x.copy() for x in pin.computeABADerivatives(eng.model, eng.data, a, b,
                                                                   c - fv * b - fc * np.sign(b))]
                   for a, b, c in zip(q, qd, tau)]
            return tuple(np.array([o[k] for o in out]) for k in range(3))

    arm.set_engine("pinocchio", Uncorrected())
    report = md.crosscheck(arm, samples=SAMPLES)
    assert not report["dqdd_dqd"].ok
    assert report["dqdd_dq"].ok and report["dtau_dqd"].ok
