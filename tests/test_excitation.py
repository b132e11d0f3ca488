"""Excitation trajectories: the optimiser's gradient, limits between samples, aliasing,
and too few equations (issue 20, item 17)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.identification import base_parameters, excitation
from manipdyn.identification.experiments import trajectory as tr


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(name)


def test_gradient_agrees_with_plain_finite_differences():
    """The optimiser's gradient (linearised in the joint states, Pinocchio's regressor)
    against central differences of the plain objective (trace-form regressor, SVD)."""
    arm = _load("ur5")
    n, K, period = arm.n, 2, 6.0
    vmax, amax, lo, hi = tr.motion_limits(arm, None, None, 0.05)
    q0 = 0.5 * (lo + hi)
    base = base_parameters(arm)
    tg = np.arange(40) * (period / 40)

    def unpack(x):
        a = x[..., :n * K].reshape(x.shape[:-1] + (n, K))
        b = x[..., n * K:].reshape(x.shape[:-1] + (n, K))
        return tr._feasible(q0, a, b, period, vmax, amax, lo, hi)

    def plain(x):
        q, qd, qdd = tr.fourier_trajectory(tg, q0, *unpack(x), period)
        s = np.linalg.svd(base.regressor(arm.lagrange.regressor(q, qd, qdd)).reshape(-1, base.count),
                          compute_uv=False)
        return math.log(s[0] / s[-1])

    # small coefficients: no limit is active, so the objective is smooth around x
    x = np.random.default_rng(4).uniform(-0.4, 0.4, 2 * n * K)
    a, _ = unpack(x)
    np.testing.assert_allclose(a, x[:n * K].reshape(n, K) * (1 - 1e-9), rtol=1e-15)   # unscaled
    value, grad = tr._log_cond_and_grad(arm.pinocchio.regressor, base, x, unpack, q0, period, tg)
    # the Gram matrix's eigenvalues err by ~eps s_max^2, i.e. log cond by ~eps cond^2 / 2
    assert value == pytest.approx(plain(x), abs=10 * 2.2e-16 * math.exp(2 * value))
    h = 1e-6
    fd = np.array([(plain(x + h * e) - plain(x - h * e)) / (2 * h) for e in np.eye(x.size)])
    # forward-difference steps of 1e-7 in q, qd and 1.5e-8 in x: ~1e-6 of the gradient's size
    np.testing.assert_allclose(grad, fd, atol=1e-5 * np.abs(fd).max())


def test_limits_hold_between_samples():
    """A coarse output rate (5 Hz) and a short grid: the limits must hold at every time."""
    arm = _load("ur5")
    ex = excitation(arm, duration=4.0, harmonics=3, rate=5.0, grid=20, iterations=2, seed=1,
                    vmax=0.8, amax=2.0)
    q, qd, qdd = ex.sample(ex.ramp + np.linspace(0.0, ex.period, 40001))      # the period between the ramps
    lo, hi = arm.qlim[:, 0], arm.qlim[:, 1]
    span = hi - lo
    assert np.all(q >= lo + 0.05 * span) and np.all(q <= hi - 0.05 * span)
    assert np.abs(qd).max() <= 0.8 and np.abs(qdd).max() <= 2.0
    # and the scaling is not needlessly timid: some limit is within 1 % of being reached
    reach = np.max([np.abs(qd).max(axis=0) / 0.8, np.abs(qdd).max(axis=0) / 2.0,
                    (q.max(axis=0) - ex.q0) / (hi - 0.05 * span - ex.q0),
                    (ex.q0 - q.min(axis=0)) / (ex.q0 - lo - 0.05 * span)], axis=0)
    assert np.all(reach >= 0.99)


def test_peak_bounds_are_upper_bounds_and_tight():
    rng = np.random.default_rng(0)
    period = 3.0
    for K in (1, 4, 9):
        a, b = rng.normal(size=(5, K)), rng.normal(size=(5, K))
        up, dn, vd, ad = tr._peaks(a, b, period)
        q, qd, qdd = tr.fourier_trajectory(np.linspace(0, period, 200001), np.zeros(5), a, b, period)
        for bound, true in ((up, q.max(axis=0)), (dn, -q.min(axis=0)), (vd, np.abs(qd).max(axis=0)),
                            (ad, np.abs(qdd).max(axis=0))):
            assert np.all(bound >= true)
            # tight: the gap term is below pi^2 / (2 * 50^2) = 0.2 % of the sum of amplitudes
            assert np.all(bound <= 1.003 * true)


def test_too_few_equations_is_an_error():
    arm = _load("ur5")
    r = base_parameters(arm).count
    with pytest.raises(md.ModelError, match=rf"duration \* rate: 1 samples give 6 equations, too few for the {r}"):
        excitation(arm, duration=1.0, rate=1.0, harmonics=1, iterations=0)
    with pytest.raises(md.ModelError, match="duration \\* rate: 3 samples give 18 equations"):
        excitation(arm, duration=1.0, rate=3.0, harmonics=1, iterations=0)
    with pytest.raises(md.ModelError, match="grid: 4 samples give 24 equations"):
        excitation(arm, duration=1.0, rate=100.0, harmonics=1, grid=4, iterations=0)


def test_harmonics_above_nyquist_are_refused():
    arm = _load("ur5")
    with pytest.raises(md.ModelError, match=r"harmonics: the highest harmonic, 5 / 2 s = 2\.5 Hz, is at or "
                                            r"above the Nyquist frequency of the samples, rate / 2 = 2 Hz"):
        excitation(arm, duration=2.0, harmonics=5, rate=4.0, iterations=0)
    with pytest.raises(md.ModelError, match="grid: 10 points per period cannot resolve 5 harmonics"):
        excitation(arm, duration=10.0, harmonics=5, grid=10, iterations=0)
    # below Nyquist is accepted: 4 / 20 s = 0.2 Hz < 0.25 Hz, 10 samples x 6 joints >= r
    ex = excitation(arm, duration=20.0, harmonics=4, rate=0.5, iterations=0, ramp=0)   # one period: 10 samples
    assert len(ex.t) == 10 and np.isfinite(ex.condition_number)
