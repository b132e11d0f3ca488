"""Identification on data no one tuned to: ``python -m manipdyn.identification.experiments.demo``.

Layer 5 (identification).

A "true" arm differs from the prior (masses +-20 %, centres of mass moved by
up to 2 cm, viscous and Coulomb friction added).  Its torques along an
optimised excitation trajectory, sampled at 200 Hz, get measurement noise:
1 % of each joint's peak torque on tau, and ``q_noise`` rad on q; qd and qdd
are then derived from the noisy q the way ``manipdyn identify`` does it
(zero-phase filter, central differences).  The demo

1. identifies the arm with ``ols``, ``wls`` and ``consistent`` (friction on);
2. reports the base-parameter error and the held-out torque RMS error (a
   second, unoptimised Fourier trajectory, other seed) against each joint's
   noise level, and pooled over the joints;
3. shows that on poorly exciting data (a short, slow, one-harmonic
   trajectory) ordinary least squares refuses to fit (the condition number
   is over its threshold) where ``consistent`` returns a physically
   consistent arm;
4. with ``--plot`` (the ``plot`` extra), plots measured against predicted
   held-out torques.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import warnings

import numpy as np

from ..._support.progress import Progress
from ..._support.threads import blas_threads
from ...model.arm import Manipulator
from ..._support.errors import ModelError, PhysicalConsistencyWarning
from ...formats.loading import load

__all__ = ["true_arm", "measure", "run_demo"]


def true_arm(prior, seed: int = 0, mass: float = 0.2, com: float = 0.02, friction: float = 0.03):
    """The prior with masses scaled by U(1 - mass, 1 + mass), COMs moved by U(+-com) m
    per axis (DH frame), and friction ``fv = fc = friction * peak |g_j|`` added
    (``fv`` per rad/s), ``peak |g_j|`` over 200 random states."""
    rng = np.random.default_rng(seed)
    peak = np.abs(prior.gravity_torque(prior.random_state(rng, 200))).max(axis=0) + 0.1
    links = []
    for i, l in enumerate(prior.links):
        links.append(dataclasses.replace(
            l, mass=l.mass * rng.uniform(1 - mass, 1 + mass), com=l.com + rng.uniform(-com, com, 3),
            friction_viscous=friction * peak[i], friction_coulomb=friction * peak[i]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicalConsistencyWarning)
        return Manipulator(links, convention=prior.convention, gravity=prior.gravity,
                              name=f"{prior.name}_true", source=prior.source)


def measure(arm, traj, rng, tau_noise: float = 0.01, q_noise: float = 1e-4, peak=None):
    """Noisy measurements of ``arm`` along ``traj`` (an :class:`Excitation`).

    Returns ``(data, tau_raw, peak)``: :class:`Measurements` after the identify
    pipeline (qd, qdd derived from the noisy q, ends trimmed), the measured
    noisy torques at the same samples, and the per-joint peak ``|tau|`` that set
    the noise (``tau_noise * peak`` standard deviation).
    """
    from ...formats.logs.data import Measurements, derivatives

    tau = arm.inverse_dynamics(traj.q, traj.qd, traj.qdd)
    if peak is None:
        peak = np.abs(tau).max(axis=0)
    tau_m = tau + tau_noise * peak * rng.standard_normal(tau.shape)
    q_m = traj.q + q_noise * rng.standard_normal(traj.q.shape)
    t, qf, qd, qdd, tf = derivatives(traj.t, q_m, tau_m)
    keep = np.searchsorted(traj.t, t)          # the samples the filter kept
    return Measurements(t, qf, qd, qdd, tf, derived=True), tau_m[keep], peak


def run_demo(name: str = "ur5", seed: int = 0, iterations: int = 15, plot: str | None = None,
             out=sys.stdout, progress: bool = False) -> dict:
    """Run the demo; print the figures to ``out`` and return them as a dict.

    ``progress=True`` reports each stage (and the optimiser's iterations) on stderr.
    """
    from ..estimation.base import base_parameters
    from ..estimation.fitting import fit
    from .trajectory import Excitation, excitation, fourier_trajectory

    stages = Progress("optimiser", bool(progress), width=20, unit="iterations")
    stages.stage(f"loading {name} and drawing the true arm")
    prior = load(name)
    truth = true_arm(prior, seed)
    rng = np.random.default_rng(seed)
    stages.stage("base parameters")
    base = base_parameters(prior, friction=True)        # one base for every excitation and fit
    # ramp=0: one period of the series, as the demo has always measured it (a simulated arm needs
    # no start from rest, and the published figures stay reproducible)
    kw = dict(duration=10.0, harmonics=5, rate=200.0, friction=True, base=base, ramp=0)
    stages.stage(f"optimising the excitation trajectory ({iterations} iterations)")
    train = excitation(prior, seed=seed, iterations=iterations, progress=stages, **kw)
    stages.stage("measuring the true arm along it, and along a held-out trajectory")
    test = excitation(prior, seed=seed + 1, iterations=0, **kw)     # held out: not optimised
    data, _, peak = measure(truth, train, rng)
    held, held_tau, _ = measure(truth, test, rng, peak=peak)
    sigma = 0.01 * peak
    print(f"prior {name}, true arm: masses +-20 %, COMs moved, friction added; noise 1 % of peak "
          f"torque on tau, 1e-4 rad on q; {len(data)} training samples, condition number "
          f"{train.condition_number:.3g}", file=out)
    figures = {"noise": sigma.tolist(), "methods": {}}
    fits = {}
    for method in ("ols", "wls", "consistent"):
        stages.stage(f"fit: {method}")
        r = fits[method] = fit(prior, data.q, data.qd, data.qdd, data.tau, method=method, friction=True,
                               base=base)
        beta_true = r.base.from_full(truth.parameters(friction=True))
        beta_err = float(np.linalg.norm(r.beta - beta_true) / np.linalg.norm(beta_true))
        rms = np.sqrt(np.mean((r.predict(held.q, held.qd, held.qdd) - held_tau) ** 2, axis=0))
        pooled = float(np.sqrt(np.sum(rms**2) / np.sum(sigma**2)))
        figures["methods"][method] = {"beta_rel_error": beta_err, "heldout_rms": rms.tolist(),
                                      "ratio": (rms / sigma).tolist(), "pooled_ratio": pooled,
                                      "consistent": r.consistent}
        print(f"{method:>10}: base-parameter error {100 * beta_err:.2f} % (relative norm), "
              f"physically consistent: {r.consistent}", file=out)
        print("            held-out RMS / noise per joint: "
              + " ".join(f"{x:.3f}" for x in rms / sigma) + f"; pooled {pooled:.3f}", file=out)
    # poorly exciting data: 4 s of one slow harmonic
    t = np.arange(800) / 200.0
    a = 0.05 * np.random.default_rng(seed + 7).standard_normal((prior.n, 1))
    q0 = prior.qlim.mean(axis=1)
    poor = Excitation(q0, a, np.zeros_like(a), 4.0, t, *fourier_trajectory(t, q0, a, 0 * a, 4.0), 0.0, 0)
    pdata, _, _ = measure(truth, poor, rng, peak=peak)
    figures["poor"] = {}
    for method in ("ols", "consistent"):
        stages.stage(f"poorly exciting data, fit: {method}")
        try:
            r = fit(prior, pdata.q, pdata.qd, pdata.qdd, pdata.tau, method=method, friction=True, base=base)
        except ModelError as exc:     # ols refuses data this ill-conditioned (its threshold)
            figures["poor"][method] = "refused"
            print(f"poorly exciting data, {method}: refused ({exc})", file=out)
            continue
        figures["poor"][method] = r.consistent
        print(f"poorly exciting data (condition number {r.condition_number:.3g}), {method}: "
              f"physically consistent: {r.consistent}", file=out)
    if plot:
        from ..._support.deps import MissingExtraError
        try:
            import matplotlib  # noqa: F401  (the figure itself: validation.plot_validation)
        except ImportError:
            raise MissingExtraError("--plot needs matplotlib: pip install 'manipdyn[plot]'") from None
        from ...formats.logs.measurements import Measurements
        from ..results.validation import plot_validation, validate

        scored = validate(fits["consistent"], Measurements(held.t, held.q, held.qd, held.qdd, held_tau),
                          name="consistent fit")
        plot_validation(scored, plot, title=f"identification demo ({name}): held-out joint torques, "
                                             "measured and predicted by the consistent fit")
        print(f"plot written to {plot}", file=out)
    return figures


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m manipdyn.identification.experiments.demo", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--model", default="ur5", help="prior model (default ur5)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--iterations", type=int, default=15, help="excitation optimiser iterations")
    p.add_argument("--plot", metavar="FILE.png", default=None, help="plot measured vs predicted torques")
    prog = p.add_mutually_exclusive_group()
    prog.add_argument("--progress", dest="progress", action="store_true", default=None,
                      help="report each stage on stderr (default: only when stderr is a terminal)")
    prog.add_argument("--no-progress", dest="progress", action="store_false")
    args = p.parse_args(argv)
    show = args.progress if args.progress is not None else sys.stderr.isatty()
    with blas_threads(1):          # small matrices: one BLAS thread is faster (manipdyn/_support/threads.py)
        run_demo(args.model, args.seed, args.iterations, args.plot, progress=show)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
