"""manipdyn.control: trajectories, regressor, plant variants, controllers, simulation, CLI.

The acceptance runs (Puma 560, 1 kHz, RK4 with the torque held over each step):

* computed torque with a perfect model tracks a 2 s quintic within 1e-6 rad;
* with a 2 kg payload the controllers do not know about, the errors of PD +
  gravity and computed torque are recorded, and the adaptive controller's RMS
  error over the final second is at most 1/5 of computed torque's;
* an unstable loop ends in SimulationDiverged, never in NaN output.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import manipdyn as md
from manipdyn.control import (PD, ComputedTorque, PDGravity, Quintic, Regressor, Sampled,
                              SimulationDiverged, SlotineLi, ViaPoints, adaptation_gains, model_torque_limits,
                              parameters_from_pseudo_inertia, pseudo_inertia_from_parameters,
                              simulate, with_payload, with_scaled_inertia)
from manipdyn.control.demo import DEFAULT_GAMMA, demo_path, make_controller

import arms


@pytest.fixture(scope="module")
def puma():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load("puma560")


@pytest.fixture(scope="module")
def stanford():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load("stanford")


@pytest.fixture(scope="module")
def puma_friction(puma):
    """The Puma 560 with made-up joint friction (exercises the friction columns)."""
    links = [dataclasses.replace(l, friction_viscous=0.5 + 0.1 * i, friction_coulomb=0.2 * i)
             for i, l in enumerate(puma.links)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.Manipulator(links, convention="standard", name="puma-friction")


Q_START = np.array([0.0, math.pi / 4, -math.pi / 2, 0.0, math.pi / 4, 0.0])
Q_GOAL = Q_START + np.array([0.8, -0.5, 0.6, -0.9, 0.7, 1.0])


def fd_derivatives(traj, ts, e=1e-6):
    """Largest mismatch between (qd, qdd) and central differences of (q, qd)."""
    worst = 0.0
    for t in ts:
        _, qd, qdd = traj(t)
        qp, qdp, _ = traj(t + e)
        qm, qdm, _ = traj(t - e)
        worst = max(worst, np.abs((qp - qm) / (2 * e) - qd).max(), np.abs((qdp - qdm) / (2 * e) - qdd).max())
    return worst


# ---------------------------------------------------------------------------
# Trajectories
# ---------------------------------------------------------------------------


def test_quintic_rest_to_rest():
    tr = Quintic([0.0, 1.0], [1.0, -1.0], duration=2.0, t0=0.5)
    q, qd, qdd = tr(0.5)
    np.testing.assert_array_equal(q, [0.0, 1.0])
    np.testing.assert_array_equal(qd, 0.0)
    q, qd, qdd = tr(2.5)
    np.testing.assert_allclose(q, [1.0, -1.0], atol=1e-15)
    np.testing.assert_allclose(np.r_[qd, qdd], 0.0, atol=1e-14)
    q, qd, qdd = tr(1.5)                      # midpoint: half way, peak speed 1.875 dq / T
    np.testing.assert_allclose(q, [0.5, 0.0], atol=1e-15)
    np.testing.assert_allclose(qd, [0.9375, -1.875], rtol=1e-14)
    np.testing.assert_allclose(qdd, 0.0, atol=1e-14)
    q, qd, qdd = tr(10.0)                     # after the end: hold at rest
    np.testing.assert_allclose(q, [1.0, -1.0], atol=1e-15)
    assert not qd.any() and not qdd.any()
    # step e = 1e-6 s: truncation e^2/6 |q'''| ~ 1e-12, rounding eps |q| / e ~ 2e-10
    assert fd_derivatives(tr, np.linspace(0.51, 2.49, 40)) < 1e-7


def test_via_points_spline_is_smooth_and_interpolates():
    rng = np.random.default_rng(0)
    pts = rng.uniform(-1, 1, (7, 3))
    times = np.cumsum(rng.uniform(0.4, 1.2, 7))
    tr = ViaPoints(pts, times)
    q, qd, qdd = tr(times)
    np.testing.assert_allclose(q, pts, atol=1e-12)
    for k in (0, -1):                         # at rest, zero acceleration, at both ends
        np.testing.assert_allclose(np.r_[qd[k], qdd[k]], 0.0, atol=1e-12)
    for tk in times[1:-1]:                    # acceleration (and jerk) continuous at the knots
        a_minus, a_plus = tr(tk - 1e-9)[2], tr(tk + 1e-9)[2]
        assert np.abs(a_minus - a_plus).max() < 1e-6
    assert fd_derivatives(tr, np.linspace(times[0] + 0.01, times[-1] - 0.01, 80)) < 1e-6
    # two via points: the quintic
    two = ViaPoints([[0.0], [2.0]], [0.0, 1.5])
    ref = Quintic([0.0], [2.0], 1.5)
    ts = np.linspace(0, 1.5, 11)
    for a, b in zip(two(ts), ref(ts)):
        np.testing.assert_allclose(a, b, atol=1e-12)


@pytest.mark.parametrize("given", ["q", "q+qd", "q+qd+qdd"])
def test_sampled_interpolates_a_known_motion(given):
    """Samples of q = A sin(t) every 0.1 s: the interpolant's error shrinks with
    the data given (natural cubic O(h^2) in qdd, cubic Hermite, quintic Hermite)."""
    t = np.linspace(0, 3, 31)
    A = np.array([1.0, -2.0])
    q, qd, qdd = np.sin(t)[:, None] * A, np.cos(t)[:, None] * A, -np.sin(t)[:, None] * A
    args = {"q": (q,), "q+qd": (q, qd), "q+qd+qdd": (q, qd, qdd)}[given]
    tr = Sampled(t, *args)
    # away from the natural spline's ends, and off the samples (the cubic Hermite's
    # acceleration jumps there)
    tt = (t[3:27, None] + np.array([0.013, 0.05, 0.087])).ravel()
    Q, QD, QDD = tr(tt)
    tol = {"q": (2e-4, 4e-3, 5e-2), "q+qd": (1e-6, 3e-5, 3e-3), "q+qd+qdd": (1e-10, 3e-9, 3e-7)}[given]
    assert np.abs(Q - np.sin(tt)[:, None] * A).max() < tol[0]
    assert np.abs(QD - np.cos(tt)[:, None] * A).max() < tol[1]
    assert np.abs(QDD + np.sin(tt)[:, None] * A).max() < tol[2]
    np.testing.assert_allclose(tr(t)[0], q, atol=1e-13)       # through the samples
    assert fd_derivatives(tr, tt) < 1e-6


def test_trajectory_scalar_and_vector_calls_agree():
    rng = np.random.default_rng(1)
    for tr in (Quintic(np.zeros(3), np.ones(3), 1.0),
               ViaPoints(rng.uniform(-1, 1, (5, 3)), [0, 0.5, 1.2, 2.0, 2.4]),
               Sampled(np.linspace(0, 1, 9), rng.uniform(-1, 1, (9, 3)))):
        ts = np.linspace(tr.t_start - 0.2, tr.t_end + 0.2, 41)
        vec = tr(ts)
        for i, tk in enumerate(ts):
            for a, b in zip(tr(tk), vec):
                np.testing.assert_allclose(a, b[i], atol=1e-13)


def test_trajectory_input_errors():
    with pytest.raises(ValueError, match="strictly increasing"):
        ViaPoints(np.zeros((3, 2)), [0.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="at least 2"):
        ViaPoints(np.zeros((1, 2)), [0.0])
    with pytest.raises(ValueError, match="duration"):
        Quintic([0.0], [1.0], duration=0.0)
    with pytest.raises(ValueError, match="shapes"):
        Quintic([0.0, 1.0], [1.0], duration=1.0)
    with pytest.raises(ValueError, match="qd"):
        Sampled([0.0, 1.0], [[0.0], [1.0]], qd=[[0.0]])
    with pytest.raises(ValueError, match="finite"):
        Sampled([0.0, 1.0], [[0.0], [np.nan]])


# ---------------------------------------------------------------------------
# Regressor and parameters
# ---------------------------------------------------------------------------


def test_parameters_match_pinocchio(puma, stanford):
    """pi from the pseudo-inertias of the chain bodies (eq. 2.21) is Pinocchio's
    toDynamicParameters of the model's bodies (order m, mc, Ixx Ixy Iyy Ixz Iyz Izz)."""
    for arm in (puma, stanford, arms.random_arm(3, n=5, convention="modified")):
        reg = Regressor(arm)
        pi = reg.parameters()
        model = arm.pinocchio.model
        ref = np.concatenate([model.inertias[i].toDynamicParameters() for i in range(1, arm.n + 1)])
        np.testing.assert_allclose(pi[:10 * arm.n], ref, rtol=1e-14, atol=1e-14)
        if reg.armature:
            np.testing.assert_array_equal(pi[10 * arm.n:11 * arm.n], arm.armature)
        assert len(reg.names) == reg.p == len(pi)
        joints, _ = arm.chain()
        for i, j in enumerate(joints):      # the round trip, rounding relative to max |J|
            J = j.body.J
            np.testing.assert_allclose(pseudo_inertia_from_parameters(pi[10 * i:10 * i + 10]), J,
                                       rtol=0, atol=1e-14 * max(1.0, np.abs(J).max()))
    assert parameters_from_pseudo_inertia(np.diag([1.0, 2.0, 3.0, 4.0]))[4:].tolist() == \
        [5.0, -0.0, 4.0, -0.0, -0.0, 3.0]


