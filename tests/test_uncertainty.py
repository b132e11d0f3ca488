"""How sure is the identified model (issue 19): calibrated standard deviations of the base
parameters, the covariance of ``consistent``, and the block bootstrap locally and on Dask."""

from __future__ import annotations

import numpy as np
import pytest

import manipdyn as md

pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
from scipy.stats import chi2  # noqa: E402  (scipy comes with the identify extra)

from manipdyn.identification import base_parameters, excitation, fit, format_report  # noqa: E402
from manipdyn.identification.demo import true_arm  # noqa: E402
from manipdyn.parameters import arm_parameters  # noqa: E402

DRAWS = 40          # seeded noise draws of the calibration test
Z95 = 1.959963984540054


@pytest.fixture(scope="module")
def perturbed_ur5():
    """A UR5 prior, a truth around it (masses +-20 %, COMs +-2 cm, friction), an unoptimised
    6 s excitation at 100 Hz (600 samples), the exact torques and 1 %-of-peak noise levels."""
    prior = md.load("ur5")
    truth = true_arm(prior, seed=1)
    ex = excitation(prior, duration=6.0, harmonics=3, rate=100.0, iterations=0)
    tau0 = truth.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    sigma = 0.01 * np.abs(tau0).max(axis=0)
    base = base_parameters(prior, friction=True)
    beta_true = base.from_full(arm_parameters(truth, False, True))
    return prior, ex, tau0, sigma, base, beta_true


def test_wls_standard_deviations_are_calibrated(perturbed_ur5):
    """Over 40 seeded noise draws the reported sigma of each base parameter matches the spread of
    its estimate, and the nominal 95 % intervals hold the truth about 95 % of the time.

    Measured (this setup, 48 base parameters): sigma / spread median 0.97, range 0.81 to 1.26;
    coverage 94.2 %.
    """
    prior, ex, tau0, sigma, base, beta_true = perturbed_ur5
    betas, stds = [], []
    for k in range(DRAWS):
        tau = tau0 + sigma * np.random.default_rng(k).standard_normal(tau0.shape)
        r = fit(prior, ex.q, ex.qd, ex.qdd, tau, method="wls", friction=True, base=base)
        assert r.covariance.shape == (base.count, base.count)
        np.testing.assert_allclose(np.sqrt(np.diag(r.covariance)),
                                   [row["std"] for row in r.report["base_parameters"]], rtol=1e-12)
        betas.append(r.beta)
        stds.append(np.sqrt(np.diag(r.covariance)))
    betas, stds = np.array(betas), np.array(stds)
    spread = betas.std(axis=0, ddof=1)
    ratio = stds.mean(axis=0) / spread
    # spread^2 / sigma^2 ~ chi2(DRAWS - 1) / (DRAWS - 1) if sigma is right; each of the r
    # ratios must lie inside the two-sided chi-square interval at 1e-3 overall (Bonferroni over
    # the r parameters): a sigma off by a factor 1.5 or more fails it
    a = 1e-3 / base.count
    lo = np.sqrt((DRAWS - 1) / chi2.ppf(1 - a / 2, DRAWS - 1))
    hi = np.sqrt((DRAWS - 1) / chi2.ppf(a / 2, DRAWS - 1))
    assert np.all((lo < ratio) & (ratio < hi)), (lo, hi, ratio)
    # the median over the parameters: each ratio has a relative standard error of
    # 1 / sqrt(2 (DRAWS - 1)) = 0.11, the median of 48 of them ~0.02 if independent
    # (more, as they are correlated): +-0.15 is a systematic error of 15 %, not chance
    assert 0.85 < np.median(ratio) < 1.15, np.median(ratio)
    # coverage of the 95 % intervals over DRAWS x r = 1920 intervals: binomial standard
    # error 0.5 % if independent; +-3 % leaves room for their correlation within a draw
    coverage = np.mean(np.abs(betas - beta_true) <= Z95 * stds)
    assert 0.92 <= coverage <= 0.98, coverage


def test_consistent_carries_the_wls_covariance_of_the_same_problem(perturbed_ur5):
    """``consistent`` reports the covariance of the unconstrained weighted problem (same weights,
    same regressor: bit-identical to the wls one), says so, and shows %sigma in its text report;
    ``ols`` reports none."""
    prior, ex, tau0, sigma, base, _ = perturbed_ur5
    tau = tau0 + sigma * np.random.default_rng(99).standard_normal(tau0.shape)
    w = fit(prior, ex.q, ex.qd, ex.qdd, tau, method="wls", friction=True, base=base)
    c = fit(prior, ex.q, ex.qd, ex.qdd, tau, method="consistent", friction=True, base=base)
    np.testing.assert_array_equal(c.covariance, w.covariance)
    assert c.report["std_source"].startswith("wls covariance") and "constraints" in c.report["std_source"]
    assert all(row["std"] > 0 for row in c.report["base_parameters"])
    assert "%sigma" in format_report(c.report) and "+-" in format_report(c.report)
    o = fit(prior, ex.q, ex.qd, ex.qdd, tau, method="ols", friction=True, base=base)
    assert o.covariance is None and o.report["std_source"] is None
    assert "%sigma" not in format_report(o.report)
