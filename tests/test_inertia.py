"""Link inertia: the pseudo-inertia J (eq. 2.20, 2.21), its conventions, input
validation, physical consistency, the classic Puma 560 data, and validation of
joint states at the API boundary.

Tolerance for conversions (``CONV``): J, the COM and the tensors are a few
(< 20) floating-point operations on O(1) numbers apart, so they agree to a few
eps; 1e-13 relative to max(1, |x|) is ~450 eps.  Sign or convention mistakes
are O(1).
"""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st

import manipdyn as md

import arms

CONV = 1e-13  # see the module docstring
ROUNDING = 1e-12  # engine sums on the Puma, as in test_identities.py


def assert_conv_close(actual, expected):
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    np.testing.assert_allclose(actual, expected, rtol=0, atol=CONV * max(1.0, np.max(np.abs(expected))))


# ---------------------------------------------------------------------------
# Eq. 2.20 / 2.21 and the two sign conventions
# ---------------------------------------------------------------------------


def point_cloud(rng, k=7):
    """k point masses (kg) at points r (m) of a link frame: a body we can integrate exactly."""
    m = rng.uniform(0.1, 2.0, k)
    r = rng.uniform(-0.5, 0.5, (k, 3)) + rng.uniform(-0.5, 0.5, 3)
    return m, r


@given(seed=st.integers(0, 2**32 - 1))
def test_pseudo_inertia_is_the_integral_of_eq_2_20(seed):
    """For point masses the integrals of eq. 2.20 are sums: ``J = sum m_k r_k r_k^T``
    with ``r = [x, y, z, 1]``.  LinkInertia(mass, com, tensor about the COM) must give
    that J, with the tensor computed by its definition
    ``I_C = sum m (|s|^2 E - s s^T)``, ``s = r - c`` (tensor sign: ``I_xy = -sum m x y``)."""
    m, r = point_cloud(np.random.default_rng(seed))
    M = m.sum()
    c = (m[:, None] * r).sum(0) / M
    s = r - c
    I_C = sum(mk * ((sk @ sk) * np.eye(3) - np.outer(sk, sk)) for mk, sk in zip(m, s))
    r4 = np.column_stack([r, np.ones(len(m))])
    J_direct = sum(mk * np.outer(rk, rk) for mk, rk in zip(m, r4))
    body = md.LinkInertia(M, c, I_C, name="cloud")
    assert_conv_close(body.J, J_direct)
    # the tensor about the frame origin, by its definition
    I_O = sum(mk * ((rk @ rk) * np.eye(3) - np.outer(rk, rk)) for mk, rk in zip(m, r))
    assert_conv_close(body.inertia_about_origin(), I_O)
    # eq. 2.21's terms integrated directly: I_xx = sum m (y^2 + z^2), I_xy = +sum m x y, ...
    x, y, z = r.T
    chapter = md.LinkInertia.from_chapter_terms(
        M, (m * x).sum(), (m * y).sum(), (m * z).sum(),
        (m * (y**2 + z**2)).sum(), (m * (x**2 + z**2)).sum(), (m * (x**2 + y**2)).sum(),
        (m * x * y).sum(), (m * x * z).sum(), (m * y * z).sum(), name="cloud")
    assert_conv_close(chapter.J, J_direct)
    assert_conv_close(chapter.inertia, I_C)
    assert_conv_close(chapter.com, c)
    assert chapter.mass == pytest.approx(M, rel=CONV)


