"""Variable projection of friction shapes, and identification from the seeded hard log (issue 17, items 3, 7)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.model.friction import Friction
from manipdyn.identification import read_log
from manipdyn.identification.experiments.hardlog import SMOOTHING, hard_log, recovered
from manipdyn.identification.experiments.trajectory import fourier_trajectory
from manipdyn.identification.estimation.varpro import fit_friction_shapes


def _ur5():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load("ur5")


def _motion(n, seed, T=20.0, N=4000):
    rng = np.random.default_rng(seed)
    l = np.arange(1, 8)
    a, b = rng.standard_normal((n, 7)) / np.sqrt(l), rng.standard_normal((n, 7)) / np.sqrt(l)
    t = np.linspace(0, T, N, endpoint=False)
    q, qd, qdd = fourier_trajectory(t, rng.uniform(-1, 1, n), a, b, T)
    s = 1.2 / np.abs(qd).max(axis=0)                   # peak speed 1.2 rad/s per joint
    return fourier_trajectory(t, rng.uniform(-1, 1, n), a * s[:, None], b * s[:, None], T)


def test_varpro_recovers_sigmoid_shapes_on_the_joint_side():
    """Gaz et al.'s sigmoid with known alpha and p3; the fit starts at half alpha and p3 = 0."""
    prior = _ur5()
    n = prior.n
    rng = np.random.default_rng(3)
    alpha = rng.uniform(30.0, 60.0, n)
    p3 = rng.uniform(-0.05, 0.05, n)
    law = Friction(viscous=rng.uniform(0.5, 2.0, n), sigmoid_A=rng.uniform(2.0, 5.0, n),
                   sigmoid_alpha=alpha, sigmoid_p3=p3)
    truth = md.Manipulator(prior.links, convention=prior.convention, gravity=prior.gravity, friction=law)
    q, qd, qdd = _motion(n, 0)
    tau = truth.inverse_dynamics(q, qd, qdd)
    tau = tau + 1e-3 * np.abs(tau).max(axis=0) * rng.standard_normal(tau.shape)
    start = Friction(viscous=np.zeros(n), sigmoid_A=np.zeros(n), sigmoid_alpha=alpha / 2, sigmoid_p3=np.zeros(n))
    r = fit_friction_shapes(prior, (q, qd, qdd, tau), friction=start, method="wls")
    got = r.base.friction
    # 0.1 % torque noise and 4000 samples determine alpha and p3 to well under 1 %; 2 % leaves
    # room for the seeds, while a fit that stayed at the start is off by 50 % (alpha) or |p3|
    assert np.all(np.abs(got.sigmoid_alpha / alpha - 1) < 0.02), got.sigmoid_alpha / alpha
    assert np.all(np.abs(got.sigmoid_p3 - p3) < 0.02 * np.abs(p3).max()), (got.sigmoid_p3, p3)
    shapes = r.report["friction_shapes"]
    assert shapes["weighted_residual_norm"]["fitted"] < 0.5 * shapes["weighted_residual_norm"]["initial"]
    # the written arm carries the fitted law and predicts what the fit predicted
    assert r.arm is not None and r.arm.friction_model.sigmoid_alpha is not None
    np.testing.assert_allclose(r.arm.inverse_dynamics(q, qd, qdd), r.predict(q, qd, qdd), atol=1e-8, rtol=1e-8)


def test_varpro_refuses_a_law_without_shapes():
    prior = _ur5()
    with pytest.raises(md.ModelError, match="no nonlinear shape"):
        fit_friction_shapes(prior, tuple(np.zeros((10, 6)) for _ in range(4)), friction=Friction(viscous=np.zeros(6)))


def test_hard_log_is_hard(tmp_path):
    h = hard_log(2, tmp_path, duration=3.0, held_out=1.0)
    header = open(h.log).readline().strip().split(",")
    assert header == ["t"] + [f"qm{i}" for i in range(1, 7)] + [f"i{i}" for i in range(1, 7)]   # no qd, no tau
    data = np.loadtxt(h.log, delimiter=",", skiprows=1)
    steps = np.diff(data[:, 0])
    assert np.all(steps > 0) and steps.max() > 1.5 * np.median(steps)                     # gaps
    assert np.ptp(steps[steps < 1.5 * np.median(steps)]) > 0.1 * np.median(steps)          # jitter
    assert np.any(np.all(data[1:, 1:] == data[:-1, 1:], axis=1))                          # duplicated rows
    step = 2 * math.pi / 2**16
    assert np.allclose(np.round(data[:, 1:7] / step) * step, data[:, 1:7], rtol=0, atol=1e-6)  # encoder counts
    truth, prior = md.load(h.truth_file), md.load(h.prior_file)
    assert truth.transmission == prior.transmission == h.truth.transmission
    assert truth.transmission.R[5, 4] == 32.0 and truth.transmission.R[2, 2] < 0
    assert truth.friction_model == h.truth.friction_model and prior.friction_model is None
    m = read_log(h.log, 6, transmission=prior.transmission)
    assert any("duplicate" in s for s in m.notes) and any("gaps" in s for s in m.notes)


