"""Drives: transmissions with couplings, rotor inertia R^T diag(Jm) R, friction laws.

Closed forms first (a planar 2R arm whose second motor also turns with joint 1),
then identities (power balance, the diagonal case), then both engines against
each other on random arms with coupled transmissions and every friction kind,
the regressor columns of every linear friction term and side, model files,
and the errors.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.check.crosscheck import draw_states
from manipdyn.model.drive import DEFAULT_SMOOTHING, Friction, FrictionTerms, Transmission
from manipdyn.model.random_arms import random_arm

# float64 sums of a few products of O(1..100) numbers: rounding stays near 1e-13
# relative; 1e-10 is far below any modelling error (1e-3 and up)
TOL = 1e-10


def _planar_2r(G1=50.0, G2=-30.0, c=12.0, Jm=(2e-4, 3e-4)):
    """Planar 2R arm (standard DH, alpha = 0): point masses m1, m2 at the link ends."""
    links = [md.DHLink(a=0.4, mass=2.0, com=(0, 0, 0), inertia=[0, 0, 0], motor_inertia=Jm[0], gear_ratio=G1),
             md.DHLink(a=0.3, mass=1.5, com=(0, 0, 0), inertia=[0, 0, 0], motor_inertia=Jm[1], gear_ratio=G2)]
    tr = Transmission.from_gear_ratios([G1, G2], coupling=[[2, 1, c]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)  # point masses have no volume
        return md.Manipulator(links, "standard", gravity=(0, -9.81, 0), transmission=tr, name="planar2r")


def test_closed_form_mass_matrix_of_a_coupled_2r_arm():
    """Point masses: D_rigid = [[m1 l1^2 + m2 (l1^2 + l2^2 + 2 l1 l2 c2), m2 (l2^2 + l1 l2 c2)],
    [., m2 l2^2]]; motor 2 turns at c qd1 + G2 qd2, so the rotors add
    [[G1^2 Jm1 + c^2 Jm2, c G2 Jm2], [c G2 Jm2, G2^2 Jm2]] (written out by hand)."""
    G1, G2, c, Jm1, Jm2 = 50.0, -30.0, 12.0, 2e-4, 3e-4
    arm = _planar_2r(G1, G2, c, (Jm1, Jm2))
    m1, m2, l1, l2 = 2.0, 1.5, 0.4, 0.3
    for q2 in (0.0, 0.7, -2.1):
        q = np.array([0.3, q2])
        c2 = np.cos(q2)
        D = np.array([[m1 * l1**2 + m2 * (l1**2 + l2**2 + 2 * l1 * l2 * c2), m2 * (l2**2 + l1 * l2 * c2)],
                      [m2 * (l2**2 + l1 * l2 * c2), m2 * l2**2]])
        D += np.array([[G1**2 * Jm1 + c**2 * Jm2, c * G2 * Jm2], [c * G2 * Jm2, G2**2 * Jm2]])
        for eng in (arm.lagrange, arm.pinocchio):
            np.testing.assert_allclose(eng.mass_matrix(q), D, rtol=TOL, atol=TOL, err_msg=eng.name)
        qd, qdd = np.array([0.4, -1.1]), np.array([2.0, 0.5])
        # K = qd^T D qd / 2, and the rotor torque of RNEA is the rotor block times qdd
        for eng in (arm.lagrange, arm.pinocchio):
            assert eng.kinetic_energy(q, qd) == pytest.approx(0.5 * qd @ D @ qd, rel=TOL)
            tau = eng.inverse_dynamics(q, qd, qdd)
            np.testing.assert_allclose(tau, D @ qdd + eng.coriolis_torque(q, qd) + eng.gravity_torque(q),
                                       rtol=TOL, atol=TOL)
            np.testing.assert_allclose(eng.forward_dynamics(q, qd, tau), qdd, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(arm.armature, [G1**2 * Jm1, G2**2 * Jm2])   # R_kk^2 Jm_k, as before
    assert not np.allclose(np.diag(arm.rotor_inertia), arm.armature)          # c^2 Jm2 on D_11


def test_power_balances_and_maps_invert():
    rng = np.random.default_rng(1)
    R = np.diag(rng.uniform(10, 100, 5) * rng.choice([-1, 1], 5)) + np.triu(rng.normal(size=(5, 5)), 1) * 5
    tr = Transmission(R, motor_offset=rng.normal(size=5), torque_constant=rng.uniform(0.1, 1, 5))
    qd, tau_m = rng.normal(size=(7, 5)), rng.normal(size=(7, 5))
    np.testing.assert_allclose(np.sum(tau_m * tr.motor_velocities(qd), axis=1),
                               np.sum(tr.joint_torques(tau_m) * qd, axis=1), rtol=1e-12)
    q = rng.normal(size=(7, 5))
    np.testing.assert_allclose(tr.joint_positions(tr.motor_positions(q)), q, atol=1e-12)
    np.testing.assert_allclose(tr.joint_velocities(tr.motor_velocities(qd)), qd, atol=1e-12)
    np.testing.assert_allclose(tr.motor_torques(tr.joint_torques(tau_m)), tau_m, atol=1e-12)
    np.testing.assert_allclose(tr.joint_accelerations(tr.motor_accelerations(q[0])), q[0], atol=1e-12)
    np.testing.assert_allclose(tr.motor_positions(np.zeros(5)), tr.motor_offset)
    np.testing.assert_allclose(tr.motor_torques_from_current(np.ones(5)), tr.torque_constant)
    assert not tr.is_diagonal and len(tr.coupling) == 10
    assert tr.R.flags.writeable is False and tr.motor_offset.flags.writeable is False


def test_rotor_inertia_is_g2_jm_when_diagonal():
    arm = random_arm(5, n=6, rotors=True)
    assert arm.transmission.is_diagonal
    G = np.array([l.gear_ratio for l in arm.links])
    Jm = np.array([l.motor_inertia for l in arm.links])
    np.testing.assert_allclose(arm.rotor_inertia, np.diag(G**2 * Jm), rtol=1e-15)
    np.testing.assert_array_equal(arm.armature, [l.armature for l in arm.links])


def test_default_friction_is_the_links_sharp_law():
    links = [md.DHLink(a=0.3, mass=1, com=(-0.1, 0, 0), inertia=[.01, .02, .02], friction_viscous=0.5,
                       friction_coulomb=0.2)] * 2
    arm = md.Manipulator(links, "standard")
    f = arm.friction_model
    assert (f.side, f.smoothing, f.deadband, f.terms) == ("joint", 0.0, 0.0, ("viscous", "coulomb"))
    np.testing.assert_array_equal(arm.friction, [[0.5, 0.5], [0.2, 0.2]])
    qd = np.array([0.0, -1e-9])
    for eng in (arm.lagrange, arm.pinocchio):
        np.testing.assert_array_equal(eng.friction_torque(qd), [0.0, -0.5e-9 - 0.2])   # sign(0) = 0
    assert md.Manipulator([links[0]], "standard").transmission == Transmission([[1.0]])


def _laws(n, rng):
    return {
        "viscous+coulomb smooth": Friction(viscous=rng.random(n), coulomb=rng.random(n)),
        "asymmetric+offset motor": Friction(viscous=rng.random(n) * 1e-3, coulomb_pos=rng.random(n) * 1e-2,
                                            coulomb_neg=rng.random(n) * 2e-2, offset=rng.normal(size=n),
                                            side="motor", smoothing=0.5),
        "deadband sharp joint": Friction(coulomb=rng.random(n), smoothing=0.0, deadband=0.3),
        "stribeck": Friction(coulomb=rng.random(n), stribeck_level=rng.random(n), smoothing=0.02,
                             stribeck_velocity=0.1 + rng.random(n), stribeck_exponent=1.5),
        "sigmoid motor": Friction(sigmoid_A=rng.random(n) * 1e-2, sigmoid_alpha=1 + 5 * rng.random(n),
                                  sigmoid_p3=0.1 * rng.normal(size=n), side="motor"),
        "sharp motor": Friction(viscous=rng.random(n) * 1e-3, coulomb=rng.random(n) * 1e-2, smoothing=0.0,
                                side="motor"),
    }


def _coupled_arm(seed, law_name, n=6):
    base = random_arm(seed, n=n, rotors=True)
    G = [l.gear_ratio for l in base.links]
    tr = Transmission.from_gear_ratios(G, coupling=[[n, n - 1, 32.0], [2, 3, -5.0]])
    law = _laws(n, np.random.default_rng(seed))[law_name]
    return md.Manipulator(base.links, base.convention, transmission=tr, friction=law, name=law_name)


@pytest.mark.parametrize("law", list(_laws(2, np.random.default_rng(0))))
@pytest.mark.parametrize("seed", [3, 11])
def test_engines_agree_with_coupled_drive_and_every_friction_kind(seed, law):
    arm = _coupled_arm(seed, law)
    assert not arm.transmission.is_diagonal and arm.pinocchio.drive_extras
    report = md.crosscheck(arm, samples=150, seed=seed)
    assert report.ok, str(report)
    assert "qdd" in report.quantities and not report.not_compared
    q, qd, qdd = draw_states(arm, 40, seed)
    np.testing.assert_allclose(arm.pinocchio.friction_torque(qd), arm.lagrange.friction_torque(qd),
                               rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("law", list(_laws(2, np.random.default_rng(0))))
def test_regressor_with_armature_and_the_friction_law_gives_tau(law):
    arm = _coupled_arm(4, law)
    q, qd, qdd = draw_states(arm, 30, 2)
    f = arm.friction_model
    pi = arm.parameters(armature=True, friction=f)
    assert len(pi) == len(md.model.parameters.parameter_names(arm.n, True, f)) == 10 * arm.n + arm.n + len(f.parameter_names())
    for eng in (arm.lagrange, arm.pinocchio):
        Y = eng.regressor(q, qd, qdd, armature=True, friction=f)
        tau = eng.inverse_dynamics(q, qd, qdd)
        np.testing.assert_allclose(Y @ pi, tau, rtol=1e-9, atol=1e-9 * np.abs(tau).max(), err_msg=eng.name)
    np.testing.assert_allclose(arm.lagrange.regressor(q, qd, qdd, armature=True, friction=f),
                               arm.pinocchio.regressor(q, qd, qdd, armature=True, friction=f), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("side", ["joint", "motor"])
@pytest.mark.parametrize("terms", [("viscous",), ("viscous", "coulomb"), ("asymmetric",), ("offset",),
                                   ("viscous", "asymmetric", "offset")])
def test_columns_times_parameters_is_the_torque(side, terms):
    rng = np.random.default_rng(5)
    n = 4
    R = np.diag([40.0, -25.0, 10.0, 8.0])
    R[3, 2] = 6.0
    tr = Transmission(R)
    law = FrictionTerms(terms, side=side, smoothing=0.05).as_friction(n)
    kw = {t: rng.random(n) for t in law.terms if t != "asymmetric"}
    if "asymmetric" in law.terms:
        kw.update(coulomb_pos=rng.random(n), coulomb_neg=rng.random(n))
    law = Friction(**kw, side=side, smoothing=0.05)
    qd = rng.normal(size=(20, n))
    Y = law.columns(qd, tr)
    np.testing.assert_allclose(Y @ law.parameters(tr), law.torque(qd, tr), rtol=1e-12, atol=1e-12)
    assert Y.shape == (20, n, len(law.parameter_names()))
    if side == "motor" and "viscous" in terms:
        # the reflected viscous parameter of a diagonal entry is R_kk^2 Fv_k (joint-side units)
        np.testing.assert_allclose(law.parameters(tr)[:n], np.diag(R) ** 2 * kw["viscous"])


def test_motor_side_law_on_a_diagonal_transmission_equals_the_joint_side_one():
    G = np.array([50.0, 20.0])
    fv_m, fc_m = np.array([1e-3, 2e-3]), np.array([0.01, 0.03])
    motor = Friction(viscous=fv_m, coulomb=fc_m, side="motor", smoothing=0.0)
    joint = Friction(viscous=G**2 * fv_m, coulomb=G * fc_m, smoothing=0.0)
    tr = Transmission(np.diag(G))
    qd = np.random.default_rng(0).normal(size=(10, 2))
    np.testing.assert_allclose(motor.torque(qd, tr), joint.torque(qd), rtol=1e-13)
    np.testing.assert_allclose(motor.parameters(tr), joint.parameters(), rtol=1e-13)
    np.testing.assert_allclose(motor.columns(qd, tr), joint.columns(qd), rtol=1e-13)


def test_booleans_keep_their_meaning():
    arm = random_arm(2, n=3, rotors=True)
    q, qd, qdd = draw_states(arm, 5, 0)
    Y = arm.lagrange.regressor(q, qd, qdd, armature=True, friction=True)
    assert Y.shape[-1] == 10 * 3 + 3 + 6
    np.testing.assert_array_equal(Y[..., 30:33], qdd[:, :, None] * np.eye(3))
    np.testing.assert_array_equal(Y[..., 36:39], np.sign(qd)[:, :, None] * np.eye(3))
    assert md.model.parameters.parameter_names(3, True, True)[-1] == "joint3.fc"
    assert md.model.parameters.parameter_names(3, False, "offset")[-1] == "joint3.offset"
    assert md.model.parameters.parameter_count(3, False, FrictionTerms(("asymmetric",))) == 36


def test_friction_true_on_a_motor_side_arm_is_refused():
    arm = _coupled_arm(4, "sharp motor")
    with pytest.raises(md.ModelError, match="cannot be written in the asked-for friction columns: side 'motor'"):
        arm.parameters(friction=True)


def test_derivative_matches_finite_differences():
    rng = np.random.default_rng(8)
    tr = Transmission(np.array([[30.0, 0.0], [4.0, -20.0]]))
    for name, law in _laws(2, rng).items():
        if law.smoothing == 0 or law.deadband:
            continue                      # kinks: derivative conventions, checked below
        qd = rng.normal(size=2) * 0.3
        h = 1e-6
        num = np.column_stack([(law.torque(qd + h * e, tr) - law.torque(qd - h * e, tr)) / (2 * h)
                               for e in np.eye(2)])
        # central differences: error ~ h^2 f''' (f''' up to ~1e3 for the steep laws here)
        np.testing.assert_allclose(law.derivative(qd, tr), num, rtol=1e-5, atol=1e-5, err_msg=name)
    sharp = Friction(viscous=[1.0], coulomb=[2.0], smoothing=0.0)
    np.testing.assert_array_equal(sharp.derivative(np.array([[0.0], [1.0]])), [[[1.0]], [[1.0]]])


def test_smooth_sign_default():
    assert DEFAULT_SMOOTHING == 0.01
    f = Friction(coulomb=[1.0])
    assert f.smoothing == DEFAULT_SMOOTHING
    assert f.torque(np.array([1e-3]))[0] == pytest.approx(np.tanh(0.1))      # encoder dither: small
    assert f.torque(np.array([0.1]))[0] == pytest.approx(1.0, abs=1e-8)      # moving: the sign


def test_model_file_round_trip(tmp_path):
    arm = _coupled_arm(6, "asymmetric+offset motor")
    arm = md.Manipulator(arm.links, arm.convention, name="rt", friction=arm.friction_model,
                         transmission=Transmission(arm.transmission.R, motor_offset=np.linspace(0, 1, 6),
                                                   torque_constant=np.full(6, 0.25)))
    for law in list(_laws(6, np.random.default_rng(1)).values()) + [Friction(viscous=np.ones(6), smoothing=0.0)]:
        a = md.Manipulator(arm.links, arm.convention, name="rt", friction=law, transmission=arm.transmission)
        md.save(a, tmp_path / "a.toml")
        b = md.load(tmp_path / "a.toml")
        assert b == a and b.friction_model == law and b.transmission == a.transmission
    text = (tmp_path / "a.toml").read_text()
    assert "[transmission]" in text and "coupling = [[2, 3, -5.0], [6, 5, 32.0]]" in text


def _toml(extra, links_extra=""):
    return f'''format = "manipdyn-model/1"
name = "t"
convention = "standard"
[[links]]
joint = "revolute"
a = 0.3
alpha = 0.0
d = 0.0
theta = 0.0
mass = 1.0
com = [-0.1, 0.0, 0.0]
inertia = [0.01, 0.02, 0.02]
gear_ratio = 10.0
{links_extra}
[[links]]
joint = "revolute"
a = 0.2
alpha = 0.0
d = 0.0
theta = 0.0
mass = 1.0
com = [-0.1, 0.0, 0.0]
inertia = [0.01, 0.02, 0.02]
gear_ratio = 10.0
{extra}
'''


@pytest.mark.parametrize("extra, links_extra, message", [
    ("[transmission]\ncoupling = [[3, 1, 2.0]]", "", r"coupling\[0\]: motor_row must be an integer 1..2"),
    ("[transmission]\ncoupling = [[2, 1, 2.0], [2, 1, 3.0]]", "", r"entry \[2, 1\] is given twice"),
    ("[transmission]\ncoupling = [[1, 1, 2.0]]", "", "on the diagonal"),
    ("[transmission]\ncoupling = [[1, 2, 10.0], [2, 1, 10.0]]", "", "the matrix R .* is singular"),
    ("[transmission]\ngears = 1", "", r"unknown key\(s\) \['transmission.gears'\]"),
    ("[transmission]\ntorque_constant = [1.0]", "", r"key 'transmission.torque_constant': expected a list of 2"),
    ("[friction]\nside = \"belt\"\nviscous = [1.0, 1.0]", "", "'side' must be 'joint' or 'motor'"),
    ("[friction]\nviscous = [1.0, -1.0]", "", r"'viscous' must be >= 0"),
    ("[friction]\ncoulomb = [1.0, 1.0]\ncoulomb_pos = [1.0, 1.0]\ncoulomb_neg = [1.0, 1.0]", "", "not both"),
    ("[friction]\nstribeck_level = [1.0, 1.0]", "", "'stribeck_level' and 'stribeck_velocity' go together"),
    ("[friction]\nsmoothing = -1.0\nviscous = [1.0, 1.0]", "", "'smoothing' must be a finite number >= 0"),
    ("[friction]\nviscous = [1.0, 1.0]", "friction_viscous = 0.5", "both 'friction' and the links' friction"),
    ("[friction]\nviscosity = [1.0, 1.0]", "", r"unknown key\(s\) \['friction.viscosity'\]"),
])
def test_model_file_errors_name_file_and_key(tmp_path, extra, links_extra, message):
    path = tmp_path / "bad.toml"
    path.write_text(_toml(extra, links_extra))
    with pytest.raises(md.ModelError, match=message) as exc:
        md.load(path)
    assert str(path) in str(exc.value)


def test_bad_python_input():
    with pytest.raises(md.ModelError, match="condition number"):
        Transmission([[1.0, 1.0], [1.0, 1.0 + 1e-13]])
    with pytest.raises(md.ModelError, match="no torque_constant"):
        Transmission(np.eye(2)).motor_torques_from_current([1.0, 2.0])
    with pytest.raises(md.ModelError, match="'R' must be a square"):
        Transmission([1.0, 2.0])
    with pytest.raises(md.ModelError, match=r"R\[2, 2\] = 5.0 but joint 2's gear_ratio is 1.0"):
        md.Manipulator([md.DHLink(a=0.3, mass=1, com=(-.1, 0, 0), inertia=[.01, .02, .02])] * 2, "standard",
                       transmission=Transmission(np.diag([1.0, 5.0])))
    with pytest.raises(md.ModelError, match="needs the transmission"):
        Friction(viscous=[1.0], side="motor").torque(np.array([1.0]))
    with pytest.raises(md.StateError, match=r"qd: expected shape \(2,\)"):
        Friction(viscous=[1.0, 1.0]).torque(np.ones(3))
    with pytest.raises(md.ModelError, match="shape-needing term"):
        FrictionTerms(("stribeck",))
    with pytest.raises(md.ModelError, match="'sigmoid_alpha' must be > 0"):
        Friction(sigmoid_A=[1.0], sigmoid_alpha=[0.0], sigmoid_p3=[0.0])


def test_urdf_arm_identity_transmission_and_friction_override():
    text = md.to_urdf(random_arm(1, n=3))
    arm = md.load(text)
    assert arm.transmission == Transmission(np.eye(3)) and arm.friction_model is None
    R = np.diag([10.0, 20.0, 30.0])
    R[2, 1] = 4.0
    law = Friction(viscous=[1e-3] * 3, coulomb=[1e-2] * 3, side="motor")
    arm = md.formats.urdf.reader.load_urdf(text, transmission=Transmission(R), friction=law)
    assert arm.friction_model is law and arm.custom_drive
    assert md.crosscheck(arm, samples=50).ok
    with pytest.raises(md.ModelError, match="cannot send URDF arm"):
        md.check.scale.model_text(arm)