@given(seed=st.integers(0, 2**32 - 1))
def test_chapter_terms_and_tensor_about_com_give_the_same_J(seed):
    """The chapter's eq. 2.21 terms, built by hand from a tensor about the COM:
    ``I_origin = I_C + m (|c|^2 E - c c^T)`` (parallel axes), chapter moments =
    its diagonal, chapter products = MINUS its off-diagonal elements
    (CONVENTIONS.md: the chapter's I_xy is +integral x y dm)."""
    rng = np.random.default_rng(seed)
    m = float(rng.uniform(0.1, 10))
    c = rng.uniform(-0.5, 0.5, 3)
    I_C = arms.random_physical_inertia(rng)
    I_O = I_C + m * ((c @ c) * np.eye(3) - np.outer(c, c))
    from_tensor = md.LinkInertia(m, c, I_C, name="t")
    from_chapter = md.LinkInertia.from_chapter_terms(
        m, m * c[0], m * c[1], m * c[2],
        I_O[0, 0], I_O[1, 1], I_O[2, 2],
        -I_O[0, 1], -I_O[0, 2], -I_O[1, 2], name="t")
    assert_conv_close(from_chapter.J, from_tensor.J)
    assert_conv_close(from_chapter.inertia, I_C)
    assert_conv_close(from_chapter.com, c)
    assert_conv_close(from_tensor.inertia_about_origin(), I_O)
    # eq. 2.21 element by element
    J = from_tensor.J
    assert_conv_close(J[0, 0], (-I_O[0, 0] + I_O[1, 1] + I_O[2, 2]) / 2)
    assert_conv_close(J[1, 1], (I_O[0, 0] - I_O[1, 1] + I_O[2, 2]) / 2)
    assert_conv_close(J[2, 2], (I_O[0, 0] + I_O[1, 1] - I_O[2, 2]) / 2)
    assert_conv_close([J[0, 1], J[0, 2], J[1, 2]], [-I_O[0, 1], -I_O[0, 2], -I_O[1, 2]])
    assert_conv_close(J[:3, 3], m * c)
    assert_conv_close(J[3, :3], m * c)
    assert J[3, 3] == m
    np.testing.assert_array_equal(J, J.T)


def test_product_of_inertia_sign_by_hand():
    """Two 1 kg points at (1, 1, 0) and (-1, -1, 0) m: integral x y dm = +2 kg m^2.
    The tensor (about the COM = origin) has I_xy = -2, the chapter's J has +2."""
    I_tensor = np.array([[2.0, -2.0, 0.0], [-2.0, 2.0, 0.0], [0.0, 0.0, 4.0]])
    body = md.LinkInertia(2.0, (0, 0, 0), I_tensor, name="dumbbell")
    expected = np.array([[2.0, 2.0, 0, 0], [2.0, 2.0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 2.0]])
    assert_conv_close(body.J, expected)
    chapter = md.LinkInertia.from_chapter_terms(2.0, 0, 0, 0, 2.0, 2.0, 4.0, +2.0, 0, 0)
    assert_conv_close(chapter.inertia, I_tensor)


@given(seed=st.integers(0, 2**32 - 1), massless=st.booleans())
def test_from_pseudo_inertia_round_trip(seed, massless):
    """LinkInertia -> J -> LinkInertia -> J returns what it started from.

    A massless body keeps its rotational inertia (J = [[tr(I)/2 E - I, 0], [0, 0]])
    but has no COM to give back."""
    rng = np.random.default_rng(seed)
    m = 0.0 if massless else float(rng.uniform(0.1, 10))
    c = np.zeros(3) if massless else rng.uniform(-0.5, 0.5, 3)
    I_C = arms.random_physical_inertia(rng)
    body = md.LinkInertia(m, c, I_C, name="rt")
    back = md.LinkInertia.from_pseudo_inertia(body.J, name="rt")
    assert back.mass == pytest.approx(m, rel=CONV, abs=0)
    assert_conv_close(back.com, c)
    assert_conv_close(back.inertia, I_C)
    assert_conv_close(back.J, body.J)
    assert back.name == "rt"


def test_inertia_given_as_three_diagonal_values():
    """``inertia=(Ixx, Iyy, Izz)`` means diag(Ixx, Iyy, Izz)."""
    a = md.DHLink(mass=1.0, inertia=(0.1, 0.2, 0.25))
    b = md.DHLink(mass=1.0, inertia=np.diag([0.1, 0.2, 0.25]))
    np.testing.assert_array_equal(a.inertia, b.inertia)
    np.testing.assert_array_equal(a.body.J, b.body.J)


def test_link_inertia_is_frozen():
    """Built values do not change afterwards: arrays are read-only."""
    body = md.LinkInertia(1.0, (0.1, 0, 0), np.eye(3) * 0.1)
    with pytest.raises(ValueError, match="read-only"):
        body.com[0] = 5.0
    with pytest.raises(ValueError, match="read-only"):
        body.inertia[0, 0] = 5.0


# ---------------------------------------------------------------------------
# Bad input: each error names the link, the field and what was expected
# ---------------------------------------------------------------------------

