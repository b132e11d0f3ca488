"""The identification pipelines (issue 24 items 1 and 2, issue 25 item 3): ``md.identify`` and
``md.validate`` with several logs, RUNS.toml, known payloads, torque constants from currents,
URDF priors written as full models, and the same defaults as the command line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main

pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
from manipdyn.identification import excitation, write_measurements_csv  # noqa: E402
from manipdyn.identification.inputs.runs import Payload, read_runs_file  # noqa: E402

UR5 = Path(__file__).resolve().parent.parent / "urdf" / "ur5.urdf"
PAYLOAD = Payload(1.5, (0.03, -0.02, 0.06), (0.004, 0.005, 0.003, 0.0, 0.0, 0.0))


def _logs(folder, arm, seeds, noise, payload_on=(), truth=None):
    """CSV logs ``t,q,tau`` (derivatives left to the reader) of excitation runs of ``arm``,
    with white torque noise ``noise[k]`` (N m) on run k; the truth's torques (default ``arm``)."""
    truth = truth or arm
    rng = np.random.default_rng(7)
    paths, trajs = [], []
    for k, seed in enumerate(seeds):
        ex = excitation(arm, duration=8.0, harmonics=4, rate=200.0, iterations=0, seed=seed)
        tau = truth.inverse_dynamics(ex.q, ex.qd, ex.qdd)
        if k in payload_on:
            tau = tau + PAYLOAD.torque(truth, ex.q, ex.qd, ex.qdd)
        tau = tau + noise[k] * rng.standard_normal(tau.shape)
        path = Path(folder) / f"run{k + 1}.csv"
        write_measurements_csv(path, ex.t, ex.q, tau)
        paths.append(path)
        trajs.append(ex)
    return paths, trajs


def test_several_logs_are_read_each_on_its_own_and_weighed_by_their_noise(tmp_path):
    arm = md.load("ur5")
    (p1, p2), (e1, e2) = _logs(tmp_path, arm, seeds=(1, 2), noise=(0.02, 0.2))
    r = md.identify(arm, [p1, p2], method="wls")
    data = r.data
    assert [Path(s).name for s in data.sources] == ["run1.csv", "run2.csv"] and len(data.segments) == 2
    # no derivative across the file boundary: each run's accelerations match its own trajectory
    # (q jumps between the files; a filter across them would ring there)
    start = 0
    for ex, k in zip((e1, e2), data.segments):
        t, qdd = data.t[start:start + k], data.qdd[start:start + k]
        true = np.column_stack([np.interp(t, ex.t, ex.qdd[:, j]) for j in range(arm.n)])
        assert np.max(np.abs(qdd - true)) < 0.02 * np.max(np.abs(ex.qdd))
        start += k
    # each run's joints by their own noise: sampling error of a noise level from ~1000
    # residuals is ~2 %, so 15 % is a loose bound that a pooled estimate (off by 5x) fails
    per_run = np.array(r.report()["noise_sigma_per_run"])
    assert np.allclose(per_run[0], 0.02, rtol=0.15) and np.allclose(per_run[1], 0.2, rtol=0.15)
    # and the joint weights differ per run: the estimate is the weighted one (closer to the clean run)
    assert r.report()["runs"] == [{"log": "run1.csv", "samples": data.segments[0]},
                                  {"log": "run2.csv", "samples": data.segments[1]}]