def test_identification_from_the_hard_log_meets_the_issue_targets(tmp_path):
    """Issue 17, item 7.  Identify from the log as written (motor-side positions and currents,
    messy stamps), on the first 30 s, validate on the last 10 s.  Seed 0 here; seeds 0 to 7
    in benchmarks/bench_hardlog.py."""
    h = hard_log(0, tmp_path)                                    # 40 s, 10 s held out
    prior = md.load(h.prior_file)
    data = read_log(h.log, 6, transmission=prior.transmission, t_range=(None, h.split))
    z = np.zeros(6)
    spec = Friction(viscous=z, coulomb_pos=z, coulomb_neg=z, offset=z, stribeck_level=z,
                    stribeck_velocity=np.full(6, 5.0), side="motor", smoothing=SMOOTHING)
    r = fit_friction_shapes(prior, data, friction=spec, method="wls", armature=True)
    # held out: the identified model on the true states of the last 10 s against the logged
    # torques R^T k_t i, whose noise sigma_j is known; 1.05 sigma leaves a model error of
    # at most 0.32 sigma (sqrt(1.05^2 - 1))
    m = h.t >= h.split
    rms = np.sqrt(np.mean((h.tau[m] - r.predict(h.q[m], h.qd[m], h.qdd[m])) ** 2, axis=0))
    assert np.all(rms <= 1.05 * h.sigma), rms / h.sigma
    rec = recovered(r, h.truth)
    # motors 1 and 2's rotor inertias are grouped with link inertias (not identifiable alone)
    assert {k for k, v in rec.items() if not v["identifiable"]} == {"joint1.armature", "joint2.armature"}
    errors = {k: v["error"] for k, v in rec.items() if v["identifiable"]}
    assert len(errors) == 4 + 6 * 6           # armatures 3..6; fv, fc+, fc-, offset, Stribeck level and velocity
    # the issue's target, 5 %, on every identifiable rotor and friction parameter
    assert max(abs(e) for e in errors.values()) < 0.05, {k: round(e, 4) for k, e in errors.items() if abs(e) >= 0.05}


def test_cli_identify_fits_sigmoid_shapes_by_variable_projection(tmp_path, capsys):
    """``identify --friction-terms viscous,sigmoid`` runs variable projection from its documented
    start (alpha = 10 s/rad, p3 = 0) and writes a model whose law carries the fitted shapes."""
    import json

    from manipdyn.cli import main
    from manipdyn.identification import write_measurements_csv

    prior = _ur5()
    n = prior.n
    rng = np.random.default_rng(4)
    alpha, p3 = rng.uniform(30.0, 60.0, n), rng.uniform(-0.05, 0.05, n)
    law = Friction(viscous=rng.uniform(0.5, 2.0, n), sigmoid_A=rng.uniform(2.0, 5.0, n),
                   sigmoid_alpha=alpha, sigmoid_p3=p3)
    truth = md.Manipulator(prior.links, convention=prior.convention, gravity=prior.gravity, friction=law)
    q, qd, qdd = _motion(n, 1)
    t = np.arange(len(q)) * (20.0 / len(q))
    tau = truth.inverse_dynamics(q, qd, qdd)
    tau = tau + 1e-3 * np.abs(tau).max(axis=0) * rng.standard_normal(tau.shape)
    data = tmp_path / "d.csv"
    write_measurements_csv(data, t, q, tau, qd=qd, qdd=qdd)
    out = tmp_path / "id.toml"
    code = main(["identify", "ur5", str(data), "-o", str(out), "--friction-terms", "viscous,sigmoid", "--json"])
    rep = json.loads(capsys.readouterr().out)
    assert code == 0, rep
    shapes = rep["friction_shapes"]
    assert shapes["initial"]["sigmoid_alpha"] == [10.0] * n and shapes["converged"]
    got = md.load(str(out)).friction_model
    np.testing.assert_allclose(got.sigmoid_alpha, shapes["fitted"]["sigmoid_alpha"], rtol=1e-9)
    # the same 2 % as the API test above; a search that stayed at the start is off by 67 to 83 %
    assert np.all(np.abs(got.sigmoid_alpha / alpha - 1) < 0.02), got.sigmoid_alpha / alpha
    assert np.all(np.abs(got.sigmoid_p3 - p3) < 0.02 * np.abs(p3).max()), (got.sigmoid_p3, p3)
    assert rep["provenance"]["options"]["friction_terms"] == "viscous,sigmoid"