NAN, INF = float("nan"), float("inf")
GOOD = dict(joint="revolute", a=0.1, mass=1.0, com=(0.0, 0.0, 0.1), inertia=(0.01, 0.01, 0.01))


@pytest.mark.parametrize("change, message", [
    (dict(mass=NAN), r"link 'elbow': field 'mass' must be finite, got nan"),
    (dict(mass=INF), r"link 'elbow': field 'mass' must be finite, got inf"),
    (dict(mass=-1.0), r"link 'elbow': field 'mass' must be >= 0 kg, got -1\.0"),
    (dict(mass="heavy"), r"link 'elbow': field 'mass' must be a number in kg, got 'heavy'"),
    (dict(com=(0.0, NAN, 0.0)), r"link 'elbow': field 'com' must be finite, got \[0\.0, nan, 0\.0\]"),
    (dict(com=(0.0, 0.0, -INF)), r"link 'elbow': field 'com' must be finite"),
    (dict(com=(0.0, 0.1)), r"link 'elbow': field 'com' must have length 3 \(x, y, z\), got shape \(2,\)"),
    (dict(com=(0.0, 0.1, 0.2, 1.0)), r"field 'com' must have length 3 \(x, y, z\), got shape \(4,\)"),
    (dict(inertia=(0.01, NAN, 0.01)), r"link 'elbow': field 'inertia' must be finite"),
    (dict(inertia=np.full((3, 3), INF)), r"link 'elbow': field 'inertia' must be finite"),
    (dict(inertia=[[0.1, 0.01, 0], [0.02, 0.1, 0], [0, 0, 0.1]]),
     r"link 'elbow': field 'inertia' must be symmetric"),
    (dict(inertia=(0.1, 0.1, 0.1, 0.0, 0.0, 0.0)),
     r"link 'elbow': field 'inertia' got 6 values; their order is ambiguous .* give a 3x3 matrix"),
    (dict(inertia=np.eye(2)),
     r"link 'elbow': field 'inertia' must be a 3x3 matrix or 3 diagonal values, got shape \(2, 2\)"),
    (dict(qlim=(-1.0, 0.0, 1.0)),
     r"link 'elbow': field 'qlim' must have length 2 \(lower, upper\), got shape \(3,\)"),
    (dict(qlim=(1.0, -1.0)), r"link 'elbow': field 'qlim' must have lower < upper"),
    (dict(qlim=(-NAN, 1.0)), r"link 'elbow': field 'qlim' must be finite"),
    (dict(joint="spherical"),
     r"link 'elbow': field 'joint' must be 'revolute' or 'prismatic', got 'spherical'"),
    (dict(joint="Revolute"),
     r"link 'elbow': field 'joint' must be 'revolute' or 'prismatic', got 'Revolute'"),
    (dict(a=NAN), r"link 'elbow': field 'a' must be finite, got nan"),
    (dict(alpha=INF), r"link 'elbow': field 'alpha' must be finite, got inf"),
    (dict(motor_inertia=-1e-4), r"link 'elbow': field 'motor_inertia' must be >= 0"),
    (dict(gear_ratio=0.0), r"link 'elbow': field 'gear_ratio' must be non-zero"),
], ids=lambda v: ",".join(f"{k}={x!r}" for k, x in v.items()) if isinstance(v, dict) else "msg")
def test_bad_dh_link_raises_model_error(change, message):
    """Malformed links raise ModelError (a ValueError) whose text is pinned here."""
    kw = dict(GOOD, name="elbow", **change)
    with pytest.raises(md.ModelError, match=message):
        md.DHLink(**kw)
    with pytest.raises(ValueError):  # ModelError subclasses ValueError
        md.DHLink(**kw)


def test_unnamed_link_is_called_dhlink_in_messages():
    with pytest.raises(md.ModelError, match=r"^DHLink: field 'mass' must be >= 0 kg, got -2\.0$"):
        md.DHLink(mass=-2.0)


