"""What an RTB or Pinocchio user expects of the arm's calls (issue 46, item 17, in part): a link by its
name wherever a link number is taken, an external wrench on any link (not only the tool), and
``with_payload`` taking the six-number inertia RUNS.toml takes.  Each fails on the code before
(a name was refused, ``link=`` was no argument of the dynamics, six numbers were 'ambiguous')."""

from __future__ import annotations

import numpy as np
import pytest

import manipdyn as md


@pytest.fixture(scope="module")
def ur5():
    return md.load("ur5")


def _state(seed=0):
    rng = np.random.default_rng(seed)
    return (rng.uniform(-1, 1, 6) for _ in range(3))


def test_links_by_name(ur5):
    q, qd, _ = _state()
    names = [j.link_name for j in ur5.chain()[0]]
    assert names[2] == "forearm"
    for engine in ("pinocchio", "lagrange"):
        for frame in ("world", "tool"):
            assert np.array_equal(ur5.jacobian(q, engine, frame=frame, link="forearm"),
                                  ur5.jacobian(q, engine, frame=frame, link=3))
    assert np.array_equal(ur5.jacobian_dot(q, qd, link="wrist_1"), ur5.jacobian_dot(q, qd, link=4))
    assert np.array_equal(ur5.point_in_base(q, [0.1, 0, 0], link="upper_arm"),
                          ur5.point_in_base(q, [0.1, 0, 0], link=2))
    for bad in ("elbow", 0, 7, True, 2.0):
        with pytest.raises(md.ModelError, match="^link: "):
            ur5.jacobian(q, link=bad)
    with pytest.raises(md.ModelError, match="'shoulder', 'upper_arm'"):
        ur5.jacobian(q, link="elbow")


def test_a_urdf_arms_links_by_their_urdf_names(tmp_path, ur5):
    path = tmp_path / "ur5.urdf"
    md.write_urdf(ur5, path)
    urdf = md.load(str(path))
    assert isinstance(urdf, md.URDFArm)
    q, _, _ = _state(1)
    name = urdf.chain()[0][1].link_name
    assert np.array_equal(urdf.jacobian(q, link=name), urdf.jacobian(q, link=2))


def test_a_wrench_on_any_link(ur5):
    """``link=k``: J_k^T f with J_k = jacobian(q, link=k) (both engines' Jacobians agree); joints after k
    feel nothing; on the last link it is the tool wrench (a DH arm's tool frame is DH frame n); forward
    dynamics inverts it."""
    q, qd, qdd = _state(2)
    f = np.array([3.0, -2.0, 5.0, 0.4, -0.1, 0.2])
    free = ur5.inverse_dynamics(q, qd, qdd)
    for k, name in ((3, "forearm"), (5, "wrist_2")):
        tau = ur5.inverse_dynamics(q, qd, qdd, f, link=name)
        J = ur5.jacobian(q, "lagrange", link=k)
        # the two engines' Jacobians agree to ~1e-15; 1e-12 N m on torques of a few N m
        np.testing.assert_allclose(tau, free - J.T @ f, rtol=0, atol=1e-12)
        assert np.array_equal(tau[k:], free[k:])            # a wrench on link k moves no joint after k
        assert np.abs(tau[:k] - free[:k]).max() > 0.1
        back = ur5.forward_dynamics(q, qd, tau, f, link=k)
        np.testing.assert_allclose(back, qdd, rtol=0, atol=1e-9)   # ABA's round trip, cond(D) ~ 1e3
    assert np.array_equal(ur5.inverse_dynamics(q, qd, qdd, f, link=6), ur5.inverse_dynamics(q, qd, qdd, f))
    batch = ur5.inverse_dynamics(np.tile(q, (3, 1)), np.tile(qd, (3, 1)), np.tile(qdd, (3, 1)), f, link=3)
    np.testing.assert_allclose(batch, np.tile(ur5.inverse_dynamics(q, qd, qdd, f, link=3), (3, 1)), rtol=0, atol=1e-12)
    with pytest.raises(md.ModelError, match="^link: "):
        ur5.inverse_dynamics(q, qd, qdd, f, link="hand")


def test_with_payload_takes_the_six_numbers_runs_toml_takes(ur5):
    """``[ixx, iyy, izz, ixy, ixz, iyz]``, RUNS.toml's order, as the (3, 3) tensor it names."""
    six = [0.02, 0.025, 0.03, 0.001, 0.002, 0.003]
    T = np.array([[0.02, 0.001, 0.002], [0.001, 0.025, 0.003], [0.002, 0.003, 0.03]])
    a = ur5.with_payload(1.5, com=(0, 0, 0.05), inertia=six)
    b = ur5.with_payload(1.5, com=(0, 0, 0.05), inertia=T)
    q, _, _ = _state(3)
    assert np.array_equal(a.mass_matrix(q), b.mass_matrix(q))
    assert not np.array_equal(a.mass_matrix(q), ur5.with_payload(1.5, com=(0, 0, 0.05)).mass_matrix(q))
    with pytest.raises(md.ModelError, match="with_payload: payload"):
        ur5.with_payload(1.0, inertia=[0.01, 0.01, 0.05, 0, 0, 0])     # breaks A + B >= C: still refused