def test_cli_shape_options_name_what_is_wrong(tmp_path, capsys):
    from manipdyn.cli import main

    d = tmp_path / "d.csv"
    d.write_text("t,q1,q2,q3,q4,q5,q6,tau1,tau2,tau3,tau4,tau5,tau6\n0,0,0,0,0,0,0,0,0,0,0,0,0\n")
    o = str(tmp_path / "x.toml")
    assert main(["identify", "ur5", str(d), "-o", o, "--stribeck-velocity", "0.1"]) == 2
    assert "--stribeck-velocity: only with --friction-terms" in capsys.readouterr().err
    assert main(["identify", "ur5", str(d), "-o", o, "--friction-terms", "viscous", "--sigmoid-alpha", "5"]) == 2
    assert "--sigmoid-alpha: only with a sigmoid term" in capsys.readouterr().err
    assert main(["identify", "ur5", str(d), "-o", o, "--friction-terms", "stribeck", "--stribeck-velocity", "-1"]) == 2
    assert "--stribeck-velocity: expected a finite number > 0" in capsys.readouterr().err


def test_varpro_moves_off_a_start_of_exactly_one():
    """Stribeck velocities near 1 rad/s, searched from 0.1: the coarse grid puts every start at
    0.1 x 10 = 1.0, i.e. log-shape 4e-16.  least_squares sized its first trust region by that and
    stopped at once ('converged', one evaluation, velocities exactly 1.0); the search now runs on
    shifted variables with absolute difference steps, and finds the truth."""
    prior = _ur5()
    n = prior.n
    rng = np.random.default_rng(5)
    vs = rng.uniform(0.8, 1.3, n)
    law = Friction(viscous=rng.uniform(0.5, 2.0, n), coulomb=rng.uniform(1.0, 3.0, n),
                   stribeck_level=rng.uniform(1.0, 2.0, n), stribeck_velocity=vs)
    truth = md.Manipulator(prior.links, convention=prior.convention, gravity=prior.gravity, friction=law)
    q, qd, qdd = _motion(n, 2)
    tau = truth.inverse_dynamics(q, qd, qdd)
    tau = tau + 1e-3 * np.abs(tau).max(axis=0) * rng.standard_normal(tau.shape)
    z = np.zeros(n)
    start = Friction(viscous=z, coulomb=z, stribeck_level=z, stribeck_velocity=np.full(n, 0.1))
    r = fit_friction_shapes(prior, (q, qd, qdd, tau), friction=start, method="wls")
    shapes = r.report["friction_shapes"]
    assert shapes["start_factor"] == [10.0] * n and shapes["evaluations"] > 2
    got = r.base.friction.stribeck_velocity
    # 0.1 % noise on 4000 samples: a few 0.1 % on each velocity; 3 % leaves room for the seed,
    # where staying at the start is off by 8 to 25 %
    assert np.all(np.abs(got / vs - 1) < 0.03), got / vs


def test_hard_log_through_the_command_line(tmp_path, capsys):
    """The README's commands: identify from the log as written (motor side, currents, the prior's
    transmission, Stribeck shapes by variable projection), then validate on the last 10 s."""
    import json

    from manipdyn.cli import main

    h = hard_log(0, tmp_path)
    out = tmp_path / "id.toml"
    assert main(["identify", h.prior_file, h.log, "-o", str(out), "--t-range", ":30", "--armature",
                 "--friction-terms", "viscous,asymmetric,offset,stribeck", "--friction-side", "motor",
                 "--smoothing", "2", "--stribeck-velocity", "5"]) == 0
    capsys.readouterr()
    assert main(["validate", str(out), h.log, "--t-range", "30:", "--json"]) == 0
    ratio = np.array(json.loads(capsys.readouterr().out)["rms"]) / h.sigma
    # linear resampling of the jittered stamps leaves sqrt(2/3) = 0.816 of the white noise (the
    # mean of (1 - a)^2 + a^2 over a uniform a); 0.9 leaves a model error of at most 0.37 sigma
    assert np.all((0.75 < ratio) & (ratio < 0.9)), ratio


def test_varpro_names_shapes_the_data_do_not_determine():
    """A Stribeck velocity started at 1e9 rad/s (far above every speed of the log) leaves the
    residual unchanged: the search cannot move it, and the report says so instead of only
    'converged'."""
    prior = _ur5()
    q, qd, qdd = _motion(prior.n, 3)
    rng = np.random.default_rng(6)
    tau = prior.inverse_dynamics(q, qd, qdd) + 0.01 * rng.standard_normal(q.shape)
    z = np.zeros(prior.n)
    start = Friction(viscous=z, stribeck_level=z, stribeck_velocity=np.full(prior.n, 1e9))
    info = fit_friction_shapes(prior, (q, qd, qdd, tau), friction=start, method="wls").report["friction_shapes"]
    assert info["undetermined"] == [f"stribeck_velocity[{i}]" for i in range(1, prior.n + 1)]
    start = Friction(viscous=z, stribeck_level=z, stribeck_velocity=np.full(prior.n, 0.5))
    info = fit_friction_shapes(prior, (q, qd, qdd, tau), friction=start, method="wls").report["friction_shapes"]
    assert info["undetermined"] == []
