"""A DH arm's base and tool transforms (issue 46, item 17): ``Manipulator(..., base=, tool=)``, 4x4
homogeneous transforms as the Robotics Toolbox's ``base`` and ``tool``, flowing into ``fkine``, the
link frames and Jacobians, the wrench at the tool, the payload, the URDF writer, the model file and
every engine (so the cross-check still agrees).  Fails on the code before (no such arguments)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.model.kinematics import rot_x, rot_y, rot_z, trans

B = trans(0.3, -0.2, 0.5) @ rot_z(0.7) @ rot_x(0.4)
X = trans(0.01, 0.0, 0.12) @ rot_y(0.3)
#: two float64 engines on the same arm agree to ~1e-15; 1e-12 leaves room for the chain of 4x4 products
TOL = 1e-12


def _with(arm, base=B, tool=X, name=None):
    return md.Manipulator(arm.links, convention=arm.convention, gravity=arm.gravity, name=name or arm.name + "_bt",
                          base=base, tool=tool, transmission=arm.transmission, friction=arm.friction_model)


@pytest.fixture(scope="module", params=["ur5", "puma560", "stanford"])
def pair(request):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        arm = md.load(request.param)
        return arm, _with(arm)


def _q(arm, seed=0):
    return arm.random_state(np.random.default_rng(seed))


def test_fkine_link_frames_and_jacobians_in_the_world(pair):
    arm, bt = pair
    q = _q(arm)
    for engine in ("lagrange", "pinocchio"):
        np.testing.assert_allclose(bt.engine(engine).fkine(q), B @ arm.fkine(q) @ X, rtol=0, atol=TOL)
    np.testing.assert_allclose(bt.link_poses(q), B @ arm.link_poses(q), rtol=0, atol=TOL)
    # the tool's Jacobian: at the offset tool origin, in world axes; both engines
    Jl, Jp = bt.jacobian(q, "lagrange"), bt.jacobian(q, "pinocchio")
    np.testing.assert_allclose(Jl, Jp, rtol=0, atol=TOL)
    R = B[:3, :3]
    J0 = arm.jacobian(q)
    p = (arm.fkine(q) @ X)[:3, 3] - arm.fkine(q)[:3, 3]             # tool offset, base axes
    v = J0[:3] + np.cross(J0[3:].T, p).T                            # v_tool = v_n + w x p
    np.testing.assert_allclose(Jp[:3], R @ v, rtol=0, atol=TOL)
    np.testing.assert_allclose(Jp[3:], R @ J0[3:], rtol=0, atol=TOL)
    for k in (2, arm.n):
        np.testing.assert_allclose(bt.jacobian(q, "lagrange", link=k), bt.jacobian(q, link=k), rtol=0, atol=TOL)


def test_the_cross_check_agrees(pair):
    _arm, bt = pair
    report = md.crosscheck(bt, samples=40, engines=("lagrange", "pinocchio"))
    assert report.ok, report


def test_gravity_is_in_the_world():
    """The arm hung upside down (base Rx(pi)) under gravity -z feels what the upright arm feels under +z."""
    arm = md.load("ur5")
    hung = _with(arm, base=rot_x(np.pi), tool=None)
    up = md.Manipulator(arm.links, convention="standard", gravity=-np.asarray(arm.gravity), name="up")
    q = _q(arm, 1)
    np.testing.assert_allclose(hung.gravity_torque(q), up.gravity_torque(q), rtol=0, atol=1e-12)
    np.testing.assert_allclose(hung.lagrange.gravity_torque(q), up.gravity_torque(q), rtol=0, atol=1e-12)
    # the mass matrix does not see the base
    np.testing.assert_allclose(hung.mass_matrix(q), arm.mass_matrix(q), rtol=0, atol=1e-12)


def test_payload_and_tool_wrench_are_the_tool_frames():
    arm = md.load("ur5")
    bt = _with(arm, base=None)
    q, qd, qdd = _q(arm, 2), np.full(6, 0.1), np.full(6, -0.2)
    # a point payload at the tool origin is a payload at X's translation in frame n
    a = bt.with_payload(2.0)
    b = arm.with_payload(2.0, com=X[:3, 3])
    np.testing.assert_allclose(a.inverse_dynamics(q, qd, qdd), b.inverse_dynamics(q, qd, qdd), rtol=0, atol=1e-11)
    f = np.array([1.0, -2.0, 3.0, 0.1, 0.2, -0.3])
    np.testing.assert_allclose(bt.inverse_dynamics(q, qd, qdd, f),
                               bt.inverse_dynamics(q, qd, qdd) - bt.jacobian(q, "lagrange").T @ f, rtol=0, atol=1e-11)


def test_urdf_and_model_file_hold_them(tmp_path):
    arm = md.load("ur5")
    bt = _with(arm)
    q = _q(arm, 3)
    md.write_urdf(bt, tmp_path / "bt.urdf")
    back = md.load(str(tmp_path / "bt.urdf"))
    np.testing.assert_allclose(back.fkine(q), bt.fkine(q), rtol=0, atol=TOL)
    np.testing.assert_allclose(back.inverse_dynamics(q, q, q), bt.inverse_dynamics(q, q, q), rtol=0, atol=1e-10)
    md.save(bt, tmp_path / "bt.toml")
    again = md.load(str(tmp_path / "bt.toml"))
    assert again == bt and again != arm
    assert np.array_equal(again.base, bt.base) and np.array_equal(again.tool, bt.tool)
    md.save(arm, tmp_path / "plain.toml")
    assert "base =" not in (tmp_path / "plain.toml").read_text(encoding="utf-8")    # identity: not written


@pytest.mark.parametrize("bad, match", [
    (np.eye(3), "4x4"), (np.diag([2.0, 1, 1, 1]), "rotation"), (rot_x(0.1) @ np.diag([1, 1, -1, 1]), "rotation"),
    (np.vstack([np.eye(4)[:3], [0, 0, 1, 1]]), "last row"), ("identity", "4x4"), (np.full((4, 4), np.nan), "finite"),
])
def test_bad_transforms_are_named(bad, match):
    arm = md.load("ur5")
    for key in ("base", "tool"):
        with pytest.raises(md.ModelError, match=f"^{key}: .*{match}"):
            md.Manipulator(arm.links, convention="standard", **{key: bad})


def test_the_generated_c_agrees():
    pytest.importorskip("casadi", reason="the C engine needs CasADi: pip install 'manipdyn[codegen]'")
    from manipdyn.engines.c import build, compiled_engine

    if build.find_compiler() is None:
        pytest.skip("no C compiler ($CC, cc or gcc) on this machine")
    bt = _with(md.load("ur5"))
    bt.set_engine("c", compiled_engine(bt, opt="-O0"))
    q = _q(bt, 4)
    np.testing.assert_allclose(bt.engine("c").fkine(q), bt.fkine(q), rtol=0, atol=TOL)
    np.testing.assert_allclose(bt.engine("c").gravity_torque(q), bt.gravity_torque(q), rtol=0, atol=1e-10)
