"""Issue 31 (as a newcomer meets it, round four): items 6, 9, 11, 13, 16 and 18.

Each test is named after its item.  Item 17 (inverse kinematics, Jacobian frames and links,
tool wrenches, potential energy) has its own file, tests/test_reach.py.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main
from manipdyn.check.crosscheck import QUANTITIES


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.ModelNoteWarning)
        return md.load(name)


def _with_law(arm, law):
    """``arm`` (a Manipulator) with the friction law ``law`` and no friction of its links."""
    links = [dataclasses.replace(l, friction_viscous=0.0, friction_coulomb=0.0) for l in arm.links]
    return md.Manipulator(links, convention=arm.convention, gravity=arm.gravity, name=arm.name,
                          transmission=arm.transmission, friction=law)


# -- item 6: regressor(friction=True) @ parameters(friction=True) is the arm's own inverse dynamics ----------
def _states(arm, k=5, seed=11):
    rng = np.random.default_rng(seed)
    return arm.random_state(rng, k), rng.uniform(-1.5, 1.5, (k, arm.n)), rng.uniform(-3, 3, (k, arm.n))


def test_item6_friction_true_on_a_sigmoid_law_is_refused_by_name():
    arm = _load("panda")                                       # the bundled panda: a sigmoid law
    assert arm.friction_model is not None and "sigmoid" in arm.friction_model.terms
    with pytest.raises(md.ModelError, match=r"^friction: panda's friction law has sigmoid term.*"
                                            r"friction=arm\.friction_model"):
        arm.parameters(friction=True)
    q, qd, qdd = _states(arm)
    law = arm.friction_model                                   # its own columns: the identity holds
    for engine in ("pinocchio", "lagrange"):
        Y = arm.engine(engine).regressor(q, qd, qdd, friction=law)
        # 1e-10 N m on torques of tens of N m: float64 round-off
        np.testing.assert_allclose(Y @ arm.parameters(friction=law), arm.inverse_dynamics(q, qd, qdd), atol=1e-10)


@pytest.mark.parametrize("law", [
    dict(viscous=[0.3] * 6, coulomb=[0.5] * 6, smoothing=0.0),           # what True's columns hold
    dict(viscous=[0.3] * 6, offset=[0.1] * 6, smoothing=0.0),
    dict(viscous=[0.2] * 6, coulomb=[0.4] * 6, stribeck_level=[0.3] * 6, stribeck_velocity=[0.1] * 6,
         smoothing=0.0),
    dict(coulomb=[0.5] * 6, smoothing=0.02),
    dict(viscous=[0.3] * 6, coulomb=[0.5] * 6, smoothing=0.0, side="motor"),
])
def test_item6_friction_true_holds_or_is_refused_for_any_law(law):
    base = _load("ur5")
    gear = md.Transmission(np.diag([50.0, 50, 50, 30, 30, 30]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.ModelNoteWarning)
        arm = md.Manipulator([dataclasses.replace(l, gear_ratio=g) for l, g in zip(base.links, np.diag(gear.R))],
                             convention=base.convention, name="ur5", transmission=gear, friction=md.Friction(**law))
    q, qd, qdd = _states(arm)
    tau = arm.inverse_dynamics(q, qd, qdd)
    try:
        p = arm.parameters(friction=True)
    except md.ModelError as exc:                    # refused: by name, and never for what True's columns hold
        assert str(exc).startswith(("friction:", "ur5:")) and "friction=arm.friction_model" in str(exc)
        assert set(law) - {"smoothing"} != {"viscous", "coulomb"} or law.get("side") == "motor" or law["smoothing"]
    else:                                           # accepted: then the identity holds on both engines
        for engine in ("pinocchio", "lagrange"):
            Y = arm.engine(engine).regressor(q, qd, qdd, friction=True)
            np.testing.assert_allclose(Y @ p, tau, atol=1e-10)
    for engine in ("pinocchio", "lagrange"):        # the law's own columns always hold it
        Y = arm.engine(engine).regressor(q, qd, qdd, friction=arm.friction_model)
        np.testing.assert_allclose(Y @ arm.parameters(friction=arm.friction_model), tau, atol=1e-10)


# -- item 13: check's timing table has every engine compared; --help lists every quantity --------------------
def test_item13_check_times_every_engine_and_lists_every_quantity(capsys):
    with pytest.raises(SystemExit):
        main(["check", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for key, what in QUANTITIES.items():
        assert f"{key}: {' '.join(what.split())}" in text
    assert f"the {len(QUANTITIES)} quantities" in text
    pytest.importorskip("casadi", reason="the C engine's first build needs CasADi (the codegen extra)")
    code = main(["check", "ur5", "--samples", "5", "--engines", "lagrange,pinocchio,c", "--timing-calls", "5",
                 "--no-progress"])
    out = capsys.readouterr().out
    assert code == 0
    header = next(l for l in out.splitlines() if "per call (median, us)" in l)
    assert header.split()[-3:] == ["lagrange", "pinocchio", "c"]
    for label in ("inverse dynamics", "mass matrix", "forward dynamics"):
        row = next(l for l in out.splitlines() if l.strip().startswith(label))
        values = [float(x) for x in row.split()[-3:]]
        assert all(v > 0 for v in values)            # each engine measured, the C one too


# -- item 11: montecarlo, excite and codegen show the model's notes, as check and track do -------------------
def test_item11_every_command_shows_the_model_notes(tmp_path, capsys):
    notes = md.load_with_notes("stanford")[1]
    assert notes                                             # link 5 breaks the triangle inequality
    code = main(["montecarlo", "stanford", "--runs", "2", "--duration", "0.2", "--scheduler", "sync",
                 "--controllers", "pd", "--no-progress"])
    out = capsys.readouterr().out
    assert code == 0 and all(f"note: {n}" in out for n in notes)
    main(["montecarlo", "stanford", "--runs", "2", "--duration", "0.2", "--scheduler", "sync",
          "--controllers", "pd", "--no-progress", "--json"])
    import json
    assert json.loads(capsys.readouterr().out)["notes"] == list(notes)
    for args in (["excite", "stanford", "-o", str(tmp_path / "x.csv"), "--duration", "2", "--harmonics", "2",
                  "--iterations", "2", "--no-progress"],):
        assert main(args) == 0
        out = capsys.readouterr().out
        assert all(f"note: {n}" in out for n in notes)
        assert main(args[:3] + [str(tmp_path / "y.csv")] + args[4:] + ["--json"]) == 0
        assert json.loads(capsys.readouterr().out)["notes"] == list(notes)
    pytest.importorskip("casadi", reason="codegen needs CasADi (the codegen extra)")
    assert main(["codegen", "stanford", "-o", str(tmp_path / "gen")]) == 0
    out = capsys.readouterr().out
    assert all(f"note: {n}" in out for n in notes)


# -- item 18: track with the user's own reference path (t, q1..qn) ----------------------------------------------
def _write_path(path, arm, t, q, header=None, comment=False):
    header = header or ["t"] + [f"q{j}" for j in range(1, arm.n + 1)]
    rows = [",".join(header)] + [",".join(repr(float(x)) for x in (ti, *qi)) for ti, qi in zip(t, q)]
    if comment:                                              # a comment and a blank line: rows stay the file's
        rows.insert(1, "# recorded by hand")
        rows.insert(2, "")
    path.write_text("\n".join(rows) + "\n")
    return path


def _sine_path(arm, t):
    mid = arm.qlim.mean(axis=1)
    return mid + 0.2 * np.sin(np.outer(t, 1.0 + 0.3 * np.arange(arm.n)))


def test_item18_track_follows_the_users_path(tmp_path, capsys):
    from manipdyn.control.track import track
    arm = _load("ur5")
    t = np.linspace(0.0, 2.0, 81) + 10.0                     # the file's clock starts at 10 s
    q = _sine_path(arm, t - 10.0)
    f = _write_path(tmp_path / "path.csv", arm, t, q)
    r = track(arm, ("ct",), trajectory=str(f))
    assert r.duration == pytest.approx(2.0) and "path.csv (81 samples of q)" in r.reference
    log = r.logs["computed torque"]
    # the reference is the file's path: at its sample times the logged reference is the file's q
    k = np.searchsorted(log.t, 1.0)
    np.testing.assert_allclose(log.q_d[k], q[40], atol=1e-12)
    assert np.max(np.abs(log.q - log.q_d)) < 0.05           # computed torque at 10 rad/s follows it
    code = main(["track", "ur5", "--trajectory", str(f), "--no-progress", "--json"])
    import json
    doc = json.loads(capsys.readouterr().out)
    assert code == 0 and doc["duration"] == pytest.approx(2.0) and "path.csv" in doc["path"]
    assert main(["track", "ur5", "--trajectory", str(f), "--no-progress", "--plot", str(f)]) == 2  # not onto it
    assert "--plot" in capsys.readouterr().err


@pytest.mark.parametrize("case, message", [
    ("outside", r"row 6, column 3 \('q2'\): 9 rad is outside joint 2's limits"),
    ("missing", r"expected the header t,q1,.*,qdd6 or t,q1,q2,q3,q4,q5,q6 .*got 't,q1,q2,q3,q4,q5'"),
    ("unknown", r"expected the header t,q1,.*,qdd6 or t,q1,q2,q3,q4,q5,q6 .*got 't,q1,q2,q3,q4,q5,q6,tau1'"),
    ("backwards", r"column 't' must increase strictly \(row 6\)"),
    ("one", r"expected at least 2 rows of samples, got 1"),
])
def test_item18_a_bad_path_is_refused_naming_row_and_column(tmp_path, capsys, case, message):
    from manipdyn.control.reference import read_path
    arm = _load("ur5")
    t = np.arange(6) * 0.05
    q = _sine_path(arm, t)
    names = ["t"] + [f"q{j}" for j in range(1, 7)]
    if case == "outside":
        q[2, 1] = 9.0
        f = _write_path(tmp_path / "p.csv", arm, t, q, comment=True)     # data row 3 is line 6
    elif case == "missing":
        f = _write_path(tmp_path / "p.csv", arm, t, q[:, :5], header=names[:6])
    elif case == "unknown":
        f = _write_path(tmp_path / "p.csv", arm, t, np.c_[q, q[:, 0]], header=names + ["tau1"])
    elif case == "backwards":
        t[2], t[1] = t[1], t[2]
        f = _write_path(tmp_path / "p.csv", arm, t, q, comment=True)
    else:
        f = _write_path(tmp_path / "p.csv", arm, t[:1], q[:1])
    with pytest.raises(md.ModelError, match=message):
        read_path(f, arm)
    assert main(["track", "ur5", "--trajectory", str(f), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "p.csv" in err


def test_item18_velocities_and_accelerations_are_matched(tmp_path):
    from manipdyn.control.reference import read_path
    arm = _load("ur5")
    t = np.linspace(0, 1, 11)
    w = 1.0 + 0.3 * np.arange(6)
    q = _sine_path(arm, t)
    qd = 0.2 * w * np.cos(np.outer(t, w))
    qdd = -0.2 * w**2 * np.sin(np.outer(t, w))
    f = tmp_path / "p.csv"                                   # as excite writes it
    from manipdyn.formats.logs.data import write_trajectory_csv
    write_trajectory_csv(f, t, q, qd, qdd)
    ref = read_path(f, arm)
    assert ref.columns == "q, qd, qdd"
    for k in (3, 7):                                         # inside: the ends hold still (Sampled)
        a, b, c = ref(t[k])
        np.testing.assert_allclose(a, q[k], atol=1e-12)
        np.testing.assert_allclose(b, qd[k], atol=1e-12)
        np.testing.assert_allclose(c, qdd[k], atol=1e-12)


# -- item 16: synthesize --perturb --truth FILE writes the arm it drew -----------------------------------------
def test_item16_synthesize_writes_the_true_arm(tmp_path, capsys):
    from manipdyn.formats.logs.trajectory import read_trajectory
    traj, log, truth = tmp_path / "traj.csv", tmp_path / "log.csv", tmp_path / "truth.toml"
    assert main(["excite", "ur5", "-o", str(traj), "--duration", "2", "--harmonics", "2", "--iterations", "2",
                 "--no-progress"]) == 0
    assert main(["synthesize", "ur5", str(traj), "-o", str(log), "--perturb", "--seed", "4", "--noise", "0",
                 "--truth", str(truth)]) == 0
    assert f"the true arm written to {truth}" in capsys.readouterr().out
    arm = md.load(str(truth))
    prior = _load("ur5")
    assert arm.name == "ur5_true" and "--seed 4" in arm.description
    T = read_trajectory(traj, 6)
    table = np.loadtxt(log, delimiter=",", skiprows=1)
    # noise 0: the log is the true arm's inverse dynamics (written with repr precision: 1e-9 N m)
    np.testing.assert_allclose(table[:, 7:13], arm.inverse_dynamics(T.q, T.qd, T.qdd), atol=1e-9)
    assert np.abs(table[:, 7:13] - prior.inverse_dynamics(T.q, T.qd, T.qdd)).max() > 0.1   # not the prior
    # the same seed draws the same arm: a second run writes the same file
    again = tmp_path / "again.toml"
    assert main(["synthesize", "ur5", str(traj), "-o", str(tmp_path / "log2.csv"), "--perturb", "--seed", "4",
                 "--truth", str(again)]) == 0
    np.testing.assert_array_equal(md.load(str(again)).inverse_dynamics(T.q, T.qd, T.qdd),
                                  arm.inverse_dynamics(T.q, T.qd, T.qdd))
    same = str(tmp_path / "same.toml")
    for model, out, args, word in (("ur5", log, ["--truth", str(tmp_path / "t.toml")], "--perturb"),
                                   ("ur5", log, ["--perturb", "--truth", str(tmp_path / "t.json")], ".toml"),
                                   ("ur5", same, ["--perturb", "--truth", same], "the same file as -o"),
                                   (str(truth), log, ["--perturb", "--truth", str(truth)], "would overwrite MODEL")):
        capsys.readouterr()
        assert main(["synthesize", model, str(traj), "-o", str(out), *args]) == 2
        err = capsys.readouterr().err
        assert "--truth" in err and word in err and len(err.strip().splitlines()) == 1


# -- item 9: Monte-Carlo counts runaway runs as diverged, and says what its draws do to the arm ---------------
def test_item9_runaway_runs_count_as_diverged_and_the_draws_are_explained():
    from manipdyn.control import montecarlo as mc
    from manipdyn.control.controllers import pd_gains
    from manipdyn.control.montecarlo.diverged import RUNAWAY_TORQUE
    arm = _load("ur5")
    # runs 0 and 4 of seed 1 are the LQR runaways (a run's plant depends on its index only),
    # drawn from the absolute distributions that were the defaults then (issue 46 sized them to the arm)
    study = mc.study(arm, 5, seed=1, controllers=("lqr",), distributions=mc.ABSOLUTE_DEFAULTS)
    report = mc.run(study, scheduler="sync")
    span = np.diff(arm.qlim, axis=1)[:, 0]
    scale = study.torque_scale()
    recs = report.per_run
    away = [r for r in recs if r["cause"] == "runaway"]
    assert {0, 4} <= {r["run"] for r in away}
    for r in recs:                  # the criterion, read off the records: error past the range, or torque x100
        beyond = r["max_error"] > span.min() or r["peak_torque"] > RUNAWAY_TORQUE * scale
        if r["cause"] == "runaway":
            assert r["diverged"] and beyond
        if not r["diverged"]:
            assert r["max_error"] <= span.max() and r["peak_torque"] <= RUNAWAY_TORQUE * scale
    assert report.controllers["lqr"]["diverged"] == len([r for r in recs if r["diverged"]]) >= 2
    text = str(report)
    assert f"diverged {report.controllers['lqr']['diverged']} (runaway {len(away)})" in text
    # what the draws do: 0.5 N m of Coulomb friction against the wrist's Kp = wn^2 D_66
    kp, _ = pd_gains(arm, study.bandwidth)
    effect = report.to_dict()["distribution_effect"]
    assert effect["coulomb_offset"] == (pytest.approx(0.5 / kp.min()), int(np.argmin(kp)) + 1)
    assert effect["coulomb_offset"][0] > 10                  # tens of rad: not an arm's scale, and said so
    assert f"holds joint {int(np.argmin(kp)) + 1} up to {0.5 / kp.min():.3g} rad off" in text
    quiet = mc.Distributions(friction_viscous=0.0, friction_coulomb=0.0, torque_noise=0.0)
    assert mc.run(mc.study(arm, 1, controllers=("ct",), distributions=quiet), scheduler="sync").effect()["text"] == ""


# -- item 14: excitation trajectories start and end at rest, limits kept -----------------------------------------
def test_item14_excitation_ramps_from_rest_and_keeps_its_limits(tmp_path, capsys):
    pytest.importorskip("scipy", reason="excitation needs the identify extra (scipy)")
    from manipdyn.identification import excitation
    from manipdyn.identification.experiments.trajectory import fourier_trajectory
    arm = _load("ur5")
    vmax, amax = 0.8, 2.0
    lo, hi = arm.qlim[:, 0], arm.qlim[:, 1]
    for ramp in ("auto", 0.5):                   # 0.5 s is too short for these limits: the joints are scaled
        ex = excitation(arm, duration=4.0, harmonics=3, rate=50.0, iterations=0, seed=2, vmax=vmax, amax=amax,
                        ramp=ramp)
        assert ex.ramp > 0 and ex.duration == pytest.approx(ex.period + 2 * ex.ramp)
        assert ex.t[-1] == pytest.approx(ex.duration)
        for k in (0, -1):                        # at rest at q0, both ends
            np.testing.assert_allclose(ex.q[k], ex.q0, atol=1e-12)
            assert not np.any(ex.qd[k]) and not np.any(ex.qdd[k])
        t = np.linspace(0.0, ex.duration, 400001)
        q, qd, qdd = ex.sample(t)
        # the limits at every time (a grid 200x finer than the samples), with the 5 % margin
        span = hi - lo
        assert np.all(q >= lo + 0.05 * span - 1e-12) and np.all(q <= hi - 0.05 * span + 1e-12)
        assert np.abs(qd).max() <= vmax and np.abs(qdd).max() <= amax
        # cross-check of the derivatives: central differences of the positions (h = 1e-5 s:
        # truncation ~h^2 q''' ~ 1e-9, round-off 1e-16 / h ~ 1e-11)
        h = 1e-5
        tt = np.linspace(0.01, ex.duration - 0.01, 997)
        qp, _, _ = ex.sample(tt + h)
        qm, _, _ = ex.sample(tt - h)
        q0_, qd0, qdd0 = ex.sample(tt)
        np.testing.assert_allclose(qd0, (qp - qm) / (2 * h), atol=1e-7)
        np.testing.assert_allclose(qdd0, (qp - 2 * q0_ + qm) / h**2, atol=1e-4)
        # between the ramps it is the series itself
        mid = (ex.t >= ex.ramp) & (ex.t <= ex.ramp + ex.period)
        np.testing.assert_allclose(ex.q[mid], fourier_trajectory(ex.t[mid], ex.q0, ex.a, ex.b, ex.period)[0],
                                   atol=1e-12)
    bare = excitation(arm, duration=4.0, harmonics=3, rate=50.0, iterations=0, seed=2, vmax=vmax, amax=amax, ramp=0)
    assert bare.ramp == 0 and len(bare.t) == 200 and np.abs(bare.qd[0]).max() > 0.1   # the old series, moving
    short = excitation(arm, duration=4.0, harmonics=3, rate=50.0, iterations=0, seed=2, vmax=vmax, amax=amax,
                       ramp=0.5)
    assert np.abs(short.a).max() < np.abs(bare.a).max()           # scaled down to keep the limits
    # the command line: on by default, --ramp 0 for the bare series, a bad value refused in one line
    out = tmp_path / "traj.csv"
    assert main(["excite", "ur5", "-o", str(out), "--duration", "4", "--harmonics", "3", "--rate", "50",
                 "--iterations", "0", "--seed", "2", "--json", "--no-progress"]) == 0
    doc = __import__("json").loads(capsys.readouterr().out)
    assert doc["ramp"] > 0 and doc["duration"] == pytest.approx(4.0 + 2 * doc["ramp"]) and doc["period"] == 4.0
    rows = np.loadtxt(out, delimiter=",", skiprows=1)
    assert not np.any(rows[[0, -1], 7:])                          # qd and qdd zero in the first and last rows
    for bad in ("-1", "soon", "nan"):
        assert main(["excite", "ur5", "-o", str(out), "--ramp", bad, "--iterations", "0"]) == 2
        err = capsys.readouterr().err
        assert "--ramp" in err and len(err.strip().splitlines()) == 1
    with pytest.raises(md.ModelError, match="^ramp:"):
        excitation(arm, iterations=0, ramp="later")


# -- item 10: the API's log options are checked by name; the CLI's 'T0:T1' works in the API too -----------------
def _synthetic_log(tmp_path):
    from manipdyn.formats.logs.data import write_measurements_csv
    arm = _load("ur5")
    t = np.arange(400) / 100.0
    q = arm.qlim.mean(axis=1) + 0.3 * np.sin(np.outer(t, 0.5 + 0.2 * np.arange(6)))
    qd = 0.3 * (0.5 + 0.2 * np.arange(6)) * np.cos(np.outer(t, 0.5 + 0.2 * np.arange(6)))
    qdd = -0.3 * (0.5 + 0.2 * np.arange(6)) ** 2 * np.sin(np.outer(t, 0.5 + 0.2 * np.arange(6)))
    path = tmp_path / "log.csv"
    write_measurements_csv(path, t, q, arm.inverse_dynamics(q, qd, qdd))
    return path


@pytest.mark.parametrize("kw, name", [
    (dict(t_range=(10,)), "t_range"), (dict(t_range=(0, "a")), "t_range"), (dict(t_range=5), "t_range"),
    (dict(t_range=(0, float("nan"))), "t_range"), (dict(t_range="10"), "t_range"), (dict(t_range="3:1"), "t_range"),
    (dict(t_range=(True, 2)), "t_range"), (dict(resample="200"), "resample"), (dict(rate="100"), "rate"),
    (dict(cutoff="5"), "cutoff"), (dict(resample=-1.0), "resample"),
])
def test_item10_api_log_options_are_refused_by_name(tmp_path, kw, name):
    pytest.importorskip("scipy", reason="identification needs the identify extra")
    log = _synthetic_log(tmp_path)
    for call in (lambda: md.identify("ur5", str(log), method="ols", **kw),
                 lambda: md.validate("ur5", str(log), **kw)):
        with pytest.raises(md.ModelError, match=f"^{name}: expected"):
            call()


def test_item10_the_clis_t_range_text_is_the_apis_too(tmp_path, capsys):
    pytest.importorskip("scipy", reason="identification needs the identify extra")
    log = _synthetic_log(tmp_path)
    a = md.identify("ur5", str(log), method="ols", t_range="0.5:3")
    b = md.identify("ur5", str(log), method="ols", t_range=(0.5, 3.0))
    c = md.identify("ur5", str(log), method="ols", t_range=":3")
    np.testing.assert_array_equal(a.fit.beta, b.fit.beta)
    assert not np.array_equal(a.fit.beta, c.fit.beta)              # the window was applied
    assert main(["identify", "ur5", str(log), "-o", str(tmp_path / "x.toml"), "--method", "ols", "--t-range", "0.5"]) == 2
    err = capsys.readouterr().err
    assert "--t-range: expected" in err and len(err.strip().splitlines()) == 1


# -- item 12: a fit that is no physical arm: the API's save and the CLI do the same thing ---------------------
def test_item12_no_physical_arm_is_one_behaviour(tmp_path, capsys):
    pytest.importorskip("scipy", reason="identification needs the identify extra")
    import json
    from manipdyn.formats.logs.data import write_measurements_csv
    from manipdyn.identification import excitation
    arm = _load("ur5")
    ex = excitation(arm, duration=6.0, harmonics=3, rate=100.0, iterations=0, ramp=0)
    tau = arm.inverse_dynamics(ex.q, ex.qd, ex.qdd) + 0.5 * np.random.default_rng(5).standard_normal(ex.q.shape)
    data = tmp_path / "data.csv"                               # heavy noise: ols sends wrist inertias negative
    write_measurements_csv(data, ex.t, ex.q, tau, qd=ex.qd, qdd=ex.qdd)
    # the command line: X.base.json beside X.toml, exit 1
    assert main(["identify", "ur5", str(data), "-o", str(tmp_path / "cli.toml"), "--method", "ols"]) == 1
    capsys.readouterr()
    assert not (tmp_path / "cli.toml").exists() and (tmp_path / "cli.base.json").exists()
    # the API: the same file beside it, and the failure raised (as the CLI's exit 1)
    r = md.identify("ur5", str(data), method="ols")
    assert r.arm is None
    with pytest.raises(md.ModelError, match=r"api\.toml: the ols parameters are not a physical arm .* the base "
                                            r"model is written to .*api\.base\.json instead"):
        r.save(tmp_path / "api.toml")
    assert not (tmp_path / "api.toml").exists()
    cli = json.loads((tmp_path / "cli.base.json").read_text())
    api = json.loads((tmp_path / "api.base.json").read_text())
    assert [p["value"] for p in api["base_parameters"]] == [p["value"] for p in cli["base_parameters"]]
    assert api["why_no_model"] == cli["why_no_model"]
    # identify(output=...) in Python: the CLI's path exactly (the base model, exit_code 1)
    r2 = md.identify("ur5", str(data), method="ols", output=str(tmp_path / "out.toml"))
    assert r2.exit_code == 1 and r2.base_model == str(tmp_path / "out.base.json")
    with pytest.raises(md.ModelError, match="^path: expected a file name ending in .toml, .urdf or .json"):
        r.save(tmp_path / "api.yaml")
