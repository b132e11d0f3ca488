"""The inverse-dynamics regressor, derived two ways.

``arm.lagrange.regressor`` is the closed-form derivative of the trace form
(eq. 2.39) with respect to each link's ten parameters; ``arm.pinocchio.regressor``
is ``pin.computeJointTorqueRegressor``.  They share no code, so their
agreement, and ``Y @ pi == inverse_dynamics`` on both engines, proves the
parameter layout (URDF link frames, Pinocchio's order) and the derivation.

Tolerance 1e-9 relative (to max(1, max|Y|)), the cross-check's: both are
float64 sums of O(n) products of O(1) matrices and agree to ~1e-15 here;
any modelling slip (a frame, a sign, a column order) shows at 1e-3 or more.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import manipdyn as md
from manipdyn.model import random_arms as arms
from manipdyn.identification.estimation.model import arm_with_parameters
from manipdyn.model.parameters import arm_parameters, parameter_names

TOL = 1e-9


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(name)


def _states(arm, N, seed=0):
    rng = np.random.default_rng(seed)
    q = arm.random_state(rng, N)
    return q, rng.uniform(-2, 2, q.shape), rng.uniform(-5, 5, q.shape)


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(b)))))


def _random_arms():
    out = []
    for seed, conv in ((1, "standard"), (2, "modified"), (3, "standard"), (4, "modified")):
        out.append(arms.random_arm(seed, n=5 + seed % 3, convention=conv, prismatic_fraction=0.4))
    return out


RANDOM = _random_arms()


def test_random_arms_cover_both_conventions_and_prismatic_joints():
    assert {a.convention for a in RANDOM} == {"standard", "modified"}
    assert {a.convention for a in RANDOM if "P" in a.joint_letters} == {"standard", "modified"}


@pytest.mark.parametrize("name", md.models())
def test_bundled_arm_regressors_agree_single_and_batch(name):
    arm = _load(name)
    q, qd, qdd = _states(arm, 30)
    YL, YP = arm.lagrange.regressor(q, qd, qdd), arm.pinocchio.regressor(q, qd, qdd)
    assert YL.shape == YP.shape == (30, arm.n, 10 * arm.n)
    for k in range(30):
        assert _rel(YL[k], YP[k]) <= TOL
    Y1 = arm.lagrange.regressor(q[3], qd[3], qdd[3])
    assert Y1.shape == (arm.n, 10 * arm.n)
    assert _rel(Y1, YP[3]) <= TOL
    assert _rel(arm.pinocchio.regressor(q[3], qd[3], qdd[3]), YL[3]) <= TOL


@pytest.mark.parametrize("arm", RANDOM, ids=lambda a: f"{a.name}-{a.joint_letters}")
def test_random_arm_regressors_agree(arm):
    q, qd, qdd = arms.random_state(np.random.default_rng(5), arm, size=40)
    YL, YP = arm.lagrange.regressor(q, qd, qdd), arm.pinocchio.regressor(q, qd, qdd)
    for k in range(40):
        assert _rel(YL[k], YP[k]) <= TOL
    assert _rel(arm.lagrange.regressor(q[0], qd[0], qdd[0]), YP[0]) <= TOL


def test_urdf_arm_regressors_agree():
    """An arm read from a URDF (example-robot-data's UR5): identity link offsets."""
    from manipdyn.formats import erd

    arm = md.load(str(erd.urdf_path("ur5_robot")))
    q, qd, qdd = _states(arm, 10)
    YL, YP = arm.lagrange.regressor(q, qd, qdd), arm.pinocchio.regressor(q, qd, qdd)
    assert max(_rel(a, b) for a, b in zip(YL, YP)) <= TOL
    rigid = arm.inverse_dynamics(q, qd, qdd) - arm.pinocchio.friction_torque(qd)
    assert _rel(YL @ arm.parameters(), rigid) <= TOL


@pytest.mark.parametrize("name", ["puma560_akb", "panda", "stanford"])
@pytest.mark.parametrize("engine", ["lagrange", "pinocchio"])
def test_Y_times_parameters_is_inverse_dynamics(name, engine):
    """With armature and friction columns, ``Y @ pi`` is the engine's own tau.

    The columns of the arm's own friction law (``friction=arm.friction_model``): the bundled
    panda's is Gaz et al.'s sigmoid, which viscous and Coulomb columns (``friction=True``)
    leave out, as :func:`manipdyn.parameters.arm_parameters` documents.
    """
    arm = _load(name)
    q, qd, qdd = _states(arm, 20, seed=2)
    eng = getattr(arm, engine)
    law = arm.friction_model if arm.friction_model is not None else True
    pi = arm.parameters(armature=True, friction=law)
    Y = eng.regressor(q, qd, qdd, armature=True, friction=law)
    assert Y.shape == (20, arm.n, pi.size) and pi.size >= 11 * arm.n
    assert _rel(Y @ pi, eng.inverse_dynamics(q, qd, qdd)) <= TOL
    Y13 = eng.regressor(q, qd, qdd, armature=True, friction=True)
    assert Y13.shape == (20, arm.n, 13 * arm.n)
    left_out = eng.friction_torque(qd) - Y13[..., 11 * arm.n:] @ arm.parameters(friction=True)[10 * arm.n:]
    assert _rel(Y13 @ arm.parameters(armature=True, friction=True), eng.inverse_dynamics(q, qd, qdd) - left_out) <= TOL
    # without the extra columns: the rigid bodies only
    rigid = eng.inverse_dynamics(q, qd, qdd) - eng.friction_torque(qd) - arm.armature * qdd
    assert _rel(eng.regressor(q, qd, qdd) @ arm.parameters(), rigid) <= TOL


def test_random_arm_with_rotors_and_friction_Y_pi_is_tau():
    base = arms.random_arm(11, n=6, convention="standard", rotors=True)
    links = [l.__class__(**{**{f: getattr(l, f) for f in l.__dataclass_fields__},
                            "friction_viscous": 0.3 + 0.1 * i, "friction_coulomb": 0.2})
             for i, l in enumerate(base.links)]
    arm = md.Manipulator(links, convention="standard", gravity=base.gravity, name="rf")
    q, qd, qdd = arms.random_state(np.random.default_rng(0), arm, size=15)
    pi = arm.parameters(armature=True, friction=True)
    for eng in (arm.lagrange, arm.pinocchio):
        Y = eng.regressor(q, qd, qdd, armature=True, friction=True)
        assert _rel(Y @ pi, arm.lagrange.inverse_dynamics(q, qd, qdd)) <= TOL


@given(seed=st.integers(0, 2**32 - 1))
def test_regressors_agree_on_any_random_arm(seed):
    """Seeded random arms: 1 to 8 joints, either convention, revolute and prismatic,
    random gravity direction, with or without rotors; a batch and one state."""
    arm = arms.random_arm(seed)
    q, qd, qdd = arms.random_state(np.random.default_rng(seed), arm, size=4)
    YL, YP = arm.lagrange.regressor(q, qd, qdd, armature=True), arm.pinocchio.regressor(q, qd, qdd, armature=True)
    assert max(_rel(a, b) for a, b in zip(YL, YP)) <= TOL
    assert _rel(arm.lagrange.regressor(q[1], qd[1], qdd[1], armature=True), YP[1]) <= TOL
    assert _rel(YL @ arm.parameters(armature=True), arm.lagrange.inverse_dynamics(q, qd, qdd)) <= TOL


def test_control_regressor_shares_the_layout():
    from manipdyn.control.regressor import Regressor

    arm = _load("puma560_akb")
    R = Regressor(arm, armature=True, friction=True)
    assert R.names == parameter_names(arm.n, True, True)
    np.testing.assert_array_equal(R.parameters(), arm_parameters(arm, True, True))
    q, qd, qdd = _states(arm, 1)
    assert _rel(R.inverse_dynamics(q[0], qd[0], qdd[0]),
                arm.pinocchio.regressor(q[0], qd[0], qdd[0], armature=True, friction=True)) <= TOL


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_arm_with_parameters_round_trips(convention):
    """Parameters written back into a DH arm give the same parameters (and dynamics)."""
    arm = arms.random_arm(21, n=5, convention=convention, rotors=True)
    pi = arm.parameters(armature=True)
    back = arm_with_parameters(arm, pi, armature=True)
    np.testing.assert_allclose(back.parameters(armature=True), pi, rtol=1e-12, atol=1e-12)
    q, qd, qdd = _states(arm, 5)
    np.testing.assert_allclose(back.inverse_dynamics(q, qd, qdd), arm.inverse_dynamics(q, qd, qdd),
                               rtol=1e-10, atol=1e-10)


def test_regressor_shape_errors_name_the_argument():
    arm = _load("ur5")
    with pytest.raises(md.StateError, match="qdd"):
        arm.lagrange.regressor(np.zeros(6), np.zeros(6), np.zeros(5))
    with pytest.raises(md.StateError, match="qd"):
        arm.pinocchio.regressor(np.zeros((3, 6)), np.zeros((2, 6)), np.zeros((3, 6)))


def test_negative_mass_cannot_be_written():
    arm = _load("ur5")
    pi = arm.parameters()
    pi[20] = -1.0
    with pytest.raises(md.ModelError, match="link 3.*negative"):
        arm_with_parameters(arm, pi)
