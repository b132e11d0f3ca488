"""Closed-form arms: the trace-form engine against dynamics derived by hand.

Each test cites where its formulas come from.  Parameters and states are drawn
by Hypothesis (seeded under the ``ci`` profile) from ranges of real arms.

Tolerance used throughout (``_close``): the engine and the formula compute the
same numbers along different floating-point paths, each a few dozen operations
on O(1..100) quantities.  Each rounding is at most eps = 2.2e-16 relative to
the largest term involved, so both sides agree to ~1e-14 of ``scale`` (the
largest term of the formula); 1e-12 leaves two orders of margin and still
catches any modelling error (a wrong sign, a missing m c^2 term, a swapped
inertia axis), all of which are O(1) relative.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import manipdyn as md

import arms

G0 = 9.81
RTOL = 1e-12  # see the module docstring


def _close(actual, expected, scale):
    actual = np.asarray(actual, dtype=float)
    expected = np.asarray(expected, dtype=float)
    np.testing.assert_allclose(actual, expected, rtol=0, atol=RTOL * max(1.0, scale))


angle = st.floats(-math.pi, math.pi)
rate = st.floats(-3.0, 3.0)
length = st.floats(0.1, 1.0)
mass = st.floats(0.1, 10.0)
frac = st.floats(0.0, 1.0)


def bar_inertia(m, length_x, width_y, thick_z):
    """Solid cuboid about its centre, edges along x, y, z (e.g. Spong 2nd ed., Table 6.1):
    ``diag(m(w^2+t^2), m(l^2+t^2), m(l^2+w^2)) / 12`` -- physical for any sizes."""
    return np.diag([m * (width_y**2 + thick_z**2), m * (length_x**2 + thick_z**2),
                    m * (length_x**2 + width_y**2)]) / 12.0


# ---------------------------------------------------------------------------
# (a) Planar elbow (two-link planar) arm
# ---------------------------------------------------------------------------


def spong_planar_elbow(m1, m2, l1, lc1, lc2, I1, I2, g, q, qd, qdd):
    """Planar elbow manipulator, Spong, Hutchinson, Vidyasagar, "Robot Modeling and
    Control", 2nd ed. (2020), sec. 6.4 (1st ed. sec. 7.4.2); the same as Siciliano,
    Sciavicco, Villani, Oriolo, "Robotics: Modelling, Planning and Control", sec. 7.3.2
    with the motors removed.

    Arm in the x-y plane, q1 from the x axis, q2 relative to link 1, gravity
    along -y; ``lc`` the distance from joint i to link i's COM, ``I`` link i's
    moment of inertia about the axis through its COM normal to the plane::

        d11 = m1 lc1^2 + m2 (l1^2 + lc2^2 + 2 l1 lc2 cos q2) + I1 + I2
        d12 = d21 = m2 (lc2^2 + l1 lc2 cos q2) + I2
        d22 = m2 lc2^2 + I2
        c121 = c211 = c221 = -m2 l1 lc2 sin q2 =: hh,   c112 = -hh, other c = 0
        phi1 = (m1 lc1 + m2 l1) g cos q1 + m2 lc2 g cos(q1 + q2)
        phi2 = m2 lc2 g cos(q1 + q2)

    so ``h1 = hh (2 qd1 qd2 + qd2^2)`` and ``h2 = -hh qd1^2``.
    Returns ``(D, h, phi, tau, K, P)`` with ``P = g (m1 lc1 s1 + m2 (l1 s1 + lc2 s12))``.
    """
    q1, q2 = q
    c2, s2 = math.cos(q2), math.sin(q2)
    d11 = m1 * lc1**2 + m2 * (l1**2 + lc2**2 + 2 * l1 * lc2 * c2) + I1 + I2
    d12 = m2 * (lc2**2 + l1 * lc2 * c2) + I2
    d22 = m2 * lc2**2 + I2
    D = np.array([[d11, d12], [d12, d22]])
    hh = -m2 * l1 * lc2 * s2
    h = np.array([hh * (2 * qd[0] * qd[1] + qd[1] ** 2), -hh * qd[0] ** 2])
    phi1 = (m1 * lc1 + m2 * l1) * g * math.cos(q1) + m2 * lc2 * g * math.cos(q1 + q2)
    phi2 = m2 * lc2 * g * math.cos(q1 + q2)
    phi = np.array([phi1, phi2])
    tau = D @ qdd + h + phi
    K = 0.5 * qd @ D @ qd
    P = g * (m1 * lc1 * math.sin(q1) + m2 * (l1 * math.sin(q1) + lc2 * math.sin(q1 + q2)))
    return D, h, phi, tau, K, P


def planar_elbow_arm(convention, m1, m2, l1, l2, lc1, lc2, I1_tensor, I2_tensor, z1=0.0, z2=0.0,
                     rotors=None):
    """The planar elbow arm as DH links; gravity (0, -9.81, 0) in the base frame.

    Standard DH: frame i sits at the distal end of link i with x_i along the
    link, so link i's COM is at ``(lc_i - l_i, 0, z_i)`` in frame i.  Modified DH:
    frame i sits at joint i, so the COM is at ``(lc_i, 0, z_i)``; row 2 carries
    ``a_1 = l1``.  ``z_i`` shifts the COM out of the plane, which must change
    nothing with gravity in the plane.
    """
    rotors = rotors or [(0.0, 1.0), (0.0, 1.0)]
    if convention == "standard":
        links = [
            md.DHLink("revolute", a=l1, mass=m1, com=(lc1 - l1, 0, z1), inertia=I1_tensor,
                      motor_inertia=rotors[0][0], gear_ratio=rotors[0][1]),
            md.DHLink("revolute", a=l2, mass=m2, com=(lc2 - l2, 0, z2), inertia=I2_tensor,
                      motor_inertia=rotors[1][0], gear_ratio=rotors[1][1]),
        ]
    else:
        links = [
            md.DHLink("revolute", a=0.0, mass=m1, com=(lc1, 0, z1), inertia=I1_tensor,
                      motor_inertia=rotors[0][0], gear_ratio=rotors[0][1]),
            md.DHLink("revolute", a=l1, mass=m2, com=(lc2, 0, z2), inertia=I2_tensor,
                      motor_inertia=rotors[1][0], gear_ratio=rotors[1][1]),
        ]
    return md.Manipulator(links, convention=convention, gravity=(0.0, -G0, 0.0), strict=True)


def _check_all(arm, expected, q, qd, qdd):
    D, h, g, tau, K, P = expected
    scale = max(np.max(np.abs(D)) * (1 + np.max(np.abs(qd)) ** 2 + np.max(np.abs(qdd))),
                np.max(np.abs(g)), abs(P))
    lag = arm.lagrange
    _close(lag.mass_matrix(q), D, scale)
    _close(lag.coriolis_torque(q, qd), h, scale)
    _close(lag.gravity_torque(q), g, scale)
    _close(lag.inverse_dynamics(q, qd, qdd), tau, scale)
    De, he, ge = lag.dynamics_terms(q, qd)
    _close(De, D, scale)
    _close(he, h, scale)
    _close(ge, g, scale)
    _close(lag.kinetic_energy(q, qd), K, scale)
    _close(lag.potential_energy(q), P, scale)


@pytest.mark.parametrize("convention", ["standard", "modified"])
@pytest.mark.parametrize("body", ["point", "bar"])
@given(m1=mass, m2=mass, l1=length, l2=length, f1=frac, f2=frac,
       q=st.tuples(angle, angle), qd=st.tuples(rate, rate), qdd=st.tuples(rate, rate))
def test_planar_elbow_spong(convention, body, m1, m2, l1, l2, f1, f2, q, qd, qdd):
    """Two-link planar arm, point masses or solid bars, against Spong et al.
    (2nd ed., sec. 6.4, "planar elbow manipulator"); see :func:`spong_planar_elbow`."""
    lc1, lc2 = f1 * l1, f2 * l2
    if body == "point":
        I1t = I2t = np.zeros((3, 3))
    else:
        I1t = bar_inertia(m1, l1, 0.05, 0.03)
        I2t = bar_inertia(m2, l2, 0.04, 0.02)
    arm = planar_elbow_arm(convention, m1, m2, l1, l2, lc1, lc2, I1t, I2t)
    q, qd, qdd = np.array(q), np.array(qd), np.array(qdd)
    # I_i of the textbook = moment about the COM axis normal to the plane = tensor zz
    expected = spong_planar_elbow(m1, m2, l1, lc1, lc2, I1t[2, 2], I2t[2, 2], G0, q, qd, qdd)
    _check_all(arm, expected, q, qd, qdd)


@pytest.mark.parametrize("convention", ["standard", "modified"])
@given(seed=st.integers(0, 2**32 - 1), q=st.tuples(angle, angle), qd=st.tuples(rate, rate),
       qdd=st.tuples(rate, rate), z=st.tuples(st.floats(-0.2, 0.2), st.floats(-0.2, 0.2)))
def test_planar_elbow_general_tensor(convention, seed, q, qd, qdd, z):
    """Same textbook formulas with a general physical inertia tensor whose principal
    axes are NOT the link axes, and the COM lifted out of the plane by z.

    For motion in the x-y plane the angular velocity is along z, so only the
    tensor's zz element about the COM enters (Spong's ``I_i``); the products
    I_xz, I_yz and the out-of-plane COM offset load the joints only through
    moments about x and y, which the joints do not measure.  Any leakage of
    them into D, h or g would be a sign or axis mix-up.
    """
    rng = np.random.default_rng(seed)
    m1, m2 = rng.uniform(0.5, 5.0, 2)
    l1, l2 = rng.uniform(0.2, 1.0, 2)
    lc1, lc2 = rng.uniform(0, 1, 2) * (l1, l2)
    I1t, I2t = arms.random_physical_inertia(rng), arms.random_physical_inertia(rng)
    arm = planar_elbow_arm(convention, m1, m2, l1, l2, lc1, lc2, I1t, I2t, z1=z[0], z2=z[1])
    q, qd, qdd = np.array(q), np.array(qd), np.array(qdd)
    expected = spong_planar_elbow(m1, m2, l1, lc1, lc2, I1t[2, 2], I2t[2, 2], G0, q, qd, qdd)
    _check_all(arm, expected, q, qd, qdd)


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_planar_elbow_rotor_inertia(convention):
    """Rotors: CONVENTIONS.md ("Pinocchio and the other side of the check") adds the
    reflected inertia ``G^2 J_m`` to D's diagonal and ``1/2 G^2 J_m qd^2`` to K,
    nothing else (the chapter's remark after eq. 2.22 leaves their form open).
    Gear ratios are signed: only G^2 may enter."""
    m1, m2, l1, l2, lc1, lc2 = 2.0, 1.5, 0.6, 0.5, 0.3, 0.2
    I1t, I2t = bar_inertia(m1, l1, 0.05, 0.05), bar_inertia(m2, l2, 0.04, 0.04)
    rotors = [(2e-4, 100.0), (1e-4, -50.0)]
    arm = planar_elbow_arm(convention, m1, m2, l1, l2, lc1, lc2, I1t, I2t, rotors=rotors)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-3, 3, (3, 2))
        D, h, g, _, _, P = spong_planar_elbow(m1, m2, l1, lc1, lc2, I1t[2, 2], I2t[2, 2], G0, q, qd, qdd)
        D = D + np.diag([2e-4 * 100.0**2, 1e-4 * 50.0**2])
        tau = D @ qdd + h + g
        _check_all(arm, (D, h, g, tau, 0.5 * qd @ D @ qd, P), q, qd, qdd)


# ---------------------------------------------------------------------------
# (b) Single pendulum
# ---------------------------------------------------------------------------


def pendulum_arm(convention, m, l, body, gravity_axis):
    """A pendulum of length l (COM at distance ``lc`` from the pivot).

    Angle q measured from the downward vertical.  Two ways to say "down":

    * ``gravity_axis="x"``: gravity (+9.81, 0, 0), base x points down, no offset;
    * ``gravity_axis="-y"``: gravity (0, -9.81, 0) and a DH offset theta = -pi/2,
      which puts q = 0 along -y (exercises the fixed offset of a revolute joint).

    ``body="point"``: point mass at the tip, ``lc = l``, ``I_pivot = m l^2``;
    ``body="rod"``: thin uniform rod, ``lc = l/2``, ``I_pivot = m l^2 / 3``.
    """
    theta = 0.0 if gravity_axis == "x" else -math.pi / 2
    gravity = (G0, 0.0, 0.0) if gravity_axis == "x" else (0.0, -G0, 0.0)
    if body == "point":
        lc, inertia = l, np.zeros(3)
    else:  # rod along x: m l^2 / 12 about y and z, zero about its own axis
        lc, inertia = l / 2, np.array([0.0, m * l**2 / 12, m * l**2 / 12])
    if convention == "standard":  # frame 1 at the tip
        link = md.DHLink("revolute", a=l, theta=theta, mass=m, com=(lc - l, 0, 0), inertia=inertia)
    else:  # frame 1 at the pivot
        link = md.DHLink("revolute", theta=theta, mass=m, com=(lc, 0, 0), inertia=inertia)
    arm = md.Manipulator([link], convention=convention, gravity=gravity, strict=True)
    I_pivot = m * l**2 if body == "point" else m * l**2 / 3
    return arm, lc, I_pivot


@pytest.mark.parametrize("gravity_axis", ["x", "-y"])
@pytest.mark.parametrize("body", ["point", "rod"])
@pytest.mark.parametrize("convention", ["standard", "modified"])
@given(m=mass, l=length, q=angle, qd=rate, qdd=rate)
def test_pendulum(convention, body, gravity_axis, m, l, q, qd, qdd):
    """Simple pendulum: ``tau = m l^2 qdd + m g l sin q`` (point mass), and for a
    uniform rod ``tau = (m l^2/3) qdd + m g (l/2) sin q``; in general
    ``tau = I_pivot qdd + m g lc sin q``, ``h = 0`` (one joint has no Coriolis
    term), ``K = I_pivot qd^2 / 2``, ``P = -m g lc cos q`` (zero at the pivot's height).
    Any mechanics text, e.g. Spong et al. 2nd ed., sec. 6.1 (single-link robot)."""
    arm, lc, I_pivot = pendulum_arm(convention, m, l, body, gravity_axis)
    D = np.array([[I_pivot]])
    h = np.zeros(1)
    g = np.array([m * G0 * lc * math.sin(q)])
    tau = D[0] * qdd + g
    K = 0.5 * I_pivot * qd**2
    P = -m * G0 * lc * math.cos(q)
    _check_all(arm, (D, h, g, tau, K, P), np.array([q]), np.array([qd]), np.array([qdd]))
    # g is the torque that HOLDS the arm still (CONVENTIONS.md): horizontal, it is +m g lc
    _close(arm.lagrange.gravity_torque([math.pi / 2]), [m * G0 * lc], m * G0 * l)


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_pendulum_vertical_axis_feels_no_gravity(convention):
    """A pendulum turning about the vertical base z axis (default gravity (0, 0, -9.81))
    moves its COM horizontally only: ``P`` is constant and ``g = 0`` exactly up to rounding."""
    link = md.DHLink("revolute", a=0.7 if convention == "standard" else 0.0, mass=3.0,
                     com=(-0.2, 0.1, 0.3) if convention == "standard" else (0.5, 0.1, 0.3),
                     inertia=bar_inertia(3.0, 0.7, 0.1, 0.1))
    arm = md.Manipulator([link], convention=convention, strict=True)
    q = np.linspace(-3, 3, 7)[:, None]
    # |g| is a sum of O(m g |c|) = O(10) terms that cancel exactly: 1e-12 * 10 bound
    _close(arm.lagrange.gravity_torque(q), np.zeros((7, 1)), 10.0)
    # P = m * 9.81 * height (CONVENTIONS.md, eq. 2.24), the COM's height is its z = 0.3 m
    _close(arm.lagrange.potential_energy(q), np.full(7, 3.0 * G0 * 0.3), 10.0)


# ---------------------------------------------------------------------------
# (c) Revolute-prismatic polar arm
# ---------------------------------------------------------------------------


def polar_rp_arm(convention, m1, m2, c1, c2, d0, I1, I2):
    """R-P polar arm in the x-y plane, gravity (0, -9.81, 0).

    Joint 1 turns about the base z axis; joint 2 slides along the radial unit
    vector ``u = (cos q1, sin q1, 0)``.  Link 1 is a body with COM at ``c1 u``;
    link 2 slides with its COM at ``r2 u``, ``r2 = q2 + d0 - c2``.  ``I1`` and
    ``I2`` are diagonal tensors about the COMs in frame 2's axes
    ``(x, y, z) = ((-sin q1, cos q1, 0), base z, u)``, so ``I[1]`` (yy) is the
    moment about the axis of joint 1.

    Standard DH: row 1 = (revolute, theta = pi/2, alpha = pi/2), giving frame 1
    axes ``((-s1, c1, 0), z0, u)``; row 2 = (prismatic, d = d0).  Frame 2 = frame 1
    shifted by ``(q2 + d0) u``.  Link 1: com (0, 0, c1), inertia as given.

    Modified DH: row 1 = (revolute, theta = pi/2): frame 1 axes
    ``((-s1, c1, 0), -u, z0)``; row 2 = (prismatic, alpha_1 = pi/2, d = d0): frame 2
    as in the standard case.  Link 1's COM is then at (0, -c1, 0) and its
    tensor's yy and zz swap places.
    """
    gravity = (0.0, -G0, 0.0)
    I1 = np.asarray(I1, dtype=float)
    if convention == "standard":
        links = [
            md.DHLink("revolute", theta=math.pi / 2, alpha=math.pi / 2, mass=m1, com=(0, 0, c1),
                      inertia=I1),
            md.DHLink("prismatic", d=d0, mass=m2, com=(0, 0, -c2), inertia=I2),
        ]
    else:
        links = [
            md.DHLink("revolute", theta=math.pi / 2, mass=m1, com=(0, -c1, 0),
                      inertia=I1[[0, 2, 1]]),
            md.DHLink("prismatic", alpha=math.pi / 2, d=d0, mass=m2, com=(0, 0, -c2), inertia=I2),
        ]
    return md.Manipulator(links, convention=convention, gravity=gravity, strict=True)


def polar_rp_dynamics(m1, m2, c1, c2, d0, I1yy, I2yy, g, q, qd, qdd):
    """Hand derivation (Lagrange, eq. 2.9 and 2.10) for :func:`polar_rp_arm`.

    With ``u = (cos q1, sin q1, 0)``, ``r2 = q2 + d0 - c2``, both bodies spinning
    at ``qd1`` about the base z axis (= their frames' y axis):

    * ``K = 1/2 (I1yy + m1 c1^2) qd1^2 + 1/2 I2yy qd1^2 + 1/2 m2 (qd2^2 + r2^2 qd1^2)``
      (link 2's COM velocity is ``qd2 u + r2 qd1 u_perp``);
    * ``P = g (m1 c1 + m2 r2) sin q1`` (heights ``c1 sin q1`` and ``r2 sin q1``).

    Lagrange's equations give

    * ``D = [[I1yy + m1 c1^2 + I2yy + m2 r2^2, 0], [0, m2]]``;
    * ``h1 = d/dt(D11) qd1 = 2 m2 r2 qd1 qd2``, ``h2 = -dK/dq2 = -m2 r2 qd1^2``;
    * ``g1 = dP/dq1 = g (m1 c1 + m2 r2) cos q1``, ``g2 = dP/dq2 = m2 g sin q1``.
    """
    q1, q2 = q
    r2 = q2 + d0 - c2
    D = np.array([[I1yy + m1 * c1**2 + I2yy + m2 * r2**2, 0.0], [0.0, m2]])
    h = np.array([2 * m2 * r2 * qd[0] * qd[1], -m2 * r2 * qd[0] ** 2])
    gv = np.array([g * (m1 * c1 + m2 * r2) * math.cos(q1), m2 * g * math.sin(q1)])
    tau = D @ qdd + h + gv
    K = 0.5 * qd @ D @ qd
    P = g * (m1 * c1 + m2 * r2) * math.sin(q1)
    return D, h, gv, tau, K, P


@pytest.mark.parametrize("convention", ["standard", "modified"])
@given(m1=mass, m2=mass, c1=st.floats(-0.5, 0.5), c2=st.floats(0.0, 0.5), d0=st.floats(0.0, 0.5),
       dims=st.tuples(length, st.floats(0.02, 0.2), st.floats(0.02, 0.2)),
       q=st.tuples(angle, st.floats(-0.5, 1.0)), qd=st.tuples(rate, rate), qdd=st.tuples(rate, rate))
def test_polar_rp_arm(convention, m1, m2, c1, c2, d0, dims, q, qd, qdd):
    """Revolute-prismatic polar arm against the hand derivation of :func:`polar_rp_dynamics`
    (the planar "polar" arm of e.g. Craig, 3rd ed., example 6.5, done by Lagrange here)."""
    L, w, t = dims
    # link 1: a bar along u (frame axis z); link 2: a bar sliding along u
    I1 = np.diag(bar_inertia(m1, t, w, L))  # length along z
    I2 = np.diag(bar_inertia(m2, w, t, L))
    arm = polar_rp_arm(convention, m1, m2, c1, c2, d0, I1, I2)
    q, qd, qdd = np.array(q), np.array(qd), np.array(qdd)
    expected = polar_rp_dynamics(m1, m2, c1, c2, d0, I1[1], I2[1], G0, q, qd, qdd)
    _check_all(arm, expected, q, qd, qdd)


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_polar_rp_arm_batch(convention):
    """The same closed form, the engine called once on a batch of 50 states."""
    m1, m2, c1, c2, d0 = 3.0, 1.2, 0.15, 0.25, 0.1
    I1, I2 = np.array([0.05, 0.04, 0.01]), np.array([0.02, 0.03, 0.015])
    arm = polar_rp_arm(convention, m1, m2, c1, c2, d0, I1, I2)
    rng = np.random.default_rng(3)
    q = np.column_stack([rng.uniform(-3, 3, 50), rng.uniform(-0.5, 1.0, 50)])
    qd, qdd = rng.uniform(-3, 3, (2, 50, 2))
    tau = arm.lagrange.inverse_dynamics(q, qd, qdd)
    D, h, g = arm.lagrange.dynamics_terms(q, qd)
    for b in range(50):
        exp = polar_rp_dynamics(m1, m2, c1, c2, d0, I1[1], I2[1], G0, q[b], qd[b], qdd[b])
        scale = np.max(np.abs(exp[0])) * 20 + np.max(np.abs(exp[2]))
        _close(D[b], exp[0], scale)
        _close(h[b], exp[1], scale)
        _close(g[b], exp[2], scale)
        _close(tau[b], exp[3], scale)


def test_polar_rp_link_poses():
    """Frame 2 of the R-P arm (standard and modified DH alike) sits at ``(q2 + d0) u``
    with axes ``((-s1, c1, 0), z0, u)``: checks the DH tables used above by hand."""
    for convention in ("standard", "modified"):
        arm = polar_rp_arm(convention, 1.0, 1.0, 0.1, 0.1, 0.2, np.ones(3) * 0.01, np.ones(3) * 0.01)
        q1, q2 = 0.7, 0.3
        T2 = arm.fkine([q1, q2])
        u = np.array([math.cos(q1), math.sin(q1), 0.0])
        R = np.column_stack([[-math.sin(q1), math.cos(q1), 0.0], [0, 0, 1.0], u])
        # entries are products of a few sines and cosines: a few ulps of O(1)
        _close(T2[:3, :3], R, 1.0)
        _close(T2[:3, 3], (q2 + 0.2) * u, 1.0)
