"""The identification API at its boundary (issue 20, item 21): ``fit``'s arrays are validated as
the dynamics calls validate states, a ``base=`` of another arm is refused, ``Bounds`` and
``base_parameters(samples=...)`` are validated, and ``excitation`` takes numpy scalars."""

from __future__ import annotations

import numpy as np
import pytest

import manipdyn as md
from manipdyn._support.errors import ModelError

pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
from manipdyn.identification import Bounds, base_parameters, excitation, fit  # noqa: E402


@pytest.fixture(scope="module")
def ur5_data():
    arm = md.load("ur5")
    ex = excitation(arm, duration=3.0, harmonics=3, rate=50.0, iterations=0)
    return arm, ex.q, ex.qd, ex.qdd, arm.inverse_dynamics(ex.q, ex.qd, ex.qdd)


@pytest.mark.parametrize("bad, what", [
    (lambda a: a.astype(bool), "bool"),
    (lambda a: a.astype(complex), "complex"),
    (lambda a: a.astype(object), "object"),
    (lambda a: a.astype("datetime64[s]"), "datetime64"),
    (lambda a: np.ma.masked_array(a, mask=np.arange(a.size).reshape(a.shape) == 3), "masked"),
])
@pytest.mark.parametrize("arg", [0, 3])
def test_fit_refuses_what_the_dynamics_refuse(ur5_data, bad, what, arg):
    arm, *data = ur5_data
    data[arg] = bad(np.asarray(data[arg]))
    name = ("q", "qd", "qdd", "tau")[arg]
    with pytest.raises(ModelError, match=rf"^{name}: expected a real array of shape \(N, 6\).*{what}"):
        fit(arm, *data, method="ols")
    if arg == 0:   # the dynamics refuse the same q (tau is not one of their arguments)
        with pytest.raises(ValueError, match=what):
            arm.inverse_dynamics(data[0], data[1], data[2])


def test_fit_converts_big_endian_and_integers_like_the_dynamics(ur5_data):
    arm, q, qd, qdd, tau = ur5_data
    ref = fit(arm, q, qd, qdd, tau, method="ols")
    big = fit(arm, q.astype(">f8"), qd.astype(">f8"), qdd, tau.astype(">f8"), method="ols")
    # the same numbers in another byte order: the same beta to rounding
    assert np.allclose(big.beta, ref.beta, rtol=1e-9, atol=1e-12)
    masked_clean = fit(arm, np.ma.masked_array(q), qd, qdd, tau, method="ols")
    assert np.allclose(masked_clean.beta, ref.beta, rtol=1e-12, atol=1e-14)


def test_fit_names_the_non_finite_entry(ur5_data):
    arm, q, qd, qdd, tau = ur5_data
    tau = tau.copy()
    tau[7, 2] = np.nan
    with pytest.raises(ModelError, match=r"tau: must be finite; row 7, column 2 is nan"):
        fit(arm, q, qd, qdd, tau, method="ols")


def test_a_base_of_another_arm_is_refused(ur5_data):
    """The PUMA's base parameters have the UR5's names (both 6 joints): the old name check let
    them through and fitted the wrong combinations."""
    arm, q, qd, qdd, tau = ur5_data
    other = base_parameters(md.load("ur10"))
    assert other.names == base_parameters(arm).names
    with pytest.raises(ModelError, match="base: not the base parameters of 'ur5'"):
        fit(arm, q, qd, qdd, tau, method="ols", base=other)
    with pytest.raises(ModelError, match="base: not the base parameters"):
        excitation(arm, duration=3.0, harmonics=3, rate=50.0, iterations=0, base=other)
    with pytest.raises(ModelError, match="base: computed with other armature/friction columns"):
        fit(arm, q, qd, qdd, tau, method="ols", base=base_parameters(arm, armature=True))
    with pytest.raises(ModelError, match="base: expected a BaseParameters"):
        fit(arm, q, qd, qdd, tau, method="ols", base="ur5")
    # the arm's own base, computed with other states, is accepted and gives the same fit
    own = base_parameters(arm, samples=150, seed=3)
    a = fit(arm, q, qd, qdd, tau, method="ols", base=own)
    b = fit(arm, q, qd, qdd, tau, method="ols")
    assert np.allclose(a.predict(q, qd, qdd), b.predict(q, qd, qdd), atol=1e-8)


@pytest.mark.parametrize("kw, match", [
    (dict(mass=[["1", "2"]] * 6), "Bounds.mass: expected real numbers, got dtype <U1"),
    (dict(mass=np.ones((6, 2), bool)), "Bounds.mass: expected real numbers, got dtype bool"),
    (dict(com=np.ones((6, 2, 3), complex)), "Bounds.com: expected real numbers, got dtype complex"),
    (dict(total_mass=np.ma.masked_array([1.0, 2.0], mask=[True, False])), "Bounds.total_mass: a masked array"),
])
def test_bounds_refuse_what_is_not_real_numbers(kw, match):
    with pytest.raises(ModelError, match=match):
        Bounds(**kw)


def test_bounds_convert_big_endian_and_must_match_the_arm(ur5_data):
    b = Bounds(mass=np.array([[1.0, 2.0]] * 6, dtype=">f8"))
    assert b.mass.dtype == np.float64 and b.mass.dtype.isnative and b.mass[0, 1] == 2.0
    arm, q, qd, qdd, tau = ur5_data
    with pytest.raises(ModelError, match="Bounds.mass: 3 rows for an arm of 6 links"):
        fit(arm, q, qd, qdd, tau, method="consistent", bounds=Bounds(mass=[[1.0, 2.0]] * 3))


@pytest.mark.parametrize("samples, match", [
    (0, "samples: expected a positive integer, got 0"),
    (2.5, "samples: expected a positive integer, got 2.5"),
    (True, "samples: expected a positive integer, got True"),
    (-3, "samples: expected a positive integer"),
    (1, r"samples: 1 states give 6 rows for 60 parameter columns; .* at least 10 states"),
])
def test_base_parameters_samples_are_validated(samples, match):
    with pytest.raises(ModelError, match=match):
        base_parameters(md.load("ur5"), samples=samples)


def test_base_parameters_take_a_numpy_integer():
    arm = md.load("ur5")
    assert base_parameters(arm, samples=np.int64(60)).count == base_parameters(arm).count


def test_excitation_grid_zero_and_numpy_duration():
    arm = md.load("ur5")
    with pytest.raises(ModelError, match="grid: expected a positive integer, got 0"):
        excitation(arm, grid=0, iterations=0)
    ex = excitation(arm, duration=np.int64(2), harmonics=2, rate=np.float32(50.0), iterations=0, ramp=0)
    ref = excitation(arm, duration=2.0, harmonics=2, rate=50.0, iterations=0, ramp=0)     # one period each
    assert ex.q.shape == ref.q.shape == (100, 6)
    assert np.array_equal(ex.q, ref.q)
    with pytest.raises(ModelError, match="duration: expected a positive number, got np.True_|duration: expected"):
        excitation(arm, duration=np.bool_(True), iterations=0)