@pytest.mark.parametrize("kw, message", [
    (dict(mass=NAN), r"^body: field 'mass' must be finite, got nan$"),
    (dict(mass=-0.5), r"^body: field 'mass' must be >= 0 kg, got -0\.5$"),
    (dict(com=[1.0, 2.0]), r"^body: field 'com' must have length 3 \(x, y, z\), got shape \(2,\)$"),
    (dict(inertia=np.arange(9.0).reshape(3, 3)), r"^body: field 'inertia' must be symmetric"),
    (dict(inertia=np.ones(6)), r"^body: field 'inertia' got 6 values; their order is ambiguous"),
])
def test_bad_link_inertia_raises_model_error(kw, message):
    base = dict(mass=1.0, com=(0, 0, 0), inertia=np.eye(3) * 0.1, name="body")
    with pytest.raises(md.ModelError, match=message):
        md.LinkInertia(**dict(base, **kw))


def test_bad_pseudo_inertia_raises_model_error():
    with pytest.raises(md.ModelError, match=r"^j: pseudo-inertia J must be 4x4, got shape \(3, 3\)$"):
        md.LinkInertia.from_pseudo_inertia(np.eye(3), name="j")
    J = np.eye(4)
    J[0, 1] = 0.5
    with pytest.raises(md.ModelError, match=r"^j: pseudo-inertia J must be symmetric$"):
        md.LinkInertia.from_pseudo_inertia(J, name="j")
    J = np.eye(4)
    J[2, 2] = NAN
    with pytest.raises(md.ModelError, match=r"^j: pseudo-inertia J must be finite$"):
        md.LinkInertia.from_pseudo_inertia(J, name="j")


@pytest.mark.parametrize("convention", ["craig", "Standard", "dh", None])
def test_bad_convention_raises_model_error(convention):
    """No silent guess between the two DH conventions."""
    with pytest.raises(md.ModelError,
                       match=rf"^convention: must be 'standard' or 'modified', got {re.escape(repr(convention))}$"):
        md.Manipulator([md.DHLink(**GOOD)], convention=convention)


def test_bad_manipulator_arguments():
    with pytest.raises(md.ModelError, match=r"^links: an arm needs at least one DHLink, got none$"):
        md.Manipulator([], convention="standard")
    with pytest.raises(md.ModelError, match=r"^links\[1\]: expected a DHLink, got dict$"):
        md.Manipulator([md.DHLink(**GOOD), dict(GOOD)], convention="standard")
    with pytest.raises(md.ModelError, match=r"^gravity: expected 3 numbers \(gx, gy, gz\) in m/s\^2, got shape \(2,\)$"):
        md.Manipulator([md.DHLink(**GOOD)], convention="standard", gravity=(0, -9.81))
    with pytest.raises(md.ModelError, match=r"^gravity: must be finite"):
        md.Manipulator([md.DHLink(**GOOD)], convention="standard", gravity=(0, 0, NAN))


# ---------------------------------------------------------------------------
# Physical consistency
# ---------------------------------------------------------------------------


def _arm_with_second_link(mass, inertia, strict=False, name="L2"):
    links = [md.DHLink(**GOOD, name="L1"),
             md.DHLink("revolute", a=0.2, mass=mass, com=(0.1, 0, 0), inertia=inertia, name=name)]
    return md.Manipulator(links, convention="standard", name="testarm", strict=strict)


def test_broken_triangle_inequality_warns_naming_link_and_condition():
    """Principal moments (0.1, 0.1, 0.3): Ixx + Iyy < Izz, no rigid body has them."""
    with pytest.warns(md.PhysicalConsistencyWarning,
                      match=r"testarm: link 2 \(L2\): physically impossible inertia: "
                            r"triangle inequality Ixx \+ Iyy >= Izz broken \(0\.1 \+ 0\.1 < 0\.3\)"):
        arm = _arm_with_second_link(1.0, (0.1, 0.1, 0.3))
    assert arm.n == 2  # a warning, not an error: the arm is built


def test_broken_triangle_inequality_in_rotated_axes_warns():
    """The same impossible body seen in rotated axes: its diagonal alone looks fine
    (0.1, 0.2, 0.2), the principal moments (0.1, 0.1, 0.3) are not."""
    c, s = math.cos(math.pi / 4), math.sin(math.pi / 4)
    R = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    I = R @ np.diag([0.1, 0.1, 0.3]) @ R.T
    with pytest.warns(md.PhysicalConsistencyWarning,
                      match=r"link 2 \(L2\): physically impossible inertia: "
                            r"triangle inequality of the principal moments broken"):
        _arm_with_second_link(1.0, 0.5 * (I + I.T))