def test_regressor_reproduces_the_dynamics(puma, stanford, puma_friction):
    """Y(q, qd, qd, qdd) pi = inverse dynamics (armature and friction included) and
    Y(q, qd, qr, ar) pi = D ar + C(q, qd) qr + g + friction(qd), with C the
    Christoffel matrix of either engine.  Tolerance 1e-11 relative to |tau| + 1."""
    rng = np.random.default_rng(4)
    for arm in (puma, stanford, puma_friction, arms.random_arm(8, n=7)):
        reg = Regressor(arm)
        pi = reg.parameters()
        for _ in range(5):
            q = arm.random_state(rng)
            qd, qr, ar = rng.uniform(-2, 2, (3, arm.n))
            tau = arm.inverse_dynamics(q, qd, ar)
            scale = 1e-11 * (1 + np.abs(tau).max())
            np.testing.assert_allclose(reg.inverse_dynamics(q, qd, ar) @ pi, tau, rtol=0, atol=scale)
            for eng in (arm.lagrange, arm.pinocchio):
                want = (eng.mass_matrix(q) @ ar + eng.coriolis_matrix(q, qd) @ qr
                        + eng.gravity_torque(q) + eng.friction_torque(qd))
                np.testing.assert_allclose(reg(q, qd, qr, ar) @ pi, want, rtol=0, atol=scale)