def test_runs_toml_form_payload_and_refusals(tmp_path):
    arm = md.load("ur5")
    (p1, p2), (e1, _) = _logs(tmp_path, arm, seeds=(3, 4), noise=(0.05, 0.05), payload_on=(1,))
    sub = tmp_path / "runs"
    sub.mkdir()
    runs = sub / "RUNS.toml"
    runs.write_text(f'[[log]]\npath = "../run1.csv"\nt_range = [0.0, 7.5]\n\n[[log]]\npath = "{p2}"\n'
                    "payload = { mass = 1.5, com = [0.03, -0.02, 0.06], inertia = [0.004, 0.005, 0.003, 0.0, 0.0, 0.0] }\n")
    specs = read_runs_file(runs)
    assert Path(specs[0].path).resolve() == p1.resolve() and specs[0].t_range == (0.0, 7.5)
    assert specs[1].payload == PAYLOAD and specs[0].payload is None
    with_payload = md.identify(arm, runs, method="wls")
    ignored = md.identify(arm, [p1, p2], method="wls")       # the same logs, the payload not declared
    rms = [np.sqrt(np.mean((arm.inverse_dynamics(e1.q, e1.qd, e1.qdd) - r.fit.predict(e1.q, e1.qd, e1.qdd)) ** 2))
           for r in (with_payload, ignored)]
    # the known payload on the known side leaves only noise (0.05 N m over 6 x 1600 samples);
    # taken for the arm's own, it bends the fit by far more
    assert rms[0] < 0.01 and rms[1] > 5 * rms[0]
    for text, match in (('[[log]]\npath = "a.csv"\n[[log]]\npath = "b.csv"\nrate = -1\n', r"\[\[log\]\] 2: key 'rate'"),
                        ('[[log]]\npath = "a.csv"\npayload = { mass = 2.0 }\n', r"\[\[log\]\] 1: key 'payload'.com"),
                        ('[[log]]\nfile = "a.csv"\n', r"\[\[log\]\] 1: key 'file': unknown"),
                        ('[[log]]\npath = "a.csv"\nt_range = [5, 1]\n', r"\[\[log\]\] 1: key 't_range'"),
                        ('[[log]]\npath = "a.csv"\npayload = { mass = 1.0, com = [0, 0, 0], '
                         'inertia = [1.0, 0.1, 0.1, 0, 0, 0] }\n', r"\[\[log\]\] 1: key 'payload'.inertia")):
        runs.write_text(text)
        with pytest.raises(md.ModelError, match=match):
            read_runs_file(runs)
    if Path("/dev/zero").exists():      # a device is refused, not read without end
        with pytest.raises(md.ModelError, match="not a regular file"):
            read_runs_file("/dev/zero")


