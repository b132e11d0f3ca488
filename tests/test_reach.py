"""Issue 31, item 17: a Toolbox or Pinocchio user's reach.

``arm.inverse_kinematics(T, q0=None)``, ``arm.jacobian(q, frame=..., link=...)``, ``f_tool=`` on
``inverse_dynamics`` and ``forward_dynamics``, and ``arm.potential_energy(q)``: each answered by
both engines and held to each other (as ``md.crosscheck`` holds the Jacobian), and each held to
something neither engine computes (finite differences of the poses, an arm carrying a payload).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.model.reach import rotation_vector, wrench_torque
from manipdyn.model.variants import with_payload

ARMS = [*md.models(), "erd:ur5_robot"]


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.ModelNoteWarning)
        return md.load(name)


def _vee(W):
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


def _fd_frame_jacobian(pose, q, h=1e-6):
    """Central differences of a pose function: [dp/dq; vee(dR R^T)] (world) and [R^T dp; vee(R^T dR)] (own axes)."""
    n = len(q)
    Jw, Jl = np.empty((6, n)), np.empty((6, n))
    R = pose(q)[:3, :3]
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        dT = (pose(q + e) - pose(q - e)) / (2 * h)
        Jw[:, j] = np.concatenate((dT[:3, 3], _vee(dT[:3, :3] @ R.T)))
        Jl[:, j] = np.concatenate((R.T @ dT[:3, 3], _vee(R.T @ dT[:3, :3])))
    return Jw, Jl


@pytest.mark.parametrize("name", ARMS)
def test_jacobian_frames_and_links_two_engines_and_finite_differences(name):
    arm = _load(name)
    q = arm.random_state(np.random.default_rng(5), 3)
    for link in [None, *range(1, arm.n + 1)]:
        if link is None:
            pose = arm.fkine
        else:
            def pose(x, k=link):
                return arm.link_poses(x)[k - 1]
        for frame in ("world", "tool"):
            JP = arm.jacobian(q, frame=frame, link=link)
            JL = arm.jacobian(q, engine="lagrange", frame=frame, link=link)
            assert JP.shape == JL.shape == (3, 6, arm.n)
            # two float64 engines on O(1) m arms: 1e-12 is a thousand round-offs
            np.testing.assert_allclose(JP, JL, atol=1e-12, err_msg=f"{frame} link={link}")
            for k in range(len(q)):
                Jw, Jl = _fd_frame_jacobian(pose, q[k])
                # central differences, h = 1e-6: truncation ~1e-12, round-off ~1e-10
                np.testing.assert_allclose(JP[k], Jw if frame == "world" else Jl, atol=1e-8)
    # the default is the tool frame in base axes, as before
    np.testing.assert_array_equal(arm.jacobian(q[0]), arm.jacobian(q[0], frame="world"))
    np.testing.assert_allclose(arm.jacobian(q, link=arm.n, engine="lagrange")[:, 3:],
                               arm.jacobian(q, engine="lagrange")[:, 3:], atol=1e-12)  # same body turns alike
    J1 = arm.jacobian(q[0], link=1)
    assert not np.any(J1[:, 1:])                                     # link 1 moves with joint 1 only


def test_jacobian_arguments_are_refused_by_name():
    arm = _load("ur5")
    q = np.zeros(6)
    for kw, word in ((dict(frame="base"), "frame"), (dict(frame=None), "frame"), (dict(link=0), "link"),
                     (dict(link=7), "link"), (dict(link=True), "link"), (dict(link="wrist"), "link")):
        for engine in ("pinocchio", "lagrange"):
            with pytest.raises(md.ModelError, match=f"^{word}:"):
                arm.jacobian(q, engine=engine, **kw)


def _payload_case(name, com):
    """The arm, the arm carrying a 2.5 kg point mass at ``com`` (tool frame), and the mass."""
    arm = _load(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.ModelNoteWarning)
        return arm, with_payload(arm, 2.5, com=com), 2.5


@pytest.mark.parametrize("name", ["ur5", "puma560", "stanford", "panda"])
def test_tool_wrench_is_the_weight_of_a_payload(name):
    """A point mass m at c (tool frame) held still pulls on the tool with f = m g at the tool origin and
    moment (R c) x m g: the arm with the payload needs ID - J^T f, by both engines."""
    c = np.array([0.02, -0.03, 0.05])
    arm, loaded, m = _payload_case(name, c)
    rng = np.random.default_rng(6)
    q = arm.random_state(rng, 4)
    zero = np.zeros_like(q)
    R = arm.fkine(q)[:, :3, :3]
    weight = m * arm.gravity
    f = np.concatenate((np.broadcast_to(weight, (4, 3)), np.cross(R @ c, weight)), axis=1)
    with_f = arm.inverse_dynamics(q, zero, zero, f_tool=f)
    for E in (loaded.pinocchio, loaded.lagrange):
        # relative 1e-12 of torques of tens of N m: round-off of two float64 paths
        np.testing.assert_allclose(with_f, E.inverse_dynamics(q, zero, zero), rtol=1e-11, atol=1e-10)
    ref = arm.lagrange.inverse_dynamics(q, zero, zero) - wrench_torque(arm.lagrange.jacobian(q), f)
    np.testing.assert_allclose(with_f, ref, rtol=1e-11, atol=1e-10)


@pytest.mark.parametrize("name", ["ur5", "stanford", "panda"])
def test_tool_wrench_in_motion_and_forward_dynamics(name):
    """With the mass at the tool origin in motion, f = m (g - a), a = J qdd + Jdot qd (linear rows);
    forward dynamics under f_tool inverts inverse dynamics under the same wrench."""
    arm, loaded, m = _payload_case(name, (0.0, 0.0, 0.0))
    rng = np.random.default_rng(7)
    q, qd, qdd = arm.random_state(rng, 4), rng.uniform(-1, 1, (4, arm.n)), rng.uniform(-2, 2, (4, arm.n))
    a = (np.einsum("bij,bj->bi", arm.jacobian(q), qdd) + np.einsum("bij,bj->bi", arm.jacobian_dot(q, qd), qd))[:, :3]
    f = np.concatenate((m * (arm.gravity - a), np.zeros((4, 3))), axis=1)
    tau = arm.inverse_dynamics(q, qd, qdd, f_tool=f)
    np.testing.assert_allclose(tau, loaded.lagrange.inverse_dynamics(q, qd, qdd), rtol=1e-10, atol=1e-9)
    # forward dynamics: back to qdd (one state and a batch; a (6,) wrench for a batch too)
    np.testing.assert_allclose(arm.forward_dynamics(q, qd, tau, f_tool=f), qdd, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(arm.forward_dynamics(q[1], qd[1], tau[1], f_tool=f[1]), qdd[1], rtol=1e-8, atol=1e-8)
    f0 = np.array([1.0, -2.0, 3.0, 0.1, 0.2, -0.3])
    t0 = arm.inverse_dynamics(q, qd, qdd, f_tool=f0)
    np.testing.assert_allclose(t0[2], arm.inverse_dynamics(q[2], qd[2], qdd[2], f_tool=f0), rtol=1e-13, atol=1e-12)
    # None is the plain call, bit for bit
    np.testing.assert_array_equal(arm.inverse_dynamics(q[0], qd[0], qdd[0], f_tool=None),
                                  arm.pinocchio.inverse_dynamics(q[0], qd[0], qdd[0]))


def test_tool_wrench_is_refused_by_name():
    arm = _load("ur5")
    q = np.zeros(6)
    for bad in ([1.0, 2.0], [np.nan] * 6, "force", np.ones((2, 6))):
        with pytest.raises(md.StateError, match="^f_tool:"):
            arm.inverse_dynamics(q, q, q, f_tool=bad)
        with pytest.raises(md.StateError, match="^f_tool:"):
            arm.forward_dynamics(q, q, q, f_tool=bad)
    with pytest.raises(md.StateError, match="^f_tool:"):                # 3 wrenches for 2 states
        arm.inverse_dynamics(np.zeros((2, 6)), np.zeros((2, 6)), np.zeros((2, 6)), f_tool=np.ones((3, 6)))


@pytest.mark.parametrize("name", ["ur5", "stanford", "panda", "erd:ur5_robot"])
def test_potential_energy_on_the_arm(name):
    arm = _load(name)
    q = arm.random_state(np.random.default_rng(8), 5)
    P = arm.potential_energy(q)
    assert P.shape == (5,) and isinstance(arm.potential_energy(q[0]), float)
    np.testing.assert_allclose(P, arm.lagrange.potential_energy(q), rtol=1e-12, atol=1e-10)
    # dP/dq is the gravity torque (eq. 2.24, 2.39); central differences, h = 1e-6
    h, n = 1e-6, arm.n
    dP = np.array([(arm.potential_energy(q[0] + h * e) - arm.potential_energy(q[0] - h * e)) / (2 * h)
                   for e in np.eye(n)])
    np.testing.assert_allclose(dP, arm.gravity_torque(q[0]), atol=1e-6)


def test_crosscheck_compares_the_new_quantities_and_catches_a_wrong_frame():
    arm = _load("ur5")
    report = md.crosscheck(arm, samples=30, seed=2)
    for key in ("J_tool", "J_link", "tau_f", "P", "J"):
        assert report[key].ok and report[key].max_rel < 1e-11
    lag = arm.lagrange
    honest = lag.jacobian

    class WorldForTool:             # a planted bug: "tool" answered in base axes
        def __getattr__(self, nm):
            return getattr(lag, nm)

        def jacobian(self, q, frame="world", link=None):
            return honest(q, frame="world", link=link)

    bad = md.load("ur5")
    bad.set_engine("lagrange", WorldForTool())
    r = md.crosscheck(bad, samples=10, seed=2)
    assert not r["J_tool"].ok and r["J"].ok and r["tau_f"].ok


@pytest.mark.parametrize("name", ARMS)
def test_inverse_kinematics_round_trip_by_both_engines(name):
    arm = _load(name)
    rng = np.random.default_rng(9)
    lo, hi = arm.qlim[:, 0], arm.qlim[:, 1]
    for q_true in arm.random_state(rng, 3):
        T = arm.fkine(q_true)
        for engine, other in (("pinocchio", arm.lagrange), ("lagrange", arm.pinocchio)):
            q = arm.inverse_kinematics(T, engine=engine)
            assert q.shape == (arm.n,) and np.all(q >= lo) and np.all(q <= hi)
            Tq = other.fkine(q)                                # held by the other engine's pose
            # tol 1e-10 (m, rad) on the solver's engine; the other adds float64 round-off
            assert np.linalg.norm(Tq[:3, 3] - T[:3, 3]) < 1e-9
            assert np.linalg.norm(rotation_vector(T[:3, :3] @ Tq[:3, :3].T)) < 1e-9
        # a start near the answer finds that answer (not another branch); a redundant arm (7 joints)
        # has a line of answers through it, and stays within the start's 0.01 rad of it
        q = arm.inverse_kinematics(T, q0=np.clip(q_true + 0.01, lo, hi))
        np.testing.assert_allclose(q, q_true, atol=1e-7 if arm.n <= 6 else 0.03)


def test_inverse_kinematics_batch_and_unreachable_pose():
    arm = _load("ur5")
    rng = np.random.default_rng(10)
    qs = arm.random_state(rng, 4)
    out = arm.inverse_kinematics(arm.fkine(qs))
    assert out.shape == (4, 6)
    np.testing.assert_allclose(arm.fkine(out), arm.fkine(qs), atol=1e-9)
    T = arm.fkine(qs[0])
    T[:3, 3] = [3.0, 0.0, 0.5]                                 # 3 m out: a UR5 reaches 0.85 m
    with pytest.raises(md.UnreachablePoseError, match=r"^T: the pose is out of reach of 'ur5'.* m and .* rad") as e:
        arm.inverse_kinematics(T, restarts=3)
    err = e.value
    assert isinstance(err, md.StateError) and err.q.shape == (6,)
    reached = np.linalg.norm(arm.fkine(err.q)[:3, 3] - T[:3, 3])
    assert abs(reached - err.position_error) < 1e-9 and 2.0 < err.position_error < 3.0
    assert f"{err.position_error:.4g} m" in str(err)


def test_inverse_kinematics_arguments_are_refused_by_name():
    arm = _load("ur5")
    T = arm.fkine(np.zeros(6))
    bad_R = T.copy()
    bad_R[:3, :3] *= 2.0
    for kw, word in ((dict(T=np.eye(3)), "T"), (dict(T=bad_R), "T"), (dict(T="pose"), "T"),
                     (dict(T=T, q0=np.zeros(5)), "q0"), (dict(T=T, tol=0), "tol"),
                     (dict(T=T, restarts=-1), "restarts"), (dict(T=T, max_steps=1.5), "max_steps")):
        with pytest.raises((md.ModelError, md.StateError), match=f"^{word}:"):
            arm.inverse_kinematics(**kw)