# ---------------------------------------------------------------------------
# Plant variants
# ---------------------------------------------------------------------------


def test_with_payload_adds_the_payload(puma):
    plant = with_payload(puma, 2.0, com=(0.0, 0.0, 0.1))
    assert plant.n == puma.n and plant.name == "puma560+2kg"
    assert plant.links[-1].mass == pytest.approx(puma.links[-1].mass + 2.0)
    np.testing.assert_allclose(plant.links[-1].body.J, puma.links[-1].body.J + 2.0 * np.outer(
        [0, 0, 0.1, 1], [0, 0, 0.1, 1]), atol=1e-15)
    assert plant.links[:-1] == puma.links[:-1] and puma.links[-1].mass == 0.09  # original untouched
    # superposition: g(plant) - g(arm) is the gravity torque of the payload alone
    alone = md.Manipulator([dataclasses.replace(l, mass=0.0, inertia=np.zeros((3, 3)), motor_inertia=0.0)
                            for l in puma.links[:-1]]
                           + [dataclasses.replace(puma.links[-1], mass=2.0, com=(0, 0, 0.1),
                                                  inertia=np.zeros((3, 3)), motor_inertia=0.0)],
                           convention="standard")
    q = puma.random_state(np.random.default_rng(2), 4)
    np.testing.assert_allclose(plant.gravity_torque(q) - puma.gravity_torque(q),
                               alone.gravity_torque(q), rtol=0, atol=1e-12)
    with pytest.raises(md.ModelError, match="mass"):
        with_payload(puma, -1.0)