def test_broken_triangle_inequality_of_a_small_body_warns():
    """BUG (manipdyn/model/inertia.py, LinkInertia.consistency_problems): a small body
    (inertias ~1e-9 kg m^2, a gram-sized part) with a broken triangle inequality
    in rotated axes passes unflagged.

    The code decides "diagonal tensor?" with ``np.allclose(I, diag(I))``, whose
    ABSOLUTE tolerance 1e-8 kg m^2 calls any tensor with entries < 1e-8
    diagonal; it then tests the triangle inequality on the diagonal entries
    only, which hold here, and reports nothing, although J has an eigenvalue
    of -4e-10 (40% of the body's scale).  The same body scaled by 1e6 is
    flagged (test above).  Fix: decide diagonality relative to the tensor's
    own scale (``max|offdiag| <= tol``), and if the per-axis loop finds
    nothing, report the principal-moment message anyway.
    """
    c, s = math.cos(math.pi / 4), math.sin(math.pi / 4)
    R = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    I = 1e-9 * (R @ np.diag([1.0, 1.0, 3.0]) @ R.T)
    I = 0.5 * (I + I.T)
    body = md.LinkInertia(1e-3, (0, 0, 0), I, name="tiny")
    assert np.linalg.eigvalsh(body.J)[0] < -0.4 * 1e-9  # impossible, clearly
    assert body.consistency_problems() != [], "impossible small body not flagged"
    # the tensor is not diagonal, so the message must speak of principal moments
    with pytest.warns(md.PhysicalConsistencyWarning,
                      match=r"link 2 \(L2\): physically impossible inertia: "
                            r"triangle inequality of the principal moments broken"):
        _arm_with_second_link(1e-3, I)


def test_massless_link_with_rotational_inertia_warns():
    with pytest.warns(md.PhysicalConsistencyWarning,
                      match=r"testarm: link 2 \(L2\): physically impossible inertia: "
                            r"rotational inertia on a massless link \(mass = 0, inertia != 0\)"):
        _arm_with_second_link(0.0, (0.0, 0.35, 0.0))


@pytest.mark.parametrize("mass, inertia, what", [
    (1.0, (0.1, 0.1, 0.3), r"triangle inequality Ixx \+ Iyy >= Izz broken"),
    (1.0, (0.3, 0.1, 0.1), r"triangle inequality Iyy \+ Izz >= Ixx broken"),
    (0.0, (0.0, 0.35, 0.0), r"rotational inertia on a massless link"),
])  # a negative principal moment is refused without strict: tests/test_model_notes.py
def test_strict_turns_the_warning_into_model_error(mass, inertia, what):
    with pytest.raises(md.ModelError, match=r"testarm: link 2 \(L2\): physically impossible inertia: .*" + what):
        _arm_with_second_link(mass, inertia, strict=True)


@pytest.mark.parametrize("exponent", [-12, -9, -6, 0, 3])
@given(seed=st.integers(0, 2**32 - 1))
def test_physical_bodies_raise_no_alarm(exponent, seed):
    """No false alarm at any scale: physical tensors (random axes) times 10^exponent,
    point masses, and massless links without inertia are all fine."""
    rng = np.random.default_rng(seed)
    I = arms.random_physical_inertia(rng) * 10.0**exponent
    assert md.LinkInertia(1.0, rng.uniform(-1, 1, 3), I).consistency_problems() == []
    assert md.LinkInertia(2.0, (0.1, 0.2, 0.3), np.zeros((3, 3))).consistency_problems() == []
    assert md.LinkInertia(0.0, (0.0, 0.0, 0.0), np.zeros((3, 3))).consistency_problems() == []
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert md.LinkInertia(1.0, (0, 0, 0), I).check_physical(strict=True) is True


@example(p=(1.0, 1.0, 3.0), seed=2, exponent=-9)  # the small-body bug (test above)
@given(p=st.tuples(*[st.floats(0.0, 1.0)] * 3), seed=st.integers(0, 2**32 - 1),
       exponent=st.integers(-12, 3))