def test_cli_identify_and_validate_take_several_logs_and_models(tmp_path, capsys):
    arm = md.load("ur5")
    (p1, p2), _ = _logs(tmp_path, arm, seeds=(5, 6), noise=(0.05, 0.05))
    out = tmp_path / "ur5_id.toml"
    assert main(["identify", "ur5", str(p1), str(p2), "-o", str(out), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert [r["log"] for r in rep["runs"]] == ["run1.csv", "run2.csv"]
    ident = md.load(str(out))
    assert ident.name == "ur5_id"                       # named as the command line names it
    assert main(["validate", "ur5", str(out), str(p1), str(p2), "--json"]) == 0
    val = json.loads(capsys.readouterr().out)
    assert [m["model"] for m in val["models"]] == ["ur5", "ur5_id"] and len(val["best"]) == 6
    api = md.validate(["ur5", ident], [p1, p2])
    assert np.allclose([r.rms for r in api.results], [m["rms"] for m in val["models"]])
    # per log too: the pooled RMS is the samples' mean of the logs' squares
    runs = val["runs"]
    assert [r["log"] for r in runs] == ["run1.csv", "run2.csv"]
    pooled = np.sqrt(sum(r["samples"] * np.square(r["rms"]["ur5_id"]) for r in runs) / sum(r["samples"] for r in runs))
    assert np.allclose(pooled, val["models"][1]["rms"])
    # the API's identified arm is named as the CLI names it: after the file it is saved to
    r = md.identify(arm, [p1])
    assert r.arm.name == "ur5_identified"
    r.save(tmp_path / "mine.toml")
    assert md.load(str(tmp_path / "mine.toml")).name == "mine"
    # held out, the fit of run 1 predicts run 2 at the noise level (0.05 N m): 0.0497 to 0.0506
    # measured over three OpenBLAS kernels (default, Haswell, Prescott); 0.06 leaves 20 % for the
    # sampling spread of 6 x 1600 residuals (~2 %) and another machine's rounding.  Before the
    # solvers' answers were weighed (issue 38 item 10) SCS's loose answer was kept, and joint 1
    # read 0.050 to 0.072 here and 0.2019 on a fresh machine
    assert r.score([p2]).results[0].rms.max() < 0.06


def test_the_consistent_fit_does_not_move_with_the_blas_kernel(tmp_path):
    """Issue 38 item 10: one fit, two OpenBLAS kernels (``OPENBLAS_CORETYPE``), one answer.

    Clarabel reports "inaccurate" on this fit's floored problem; SCS's "optimal" then broke the
    PSD constraints by 1e-3 and its answer moved with the kernel's rounding (held-out torque of
    joint 1: 0.050 to 0.072 N m by kernel).  The kept answer is now the verified one, the same to
    ~1e-8 whatever the kernel; 1e-6 of the torque's scale leaves that a hundredfold margin.
    (Where the variable is not honoured, as on a CPU without those kernels, both runs use one
    kernel and the test checks nothing more than determinism.)"""
    import os
    import subprocess
    import sys

    arm = md.load("ur5")
    (p1,), (e1,) = _logs(tmp_path, arm, seeds=(5,), noise=(0.05,))
    script = (
        "import sys, numpy as np, manipdyn as md\n"
        f"r = md.identify(md.load('ur5'), [{str(p1)!r}])\n"
        f"np.save(sys.argv[1], r.fit.predict(*[np.load({str(tmp_path / 'state.npy')!r})[k] for k in range(3)]))\n")
    np.save(tmp_path / "state.npy", np.stack([e1.q[::50], e1.qd[::50], e1.qdd[::50]]))
    root = str(Path(__file__).resolve().parents[1])
    out = []
    for kernel in ("Prescott", "Haswell"):
        env = dict(os.environ, OPENBLAS_CORETYPE=kernel, PYTHONPATH=root)
        path = tmp_path / f"{kernel}.npy"
        proc = subprocess.run([sys.executable, "-c", script, str(path)], env=env, capture_output=True,
                              text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr[-3000:]
        out.append(np.load(path))
    scale = np.abs(out[0]).max()
    assert np.max(np.abs(out[0] - out[1])) < 1e-6 * scale
    from manipdyn.identification.estimation import sdp, solvers
    assert solvers.VIOLATION_TOL == sdp.EPS / 2     # a body that passes the check is still physical


def test_urdf_prior_with_friction_armature_and_gears_is_written_as_a_full_model(tmp_path):
    """A URDF prior with motor-side friction, rotor inertias and gears: the written model file
    (the URDF embedded, the drive beside it) predicts what the fit predicted (issue 24, item 5)."""
    from manipdyn.model.drive import Transmission
    from manipdyn.model.friction import Friction
    from manipdyn.formats.urdf.reader import load_urdf

    n = 6
    tr = Transmission.from_gear_ratios([50.0, 50.0, -50.0, 30.0, 30.0, 30.0], coupling=[[6, 5, 12.0]])
    law = Friction(viscous=np.full(n, 2e-4), coulomb=np.full(n, 0.02), offset=np.linspace(-0.3, 0.3, n),
                   side="motor", smoothing=0.5)
    truth = load_urdf(str(UR5), transmission=tr, friction=law, motor_inertia=np.full(n, 4e-5))
    prior = load_urdf(str(UR5), transmission=tr)
    (p1,), (e1,) = _logs(tmp_path, prior, seeds=(8,), noise=(0.02,), truth=truth)
    out = tmp_path / "ur5_full.toml"
    r = md.identify(prior, p1, friction_terms="viscous,coulomb,offset", friction_side="motor", smoothing=0.5,
                    armature=True, output=out)
    back = md.load(str(out))
    assert isinstance(back, md.URDFArm) and back.name == "ur5_full"
    assert np.array_equal(back.transmission.R, tr.R) and back.friction_model.side == "motor"
    q, qd, qdd = e1.q[::20], e1.qd[::20], e1.qdd[::20]
    fitted = r.fit.predict(q, qd, qdd)
    scale = np.abs(fitted).max()
    for engine in (back.inverse_dynamics, back.lagrange.inverse_dynamics):
        assert np.max(np.abs(engine(q, qd, qdd) - fitted)) < 1e-6 * scale
    # and it is the arm: the truth's torques within the noise's reach
    assert np.sqrt(np.mean((back.inverse_dynamics(q, qd, qdd) - truth.inverse_dynamics(q, qd, qdd)) ** 2)) < 0.05


def test_torque_constants_within_two_percent_on_the_hard_log_set(tmp_path):
    """Item 2's target on a seeded synthetic set built from the hard log (one run with a known
    payload): every motor's k_t within 2 % (benchmarks/bench_torque_constants.py measures
    3 seeds); without a payload and without the model's k_t, the scale from the prior's gravity."""
    from manipdyn.identification.experiments.hardlog import SMOOTHING, hard_log_set

    s = hard_log_set(0, tmp_path, duration=20.0)
    OPTIONS = dict(identify_torque_constants=True, armature=True, friction_terms="viscous,asymmetric,offset,stribeck",
                   friction_side="motor", smoothing=SMOOTHING, stribeck_velocity=5.0)
    r = md.identify(s["prior"], s["runs"], **OPTIONS)
    err = r.torque_constants.values / s["torque_constant"] - 1
    assert np.max(np.abs(err)) < 0.02
    assert np.all(r.torque_constants.std < 0.02 * r.torque_constants.values)
    out = tmp_path / "id.toml"
    r.save(out)
    assert np.allclose(md.load(str(out)).transmission.torque_constant, r.torque_constants.values)
    # no payload run, no model k_t: the scale from the prior's gravity (issue 45; it was refused). Measured on
    # seed 0: motors 1 to 5 within 1.75 % (each about one of its standard deviations), motor 6 not determined
    bare = md.identify(s["prior"], tmp_path / "run1.csv", band_folds=0, **OPTIONS).torque_constants
    assert bare.scale == "gravity" and list(bare.reference) == [2, 3]
    known = np.isfinite(bare.std)
    assert known.sum() >= 4
    assert np.all(np.abs(bare.values[known] / np.asarray(s["torque_constant"])[known] - 1) < 0.03)


def test_validate_reads_runs_toml_and_scores_a_payload_run_without_its_payload(tmp_path, capsys):
    """``validate --logs RUNS.toml``: a run's known payload is taken off the measured torque, so
    the arm's own model scores the noise on it; the same log without the declaration does not."""
    arm = md.load("ur5")
    (p1,), _ = _logs(tmp_path, arm, seeds=(9,), noise=(0.05,), payload_on=(0,))
    runs = tmp_path / "RUNS.toml"
    runs.write_text('[[log]]\npath = "run1.csv"\n'
                    "payload = { mass = 1.5, com = [0.03, -0.02, 0.06], inertia = [0.004, 0.005, 0.003, 0.0, 0.0, 0.0] }\n")
    assert main(["validate", "ur5", "--logs", str(runs), "--json"]) == 0
    declared = json.loads(capsys.readouterr().out)
    assert main(["validate", "ur5", str(p1), "--json"]) == 0
    plain = json.loads(capsys.readouterr().out)
    # 0.05 N m of white noise, trimmed edges and decimation aside: the RMS is the noise within 20 %;
    # the 1.5 kg load at up to 0.5 m from the shoulder is several N m
    assert max(declared["rms"]) < 0.06 and max(plain["rms"]) > 1.0
    assert any("payload" in note for note in declared["data_notes"])


def test_a_urdf_arm_with_rotor_inertias_round_trips_through_a_model_file(tmp_path):
    from manipdyn.formats.urdf.reader import load_urdf

    with pytest.raises(md.ModelError, match="motor_inertia: expected 6 finite numbers >= 0"):
        load_urdf(str(UR5), motor_inertia=[-1e-4] * 6)
    arm = load_urdf(str(UR5), motor_inertia=np.linspace(1e-4, 6e-4, 6))
    md.save(arm, tmp_path / "ur5.toml")
    back = md.load(str(tmp_path / "ur5.toml"))
    assert np.array_equal(back.armature, arm.armature) and np.any(back.armature)
    rng = np.random.default_rng(1)
    q, qd, qdd = (rng.standard_normal((20, 6)) for _ in range(3))
    assert np.allclose(back.inverse_dynamics(q, qd, qdd), arm.inverse_dynamics(q, qd, qdd), rtol=1e-12, atol=1e-12)


def test_the_library_names_its_keywords_and_the_command_line_its_flags(tmp_path):
    """One check of each option, before any log is read: the API's message names the keyword,
    the CLI's the flag (OptionError.cli_message)."""
    from manipdyn.identification.inputs.options import OptionError

    log = tmp_path / "never_read.csv"
    for kw, api, cli in (({"method": "wls", "mass_bound": 0.2}, "mass_bound: only with method consistent",
                          "--mass-bound: only with --method consistent"),
                         ({"prior_weight": 1e9}, "prior_weight: expected a number in [0, 1e+06]",
                          "--prior-weight: expected a number in [0, 1e+06]"),
                         ({"stribeck_velocity": 1.0}, "stribeck_velocity: only with friction_terms",
                          "--stribeck-velocity: only with --friction-terms"),
                         ({"friction_terms": "viscous,bogus"}, "friction_terms: unknown term(s) ['bogus']",
                          "--friction-terms: unknown term(s) ['bogus']")):
        with pytest.raises(OptionError) as info:
            md.identify("ur5", log, **kw)
        assert str(info.value).startswith(api) and info.value.cli_message().startswith(cli)
    with pytest.raises(md.ModelError, match="bootstrap: the number of replicates .* over the limit"):
        md.identify("ur5", log, bootstrap=10**6)


def test_identify_tells_its_stages_and_draws_the_bootstrap(tmp_path, capsys):
    """issue 31 item 15: ``manipdyn identify --progress`` names each long stage as it starts and draws
    a bar over the bootstrap's refits; ``--no-progress`` is silent; ``md.identify(progress=...)``
    is told the same stages, and a progress that is not callable is refused by name."""
    arm = md.load("ur5")
    (p1,), _ = _logs(tmp_path, arm, seeds=(1,), noise=(0.02,))
    args = ["identify", "ur5", str(p1), "--method", "wls", "--bootstrap", "3", "--band-folds", "2"]
    assert main(args + ["-o", str(tmp_path / "a.json"), "--progress"]) == 0
    err = capsys.readouterr().err
    for stage in ("identify: reading the logs", "identify: fit (wls)", "identify: prediction band (2 blocked",
                  "identify: bootstrap (3 refits)"):
        assert stage in err, err
    assert "3/3 refits" in err
    assert main(args + ["-o", str(tmp_path / "b.json"), "--no-progress"]) == 0
    assert "identify:" not in capsys.readouterr().err
    told = []
    md.identify(arm, [p1], method="wls", band_folds=0, progress=lambda stage, done=None, total=None: told.append(stage))
    assert told == ["reading the logs", "fit (wls)"]
    with pytest.raises(md.ModelError, match="progress"):
        md.identify(arm, [p1], method="wls", progress="yes")