def test_with_scaled_inertia(puma):
    half = with_scaled_inertia(puma, 0.5)
    q = puma.random_state(np.random.default_rng(3))
    arm_diag = np.diag(puma.armature)
    np.testing.assert_allclose(half.mass_matrix(q) - arm_diag, 0.5 * (puma.mass_matrix(q) - arm_diag),
                               rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(half.gravity_torque(q), 0.5 * puma.gravity_torque(q), rtol=1e-12, atol=1e-12)
    with pytest.raises(md.ModelError, match="factor"):
        with_scaled_inertia(puma, [1.0, 2.0])


# ---------------------------------------------------------------------------
# Controllers
# ---------------------------------------------------------------------------


def test_controller_laws_and_saturation(puma):
    tr = Quintic(Q_START, Q_GOAL, 2.0)
    q = Q_START + 0.01
    qd = np.full(6, 0.1)
    q_d, qd_d, qdd_d = tr(0.7)
    kp, kd = np.arange(1.0, 7.0) * 100, np.arange(1.0, 7.0) * 10
    pd = PD(puma, kp, kd, trajectory=tr)
    np.testing.assert_allclose(pd(0.7, q, qd), kp * (q_d - q) + kd * (qd_d - qd))
    pdg = PDGravity(puma, kp, kd, trajectory=tr)
    np.testing.assert_allclose(pdg(0.7, q, qd), pd(0.7, q, qd) + puma.gravity_torque(q))
    ct = ComputedTorque(puma, 100.0, 20.0, trajectory=tr)
    v = qdd_d + 20.0 * (qd_d - qd) + 100.0 * (q_d - q)
    D, h, g = puma.lagrange.dynamics_terms(q, qd)
    np.testing.assert_allclose(ct(0.7, q, qd), D @ v + h + g, rtol=1e-10)
    # saturation joint by joint, at the controller's tau_max
    lim = np.array([5.0, 5.0, 5.0, np.inf, 0.01, 0.01])
    sat = PD(puma, kp, kd, trajectory=tr, tau_max=lim)
    raw = pd(0.7, q, qd)
    np.testing.assert_allclose(sat(0.7, q, qd), np.clip(raw, -lim, lim))
    assert np.all(np.abs(sat(0.7, q, qd)) <= lim)
    # a DH arm has no torque limits of its own; a URDF's <limit effort> are used
    assert model_torque_limits(puma) is None
    assert PD(puma, 1.0, 1.0).tau_max is None


TWO_LINK_URDF = """<?xml version="1.0"?>
<robot name="two">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="0.25 0 0"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l2"><inertial><origin xyz="0.2 0 0"/><mass value="0.5"/>
    <inertia ixx="0.005" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="5" velocity="2"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.5 0 0"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="2" velocity="2"/></joint>
</robot>
"""


def test_urdf_effort_limits_are_honoured():
    """A URDF arm's <limit effort> are the controllers' default tau_max."""
    from manipdyn.formats.urdf.reader import load_urdf

    arm = load_urdf(TWO_LINK_URDF)
    np.testing.assert_array_equal(model_torque_limits(arm), [5.0, 2.0])
    tr = Quintic([0.0, 0.0], [1.5, -1.5], 0.5)
    ct = ComputedTorque(arm, 400.0, 40.0)
    log = simulate(arm, ct, tr, duration=1.0)
    assert np.all(np.abs(log.tau) <= [5.0, 2.0])
    assert np.any(np.abs(log.tau[:, 0]) == 5.0)          # the limit was reached, and held
    assert ComputedTorque(arm, tau_max=np.inf).tau_max is None   # explicit: no limits


def test_adaptation_gains_follow_joint_inertias(puma, puma_friction):
    q = np.mean(puma.qlim, axis=1)
    d = np.diag(puma.mass_matrix(q))
    G = adaptation_gains(puma, 2.0)
    assert G.shape == (Regressor(puma).p,) == (66,)
    np.testing.assert_allclose(G[:60].reshape(6, 10), 2.0 * np.minimum.accumulate(d)[:, None] * np.ones(10))
    np.testing.assert_allclose(G[60:], 2.0 * d)                  # armature of joint j: D_jj
    assert adaptation_gains(puma_friction, 1.0).shape == (Regressor(puma_friction).p,) == (78,)


def test_controller_errors(puma):
    with pytest.raises(ValueError, match="no trajectory"):
        PD(puma, 1.0, 1.0)(0.0, np.zeros(6), np.zeros(6))
    with pytest.raises(ValueError, match="kp"):
        PD(puma, [1.0, 2.0], 1.0)
    with pytest.raises(ValueError, match="tau_max"):
        PD(puma, 1.0, 1.0, tau_max=-1.0)
    with pytest.raises(ValueError, match="gamma"):
        SlotineLi(puma, 1.0, 1.0, gamma=np.ones(3))
    with pytest.raises(md.StateError, match="q"):
        PD(puma, 1.0, 1.0, trajectory=Quintic(Q_START, Q_GOAL, 1.0))(0.0, np.zeros(5), np.zeros(6))


def test_adaptive_law_and_reset(puma):
    """tau = Y pi_hat - K_D s; forward-Euler update of pi_hat between calls; reset()."""
    tr = Quintic(Q_START, Q_GOAL, 2.0)
    sl = SlotineLi(puma, lam=5.0, kd=2.0, gamma=0.5, trajectory=tr)
    pi0 = sl.pi_hat.copy()
    q, qd = Q_START + 0.02, np.full(6, 0.2)
    q_d, qd_d, qdd_d = tr(0.3)
    qt, qtd = q - q_d, qd - qd_d
    s = qtd + 5.0 * qt
    Y = sl.regressor(q, qd, qd_d - 5.0 * qt, qdd_d - 5.0 * qtd)
    np.testing.assert_allclose(sl(0.3, q, qd), Y @ pi0 - 2.0 * s, rtol=1e-12)
    np.testing.assert_array_equal(sl.pi_hat, pi0)                # first call: nothing to integrate
    sl(0.31, q, qd)
    np.testing.assert_allclose(sl.pi_hat, pi0 - 0.01 * 0.5 * Y.T @ s, rtol=1e-12, atol=1e-15)
    sl.reset()
    np.testing.assert_array_equal(sl.pi_hat, pi0)


# ---------------------------------------------------------------------------
# Simulation
# ---------------------------------------------------------------------------


def test_rk4_conserves_energy_of_the_free_arm(puma):
    """No torque, no friction: K + P is constant.  RK4's error per unit time is
    O(dt^4); halving dt must cut the drift by about 16 (between 8 and 32)."""
    zero = np.zeros(6)
    drift = []
    for dt in (4e-3, 2e-3):
        log = simulate(puma, lambda t, q, qd: zero, Quintic(Q_START, Q_START, 1.0), duration=0.4, dt=dt)
        E = puma.pinocchio.kinetic_energy(log.q, log.qd) + puma.pinocchio.potential_energy(log.q)
        drift.append(np.abs(E - E[0]).max())
    assert drift[1] < 1e-6
    assert 8 < drift[0] / drift[1] < 32


def test_computed_torque_perfect_model_tracks_quintic(puma):
    """Acceptance: perfect model, 1 kHz, 2 s quintic, max joint error < 1e-6 rad.

    What remains is the sampling: the torque is held over each step while the
    reference and D(q), h, g move, an acceleration error ~ jerk dt / 2 that the
    loop turns into e ~ jerk dt / (2 Kp).  For this path (jerk up to 60 |dq| / T^3
    ~ 7 rad/s^3) that is 3.5e-5 rad at Kp = 100 1/s^2, so the test uses a
    100 rad/s bandwidth (Kp = 1e4, Kd = 200, critically damped; 10 samples per
    1/wn).  The residual is O(dt): halving the rate doubles it."""
    path = Quintic(Q_START, Q_GOAL, 2.0)
    ctrl = ComputedTorque(puma, kp=1e4, kd=200.0)
    log = simulate(puma, ctrl, path, duration=2.0, dt=1e-3)
    err = np.abs(log.e).max()
    print(f"\ncomputed torque, perfect model, 1 kHz: max |e| = {err:.3e} rad")
    assert err < 1e-6
    assert log.t.shape == (2001,) and log.q.shape == log.tau.shape == (2001, 6)
    np.testing.assert_array_equal(log.q[0], Q_START)
    coarse = simulate(puma, ctrl, path, duration=2.0, dt=2e-3)
    ratio = np.abs(coarse.e).max() / err
    assert 1.6 < ratio < 2.4, ratio


def test_payload_study(puma, record_property):
    """Acceptance: a 2 kg payload 0.1 m out along z of the last link's frame, unknown
    to the controllers; the 6 s demo path (cli.demo_path: every joint swinging
    out of step with the others, up to 0.6 rad); all controllers tuned to a
    10 rad/s bandwidth, critically damped, and Slotine-Li with the demo's
    adaptation gain (cli.make_controller, DEFAULT_GAMMA, adaptation_gains).  The
    adaptive controller's RMS error over the final second (all joints) must be
    at most 1/5 of computed torque's with the wrong model (measured: about
    1/27).  The same controller with Gamma = 0 must do about as badly as
    computed torque: the gain comes from the adaptation."""
    T = 6.0
    plant = with_payload(puma, 2.0, com=(0.0, 0.0, 0.1))
    path = demo_path(puma, T)
    final = {}
    report = []
    for key, kind, gamma in (("PD + gravity", "pdg", None), ("computed torque", "ct", None),
                             ("adaptive", "adaptive", DEFAULT_GAMMA), ("adaptive, Gamma = 0", "adaptive", 0.0)):
        ctrl = make_controller(kind, puma, gamma=DEFAULT_GAMMA if gamma is None else gamma)
        log = simulate(puma, ctrl, path, duration=T, plant=plant)
        last = log.e[log.t >= T - 1.0]
        final[key] = float(np.sqrt(np.mean(last**2)))
        report.append(f"{key:<22} RMS {np.sqrt(np.mean(log.e**2)):.3e}  final second "
                      f"{final[key]:.3e}  max {np.abs(log.e).max():.3e} rad  "
                      f"peak torque {log.peak_torque().max():.1f} N m")
        record_property(f"rms_final_second[{key}]", final[key])
    print("\n" + "\n".join(report))
    assert final["adaptive"] <= final["computed torque"] / 5
    assert final["computed torque"] < final["PD + gravity"]
    assert final["adaptive, Gamma = 0"] > final["computed torque"] / 2


def test_unstable_loop_raises_diverged_not_nan(puma):
    """Negative damping drives the arm away: SimulationDiverged says when and where,
    carries a finite log, and nothing returns NaN."""
    path = Quintic(Q_START, Q_GOAL, 2.0)
    kd = make_controller("pd", puma).kd
    # PD refuses a negative gain (tests/test_user_findings.py), so the unstable law is written out:
    # velocity fed back with the wrong sign
    def negative_damping(t, q, qd):
        return kd * qd

    with pytest.raises(SimulationDiverged, match=r"diverged at t = [0-9.]+ s .*joint \d qd = .* beyond"
                       ) as exc:
        simulate(puma, negative_damping, path, duration=10.0)
    err = exc.value
    assert isinstance(err, RuntimeError) and err.quantity == "qd" and 1 <= err.joint <= 6
    assert 0 < err.t < 10 and abs(err.value) > 1000
    assert np.all(np.isfinite(err.log.q)) and np.all(np.isfinite(err.log.tau))
    assert err.log.t[-1] < err.t

    with pytest.raises(SimulationDiverged, match=r"tau = nan"):
        simulate(puma, lambda t, q, qd: np.full(6, np.nan), path, duration=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # and no numpy warning on the way
        with pytest.raises(SimulationDiverged, match="diverged at t = 0.001 s"):
            simulate(puma, lambda t, q, qd: np.full(6, 1e200), path, duration=1.0)


def test_simulate_input_errors(puma):
    path = Quintic(Q_START, Q_GOAL, 1.0)
    ct = ComputedTorque(puma)
    with pytest.raises(ValueError, match="plant"):
        simulate(puma, ct, path, plant=arms.random_arm(1, n=5))
    with pytest.raises(ValueError, match="dt"):
        simulate(puma, ct, path, dt=0.0)
    with pytest.raises(ValueError, match="trajectory"):
        simulate(puma, lambda t, q, qd: np.zeros(6), None, duration=1.0)
    log = simulate(puma, ct, path)              # duration defaults to the path's end
    assert log.t[-1] == pytest.approx(1.0)
    assert "computed torque" in log.summary()


# ---------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------


def test_cli_track_prints_summary(capsys):
    from manipdyn.cli import main

    assert main(["track", "puma560", "--duration", "1.5"]) == 0
    out = capsys.readouterr().out
    assert "computed torque" in out and "RMS error" in out and "peak torque" in out


def test_cli_track_compare_plot(tmp_path, capsys):
    pytest.importorskip("matplotlib", reason="matplotlib (the plot extra) is not installed: the figure is not tested")
    from manipdyn.cli import main

    png = tmp_path / "cmp.png"
    assert main(["track", "stanford", "--compare", "--payload", "1", "--duration", "1.5",
                 "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    for label in ("PD", "PD + gravity", "computed torque", "adaptive (Slotine-Li)"):
        assert label in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["cmp.png"]    # no temporary left behind


def test_cli_track_bad_input_and_divergence(capsys, monkeypatch):
    from manipdyn.cli import main

    assert main(["track", "puma560", "--duration", "-1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--duration" in err[0]
    assert main(["track", "puma560", "--payload", "-2"]) == 2
    capsys.readouterr()
    # an adaptation gain far too high for 1 kHz: reported, exit 1
    assert main(["track", "puma560", "--controller", "adaptive", "--gamma", "1000",
                 "--duration", "1"]) == 1
    assert "diverged at t =" in capsys.readouterr().out
    # matplotlib missing: one line naming the extra
    import builtins

    real_import = builtins.__import__

    def no_mpl(name, *a, **k):
        if name == "matplotlib" or name.startswith("matplotlib."):
            raise ImportError("no matplotlib")
        return real_import(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_mpl)
    assert main(["track", "puma560", "--plot", "x.png"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pip install 'manipdyn[plot]'" in err[0]
    # the same hint as the README's
    import guide

    readme = guide.TEXT                            # the README and the guide's pages
    assert "pip install 'manipdyn[plot]'" in readme and "pip install -e '.[plot]'" in err[0]


@pytest.mark.parametrize("argv, message", [
    (["--duration", "inf"], "--duration: must be a finite number"),
    (["--gamma", "-1"], "--gamma: must be >= 0"),
    (["--bandwidth", "nan"], "--bandwidth: must be a finite number"),
    (["--duration", "1e9", "--dt", "1e-9"], "--duration: must be > 0 s and at most 300 s"),
    (["--duration", "100", "--dt", "1e-5"], "more than 2e+06 steps"),
    (["--plot", "/nonexistent-folder/x.png"], "--plot /nonexistent-folder/x.png: expected a writable file path"),
])
def test_cli_track_bad_options_are_one_line(argv, message, capsys):
    from manipdyn.cli import main

    assert main(["track", "puma560", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