def test_consistency_check_agrees_with_positive_semidefinite_J(p, seed, exponent):
    """CONVENTIONS.md: a body is physical iff J (eq. 2.20) is positive semidefinite.
    For m > 0 and principal moments p in random axes, the check must say "problem"
    exactly when J has a clearly negative eigenvalue.  Borderline bodies (smallest
    eigenvalue within 1e-6 of the scale, where the code's own 1e-9 tolerance
    decides) are skipped.  Fails on the small-body bug described in
    :func:`test_broken_triangle_inequality_of_a_small_body_warns`."""
    rng = np.random.default_rng(seed)
    R = arms.random_rotation(rng)
    scale = 10.0**exponent
    I = scale * (R @ np.diag(p) @ R.T)
    I = 0.5 * (I + I.T)
    body = md.LinkInertia(1.0, (0, 0, 0), I)
    lam = np.linalg.eigvalsh(body.J[:3, :3])[0]  # COM at the origin: S = J[:3,:3]
    if abs(lam) <= 1e-6 * scale * max(1.0, max(p)):
        return
    assert (body.consistency_problems() != []) == (lam < 0), (p, exponent, lam)


# ---------------------------------------------------------------------------
# The classic Puma 560 (Corke): a massless link with Iyy = 0.35 kg m^2
# ---------------------------------------------------------------------------


def build_puma560_expecting_warnings(**kw):
    """Corke's Puma 560 has two physically impossible links, and must say so:

    * link 1: mass 0 with Iyy = 0.35 kg m^2 (J indefinite);
    * link 3: Ixx + Izz = 0.066 + 0.0125 < Iyy = 0.086 kg m^2 (triangle inequality).
    """
    with pytest.warns(md.PhysicalConsistencyWarning) as record:
        arm = arms.puma560(**kw)
    warned = [str(w.message) for w in record if w.category is md.PhysicalConsistencyWarning]
    messages = list(arm.notes)       # the arm carries one note per link; one warning says them all
    assert len(warned) == 1 and all(m in warned[0] for m in messages), warned
    assert len(messages) == (2 if "link1_inertia" not in kw else 1), messages
    if "link1_inertia" not in kw:
        assert re.search(r"^puma560: link 1 \(link1\): physically impossible inertia: "
                         r"rotational inertia on a massless link", messages[0])
    assert re.search(r"^puma560: link 3 \(link3\): physically impossible inertia: triangle "
                     r"inequality Ixx \+ Izz >= Iyy broken \(0\.066 \+ 0\.0125 < 0\.086\)$",
                     messages[-1])
    return arm


def test_puma560_builds_with_a_warning_and_computes():
    """Corke's standard-DH Puma 560 puts Iyy = 0.35 kg m^2 on link 1, whose mass is
    0: physically impossible (J is indefinite), but the data set everybody uses
    (and link 3 breaks a triangle inequality, see
    :func:`build_puma560_expecting_warnings`).  It must build, with warnings naming
    the links and conditions, and its D must be finite and symmetric positive
    definite: the 0.35 is a pure rotational inertia about joint 1's axis, which
    adds to D_11 only."""
    arm = build_puma560_expecting_warnings()
    with pytest.raises(md.ModelError, match=r"puma560: link 1 \(link1\): .*massless link"):
        arms.puma560(strict=True)
    rng = np.random.default_rng(560)
    q = rng.uniform(-math.pi, math.pi, (200, 6))
    D = arm.lagrange.mass_matrix(q)
    assert np.all(np.isfinite(D))
    # symmetric to rounding (ROUNDING, see test_identities.py)
    assert np.max(np.abs(D - np.swapaxes(D, 1, 2))) <= ROUNDING * max(1.0, np.max(np.abs(D)))
    assert np.all(np.linalg.eigvalsh(D)[:, 0] > 0)
    np.linalg.cholesky(D)


def test_puma560_link1_inertia_adds_to_D11_only():
    """Link 1 (alpha_1 = pi/2) spins about its own y axis, which is the base z axis of
    joint 1, and moves with q1 alone; so its Iyy = 0.35 kg m^2 adds exactly 0.35 to
    D_11 and nothing else, whatever q.  Tolerance ROUNDING (same sums either way)."""
    full = build_puma560_expecting_warnings()
    bare = build_puma560_expecting_warnings(link1_inertia=(0.0, 0.0, 0.0))
    q = np.random.default_rng(1).uniform(-math.pi, math.pi, (50, 6))
    diff = full.lagrange.mass_matrix(q) - bare.lagrange.mass_matrix(q)
    expected = np.zeros((50, 6, 6))
    expected[:, 0, 0] = 0.35
    np.testing.assert_allclose(diff, expected, rtol=0,
                               atol=ROUNDING * max(1.0, np.max(np.abs(full.lagrange.mass_matrix(q)))))


