"""Are the identification's error bars right?  ``python -m manipdyn.identification.experiments.calibration``.

Layer 5 (identification).

A seeded synthetic study with a known truth and a known noise: a perturbed arm
(:func:`.demo.true_arm`), an excitation trajectory, and ``repeats`` noise draws of
its torques (``noise`` times each joint's peak torque, white Gaussian; q, qd, qdd
exact).  Each draw is identified with ``wls`` (friction identified), and the
study counts how often the nominal 95 % intervals contain the truth:

* base parameters: ``|beta_hat_k - beta_k| <= 1.96 sigma_k`` with
  ``sigma_k = sqrt(C_kk)`` of :mod:`.uncertainty`;
* held-out torque predictions (the noise-free torque of the true arm along a
  second, unoptimised trajectory, ``samples`` of its points): the prediction
  ``Y_b beta_hat`` has the standard deviation ``sqrt(y_b^T C y_b)`` per joint and
  sample, and ``|tau_hat - tau_true| <= 1.96`` of it;

and reports the ratio of the reported sigma to the spread of the estimates
over the draws.  Well calibrated: coverage 93 to 97 %, ratio near 1.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

__all__ = ["calibrate"]

Z95 = 1.959963984540054


def calibrate(model: str = "ur5", repeats: int = 500, noise: float = 0.01, seed: int = 1,
              duration: float = 6.0, rate: float = 100.0, samples: int = 200) -> dict:
    """Run the study of the module docstring; a JSON-ready dict of its figures."""
    from ..._support.threads import blas_threads
    from ...formats.loading import load
    from ...model.parameters import arm_parameters
    from ..estimation.base import base_parameters
    from .demo import true_arm
    from ..estimation.fitting import fit
    from .trajectory import excitation

    prior = load(model)
    truth = true_arm(prior, seed=seed)
    with blas_threads(1):
        ex = excitation(prior, duration=duration, harmonics=3, rate=rate, iterations=0, seed=seed)
        held = excitation(prior, duration=duration, harmonics=3, rate=rate, iterations=0, seed=seed + 1)
        pick = np.linspace(0, len(held.q) - 1, samples).astype(int)
        hq, hqd, hqdd = held.q[pick], held.qd[pick], held.qdd[pick]
        tau0 = truth.inverse_dynamics(ex.q, ex.qd, ex.qdd)
        sigma = noise * np.abs(tau0).max(axis=0)
        base = base_parameters(prior, friction=True)
        beta_true = base.from_full(arm_parameters(truth, False, True))
        tau_true = truth.inverse_dynamics(hq, hqd, hqdd)
        Yb = base.regressor(prior.lagrange.regressor(hq, hqd, hqdd, friction=True))     # (S, n, r)
        betas, stds, pcover = [], [], []
        for k in range(repeats):
            tau = tau0 + sigma * np.random.default_rng([seed, k]).standard_normal(tau0.shape)
            r = fit(prior, ex.q, ex.qd, ex.qdd, tau, method="wls", friction=True, base=base)
            betas.append(r.beta)
            stds.append(np.sqrt(np.diag(r.covariance)))
            pred = Yb @ r.beta
            psd = np.sqrt(np.einsum("snr,rt,snt->sn", Yb, r.covariance, Yb))
            pcover.append(np.abs(pred - tau_true) <= Z95 * psd)
    betas, stds, pcover = np.array(betas), np.array(stds), np.array(pcover)
    ratio = stds.mean(axis=0) / betas.std(axis=0, ddof=1)
    return {
        "model": model, "repeats": repeats, "noise": noise, "seed": seed, "n_base": int(base.count),
        "training_samples": len(ex.q), "heldout_points": int(samples),
        "base_coverage_95": float(np.mean(np.abs(betas - beta_true) <= Z95 * stds)),
        "base_coverage_95_per_parameter_min": float(np.min(np.mean(np.abs(betas - beta_true) <= Z95 * stds,
                                                                   axis=0))),
        "prediction_coverage_95": float(pcover.mean()),
        "prediction_coverage_95_per_joint": [float(x) for x in pcover.mean(axis=(0, 1))],
        "sigma_over_spread_median": float(np.median(ratio)),
        "sigma_over_spread_range": [float(ratio.min()), float(ratio.max())],
    }


def build_parser() -> argparse.ArgumentParser:
    """The command line of ``python -m manipdyn.identification.experiments.calibration``."""
    p = argparse.ArgumentParser(prog="python -m manipdyn.identification.experiments.calibration",
                                description="Are the identification's error bars right? Identifies --repeats "
                                "noisy logs of a known arm with wls and prints, as JSON, how often the 95 % "
                                "intervals hold the truth (base parameters, held-out torques): 93 to 97 % is "
                                "well calibrated.")
    p.add_argument("--model", default="ur5", help="the prior arm, perturbed into the truth (a bundled name, "
                   ".toml or .urdf; default: ur5)")
    p.add_argument("--repeats", type=int, default=500, help="noise draws, each identified with wls (default: "
                   "500; the coverage's own standard error is about 1 %% at 500)")
    p.add_argument("--noise", type=float, default=0.01, help="torque noise as a fraction of each joint's peak "
                   "torque, white Gaussian (default: 0.01)")
    p.add_argument("--seed", type=int, default=1, help="seed of the truth, the trajectories and the noise "
                   "(default: 1)")
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    print(json.dumps(calibrate(args.model, args.repeats, args.noise, args.seed), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