def test_puma560_gravity_torque_at_zero_angles():
    """Gravity torque of the Puma 560 at q = 0, derived by hand.

    At q = 0 (standard DH, Corke's table): frame 1 has axes (x0, z0, -y0); link 2's
    frame sits at x = a2 = 0.4318 with the same axes; frames 3, 5, 6 have the base
    axes and frame 4 the axes of frame 1; links 3..6 hang at x = a2 + a3 = 0.4521
    from the base axis, plus their COM offsets.  Joint 2 turns about -y0 through the
    base origin, so g2 = dP/dq2 = g sum_{p>=2} m_p x_p (x of each COM):

        link 2: x = a2 + r2x = 0.4318 - 0.3638;  link 3: x = a2 + a3 + r3x = 0.4318;
        links 4, 5, 6: x = a2 + a3 = 0.4521 (their COM offsets are along y0 or z0).

    Joint 3 turns about -y0 through (a2, 0, 0): g3 = g sum_{p>=3} m_p (x_p - a2).
    Joints 1, 4 and 6 turn about vertical axes (g = 0); joint 5's axis (-y0
    through x = 0.4521) has links 5 and 6's COMs on its vertical plane (g5 = 0).
    Corke's Robotics Toolbox prints ``p560.gravload(qz) = [0 37.4837 0.2489 0 0 0]``.
    Tolerance: ROUNDING relative to the largest term (~20 N m).
    """
    g = 9.81
    m = arms.PUMA560["m"]
    a2, a3 = 0.4318, 0.0203
    x = [None, a2 - 0.3638, a2 + a3 - 0.0203, a2 + a3, a2 + a3, a2 + a3]
    g2 = g * sum(m[p] * x[p] for p in range(1, 6))
    g3 = g * sum(m[p] * (x[p] - a2) for p in range(2, 6))
    arm = build_puma560_expecting_warnings()
    got = arm.lagrange.gravity_torque(np.zeros(6))
    np.testing.assert_allclose(got, [0, g2, g3, 0, 0, 0], rtol=0, atol=ROUNDING * 100)
    # and the published numbers, to the 4 decimals printed
    np.testing.assert_allclose(got, [0, 37.4837, 0.2489, 0, 0, 0], rtol=0, atol=0.5e-4)


# ---------------------------------------------------------------------------
# Joint states at the API boundary
# ---------------------------------------------------------------------------

N_J = 3


@pytest.fixture(scope="module")
def arm3():
    return arms.random_arm(3, n=N_J, convention="standard")


def _calls(lag, q, qd, qdd):
    """Every public method, with the argument names it validates."""
    return {
        "mass_matrix": lambda: lag.mass_matrix(q),
        "gravity_torque": lambda: lag.gravity_torque(q),
        "potential_energy": lambda: lag.potential_energy(q),
        "link_poses": lambda: lag.link_poses(q),
        "fkine": lambda: lag.fkine(q),
        "coriolis_torque": lambda: lag.coriolis_torque(q, qd),
        "kinetic_energy": lambda: lag.kinetic_energy(q, qd),
        "dynamics_terms": lambda: lag.dynamics_terms(q, qd),
        "inverse_dynamics": lambda: lag.inverse_dynamics(q, qd, qdd),
        "forward_dynamics": lambda: lag.forward_dynamics(q, qd, qdd),
    }


USES = {
    "q": ["mass_matrix", "gravity_torque", "potential_energy", "link_poses", "fkine",
          "coriolis_torque", "kinetic_energy", "dynamics_terms", "inverse_dynamics",
          "forward_dynamics"],
    "qd": ["coriolis_torque", "kinetic_energy", "dynamics_terms", "inverse_dynamics",
           "forward_dynamics"],
    "qdd": ["inverse_dynamics"],
    "tau": ["forward_dynamics"],
}
CASES = [(arg, method) for arg, methods in USES.items() for method in methods]


def _with_bad(arg, bad):
    good = np.zeros(N_J)
    q, qd, third = good, good, good
    if arg == "q":
        q = bad
    elif arg == "qd":
        qd = bad
    else:
        third = bad
    return q, qd, third


@pytest.mark.parametrize("arg, method", CASES, ids=[f"{a}-{m}" for a, m in CASES])
@pytest.mark.parametrize("shape", [(N_J - 1,), (N_J + 1,), (4, N_J + 1), (2, 2, N_J), ()],
                         ids=str)
def test_wrong_state_shape_names_argument_and_shapes(arm3, arg, method, shape):
    q, qd, third = _with_bad(arg, np.zeros(shape))
    msg = rf"^{arg}: got shape {re.escape(str(shape))}, expected \({N_J},\) or \(N, {N_J}\)$"
    with pytest.raises(md.StateError, match=msg):
        _calls(arm3.lagrange, q, qd, third)[method]()


@pytest.mark.parametrize("arg, method", CASES, ids=[f"{a}-{m}" for a, m in CASES])
@pytest.mark.parametrize("bad", [NAN, INF, -INF], ids=["nan", "inf", "-inf"])
def test_non_finite_state_names_argument_and_entry(arm3, arg, method, bad):
    x = np.zeros(N_J)
    x[1] = bad
    q, qd, third = _with_bad(arg, x)
    with pytest.raises(md.StateError, match=rf"^{arg}: entry 1 is .*{re.escape(repr(bad))}.*; states must be finite$"):
        _calls(arm3.lagrange, q, qd, third)[method]()
    # in a batch the entry is (row, column)
    xb = np.zeros((3, N_J))
    xb[2, 0] = bad
    good_b = np.zeros((3, N_J))
    q, qd, third = good_b, good_b, good_b
    if arg == "q":
        q = xb
    elif arg == "qd":
        qd = xb
    else:
        third = xb
    with pytest.raises(md.StateError, match=rf"^{arg}: entry \(2, 0\) is .*; states must be finite$"):
        _calls(arm3.lagrange, q, qd, third)[method]()


def test_state_error_is_a_value_error_and_lists_are_accepted(arm3):
    with pytest.raises(ValueError, match=r"^q: got shape \(2,\), expected \(3,\) or \(N, 3\)$"):
        arm3.lagrange.mass_matrix([0.0, 1.0])
    with pytest.raises(md.StateError, match=r"^q: expected a real array of shape \(3,\) or \(N, 3\), could not convert str"):
        arm3.lagrange.mass_matrix("abc")
    # plain lists and integer arrays are fine
    np.testing.assert_array_equal(arm3.lagrange.mass_matrix([0, 0, 0]),
                                  arm3.lagrange.mass_matrix(np.zeros(3)))


def test_complex_state_is_refused(arm3):
    """BUG (manipdyn/_support/state.py, as_state): a complex state is cast to float64 with
    numpy's ComplexWarning only, silently dropping the imaginary part (a
    complex-step derivative would come out as 0).  The boundary must refuse it
    like any other non-real input.  Fix: in ``as_state``, before converting,
    ``if np.iscomplexobj(x): raise StateError(f"{name}: expected a real array of
    shape ({n},) or (N, {n}), got complex values")``."""
    q = np.array([0.1 + 1e-20j, 0.2, 0.3])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", getattr(np, "exceptions", np).ComplexWarning)
        with pytest.raises(md.StateError, match=r"^q: expected a real array of shape \(3,\) or \(N, 3\)"):
            arm3.lagrange.gravity_torque(q)


@pytest.mark.parametrize("second", ["qd", "qdd"])
def test_batch_sizes_must_match(arm3, second):
    q = np.zeros((2, N_J))
    other = np.zeros((3, N_J))
    with pytest.raises(md.StateError, match=rf"^{second}: got shape \(3, 3\), expected \(2, 3\) to match q$"):
        if second == "qd":
            arm3.lagrange.inverse_dynamics(q, other, q)
        else:
            arm3.lagrange.inverse_dynamics(q, q, other)
    # one state against a batch is a mismatch too, not a silent broadcast
    with pytest.raises(md.StateError, match=r"^qd: got shape \(2, 3\), expected \(3,\) to match q$"):
        arm3.lagrange.coriolis_torque(np.zeros(N_J), q)
