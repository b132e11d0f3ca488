"""Identification results a user can use: friction terms, plausibility bounds, base models,
provenance and ``manipdyn validate`` (issue: from a real robot's log to a model you can believe)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import manipdyn as md
from manipdyn._support.errors import ModelError

pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
from manipdyn.identification import Bounds, excitation, fit, write_measurements_csv  # noqa: E402
from manipdyn.identification.results.basemodel import load_base_model  # noqa: E402


@pytest.fixture(scope="module")
def ur5_motion():
    arm = md.load("ur5")
    ex = excitation(arm, duration=6.0, harmonics=3, rate=100.0, iterations=0)
    return arm, ex


def _noisy_log(tmp_path, ur5_motion, seed, noise=0.01):
    """The excitation's exact torques plus ``noise`` N m of seeded white noise, written as d.csv."""
    arm, ex = ur5_motion
    tau = arm.inverse_dynamics(ex.q, ex.qd, ex.qdd) + noise * np.random.default_rng(seed).standard_normal(ex.q.shape)
    data = tmp_path / "d.csv"
    write_measurements_csv(data, ex.t, ex.q, tau, qd=ex.qd, qdd=ex.qdd)
    return data


def _with_law(arm, law):
    return md.Manipulator(arm.links, convention=arm.convention, gravity=arm.gravity, name="truth",
                          friction=law)


def test_asymmetric_coulomb_viscous_and_offsets_are_recovered(ur5_motion):
    """1 % noise-level torques (0.01 N m) of a UR5 with asymmetric Coulomb friction, viscous friction
    and offsets: the consistent fit recovers every friction parameter within 2 % (each is seen on
    600 samples with about 0.01 N m noise, so its standard error is ~1e-3 of its size), and the written
    model predicts exactly what the fit predicted."""
    arm, ex = ur5_motion
    law = md.Friction(viscous=np.full(6, 0.3), coulomb_pos=np.full(6, 1.0), coulomb_neg=np.full(6, 0.7),
                      offset=np.linspace(-0.5, 0.5, 6), n=6)
    tau = _with_law(arm, law).inverse_dynamics(ex.q, ex.qd, ex.qdd)
    tau = tau + 0.01 * np.random.default_rng(0).standard_normal(tau.shape)
    r = fit(arm, ex.q, ex.qd, ex.qdd, tau, method="consistent", friction=("viscous", "asymmetric", "offset"))
    fm = r.arm.friction_model
    np.testing.assert_allclose(fm.viscous, law.viscous, rtol=0.02)
    np.testing.assert_allclose(fm.coulomb_pos, law.coulomb_pos, rtol=0.02)
    np.testing.assert_allclose(fm.coulomb_neg, law.coulomb_neg, rtol=0.02)
    np.testing.assert_allclose(fm.offset, law.offset, atol=0.02)
    pred = r.arm.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    np.testing.assert_allclose(pred, r.predict(ex.q, ex.qd, ex.qdd), atol=1e-9)
    # the model file carries the law: save, load, same torques
    text = md.to_toml(r.arm)
    from manipdyn.formats.modelfile import parse_model

    np.testing.assert_allclose(parse_model(text).inverse_dynamics(ex.q[:5], ex.qd[:5], ex.qdd[:5]),
                               pred[:5], atol=1e-9)


def test_plausible_bounds_hold_and_active_ones_are_reported(ur5_motion):
    """Data of a UR5 whose links are 2x heavier than the prior: the default bounds (+-50 % per link,
    +-25 % total) keep the answer plausible and say which bound is active."""
    arm, ex = ur5_motion
    heavy = md.Manipulator([type(l)(**{**_link_kwargs(l), "mass": 2 * l.mass}) for l in arm.links],
                           convention=arm.convention, gravity=arm.gravity, name="heavy")
    tau = heavy.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    r = fit(arm, ex.q, ex.qd, ex.qdd, tau, method="consistent")
    m = np.array([j.body.mass for j in r.arm.chain()[0]])
    prior_m = np.array([j.body.mass for j in arm.chain()[0]])
    assert m.sum() <= 1.25 * prior_m.sum() * (1 + 1e-6)
    assert np.all(m <= 1.5 * prior_m * (1 + 1e-6))
    assert any("total mass" in b for b in r.report["active_bounds"])
    free = fit(arm, ex.q, ex.qd, ex.qdd, tau, method="consistent", bounds=None)
    assert free.report["active_bounds"] == []
    assert np.array([j.body.mass for j in free.arm.chain()[0]]).sum() > 1.5 * prior_m.sum()


def _link_kwargs(l):
    return dict(joint=l.joint, a=l.a, alpha=l.alpha, d=l.d, theta=l.theta, mass=l.mass, com=l.com,
                inertia=l.inertia, qlim=l.qlim, name=l.name)


def test_bounds_validate_their_arrays():
    with pytest.raises(ModelError, match=r"Bounds.mass: expected shape"):
        Bounds(mass=[1.0, 2.0, 3.0])
    with pytest.raises(ModelError, match="lower bound exceeds"):
        Bounds(total_mass=(3.0, 1.0))
    with pytest.raises(ModelError, match="finite"):
        Bounds(total_mass=(1.0, float("inf")))


def test_zero_excitation_is_refused_naming_the_condition_number(ur5_motion):
    arm, ex = ur5_motion
    q = np.tile(ex.q[:1], (200, 1))
    z = np.zeros_like(q)
    tau = arm.inverse_dynamics(q, z, z)
    for method in ("ols", "consistent"):
        with pytest.raises(ModelError, match="condition number is .* over the .* threshold"):
            fit(arm, q, z, z, tau, method=method)


def test_cli_base_model_when_no_physical_arm_then_validate(tmp_path, capsys, ur5_motion):
    """ols on short noisy data: no physical arm, so identify writes the base model (exit 1) with
    sigma and %sigma; validate scores it and a model file, strict JSON, and draws the figure."""
    from manipdyn.cli import main

    arm, ex = ur5_motion
    rng = np.random.default_rng(5)
    tau = arm.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    tau = tau + 0.5 * rng.standard_normal(tau.shape)          # heavy noise: wrist parameters go negative
    data = tmp_path / "data.csv"
    write_measurements_csv(data, ex.t, ex.q, tau, qd=ex.qd, qdd=ex.qdd)
    out = tmp_path / "ols.toml"
    code = main(["identify", "ur5", str(data), "-o", str(out), "--method", "ols", "--json"])
    rep = json.loads(capsys.readouterr().out)
    assert code == 1 and not out.exists()
    base = tmp_path / "ols.base.json"
    assert rep["base_model"] == str(base) and base.exists()
    doc = json.loads(base.read_text())
    assert doc["why_no_model"] and doc["provenance"]["data_sha256"]
    assert all("std" in row and "rel_std_percent" in row for row in doc["base_parameters"]) is False  # ols: no sigma
    # wls carries sigma and %sigma
    assert main(["identify", "ur5", str(data), "-o", str(tmp_path / "w.json"), "--method", "wls"]) == 0
    capsys.readouterr()
    w = json.loads((tmp_path / "w.json").read_text())
    assert all(row["std"] > 0 and row["rel_std_percent"] > 0 for row in w["base_parameters"])
    bm = load_base_model(base)
    np.testing.assert_allclose(bm.inverse_dynamics(ex.q[:3], ex.qd[:3], ex.qdd[:3]),
                               np.einsum("nij,j->ni", arm.lagrange.regressor(ex.q[:3], ex.qd[:3], ex.qdd[:3]),
                                         bm.parameters), atol=1e-9)
    fig = tmp_path / "v.png"
    assert main(["validate", str(base), str(data), "--json", "--plot", str(fig)]) == 0
    v = json.loads(capsys.readouterr().out)
    assert len(v["rms"]) == 6 and all(0 <= x < 1 for x in v["relative_rms"]) and fig.stat().st_size > 1000
    # the prior itself, scored on the same data: its error is the noise, ~0.5 N m per joint
    assert main(["validate", "ur5", str(data), "--json"]) == 0
    v0 = json.loads(capsys.readouterr().out)
    assert all(0.4 < x < 0.6 for x in v0["rms"])


def test_identified_model_says_where_it_came_from(tmp_path, capsys, ur5_motion):
    from manipdyn.cli import main
    from manipdyn.identification.results.provenance import file_sha256

    data = _noisy_log(tmp_path, ur5_motion, 1)
    out = tmp_path / "ident.toml"
    assert main(["identify", "ur5", str(data), "-o", str(out), "--friction-terms", "viscous,coulomb,offset"]) == 0
    capsys.readouterr()
    ident = md.load(str(out))
    assert file_sha256(data) in ident.source and "consistent" in ident.source
    assert set(ident.sources) == {"data", "method", "options", "date", "prior", "residuals", "fitted_range",
                                  "prediction_band"}      # the last two: what validate reads (issue 24)
    text = out.read_text()
    assert "Universal Robots" not in text and "ROS description" not in text   # nothing of the prior's citation
    assert ident.friction_model is not None and ident.friction_model.offset is not None


def test_cli_friction_option_errors(tmp_path, capsys):
    from manipdyn.cli import main

    d = tmp_path / "d.csv"
    d.write_text("t,q1,q2,q3,q4,q5,q6,tau1,tau2,tau3,tau4,tau5,tau6\n")
    assert main(["identify", "ur5", str(d), "-o", str(tmp_path / "x.toml"), "--smoothing", "0.1"]) == 2
    assert "only with --friction-terms" in capsys.readouterr().err
    assert main(["identify", "ur5", str(d), "-o", str(tmp_path / "x.toml"), "--friction-terms", "stiction"]) == 2
    assert "unknown" in capsys.readouterr().err


def test_prior_weight_chosen_by_blocked_cross_validation():
    """When the prior is the truth and the data are noisy (5 % of each joint's peak torque), a pull
    towards the prior predicts unseen blocks better than the data alone: cross-validation inside
    the fit window must prefer a positive weight, and its table must say so."""
    from manipdyn.identification.estimation.selection import choose_prior_weight

    arm = md.load("ur5")
    ex = excitation(arm, duration=6.0, harmonics=3, rate=50.0, iterations=0)
    tau = arm.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    tau = tau + 0.05 * np.abs(tau).max(axis=0) * np.random.default_rng(0).standard_normal(tau.shape)
    w, table = choose_prior_weight(arm, ex.q, ex.qd, ex.qdd, tau, weights=(0.0, 1.0))
    scores = {row["prior_weight"]: row["score"] for row in table}
    assert w == 1.0 and scores[1.0] < scores[0.0]
    with pytest.raises(ModelError, match="folds"):
        choose_prior_weight(arm, ex.q, ex.qd, ex.qdd, tau, folds=1)


def test_validate_draws_calibrated_prediction_bands(tmp_path, capsys):
    """A wls base model carries its covariance; validate's 95 % band (parameter covariance plus
    the fitted noise level) holds about 95 % of fresh measurements: 600 samples per joint give a
    binomial standard error of 0.9 %, so 90 to 99 % is a band of over 5 of them."""
    from manipdyn.cli import main

    arm = md.load("ur5")
    ex = excitation(arm, duration=6.0, harmonics=3, rate=100.0, iterations=0, seed=3)
    tau = arm.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    sig = 0.01   # N m on every joint (1 % of a joint's peak would put the wrist below wls's noise floor,
    files = []   # 1e-6 of the largest joint's RMS torque, and widen its band on purpose)
    for seed in (1, 2):
        f = tmp_path / f"d{seed}.csv"
        noisy = tau + sig * np.random.default_rng(seed).standard_normal(tau.shape)
        write_measurements_csv(f, ex.t, ex.q, noisy, qd=ex.qd, qdd=ex.qdd)
        files.append(f)
    base = tmp_path / "w.json"
    assert main(["identify", "ur5", str(files[0]), "-o", str(base), "--method", "wls"]) == 0
    capsys.readouterr()
    fig = tmp_path / "bands.png"
    assert main(["validate", str(base), str(files[1]), "--json", "--plot", str(fig)]) == 0
    cov = json.loads(capsys.readouterr().out)["band_95_coverage"]
    assert len(cov) == 6 and all(0.90 <= c <= 0.99 for c in cov), cov


def test_cli_prior_weight_auto_and_bootstrap(tmp_path, capsys, ur5_motion):
    from manipdyn.cli import main

    arm, ex = ur5_motion
    tau = arm.inverse_dynamics(ex.q, ex.qd, ex.qdd) + 0.05 * np.random.default_rng(4).standard_normal(ex.q.shape)
    data = tmp_path / "d.csv"
    write_measurements_csv(data, ex.t, ex.q, tau, qd=ex.qd, qdd=ex.qdd)
    out = tmp_path / "auto.toml"
    assert main(["identify", "ur5", str(data), "-o", str(out), "--prior-weight", "auto", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    chosen = rep["prior_weight"]
    scores = {row["prior_weight"]: row["score"] for row in rep["prior_weight_selection"]}
    # issue 37: the best score, unless it beats the default (0, the data alone) by no more than the folds' spread
    from manipdyn.identification.estimation.selection import one_se_choice

    assert chosen in scores and chosen == one_se_choice(rep["prior_weight_selection"], "prior_weight", 0.0)[0][
        "prior_weight"]
    assert any(x.startswith(f"prior weight {chosen:.3g} chosen by 5-fold blocked hold-outs") for x in rep["fit_notes"])
    assert main(["identify", "ur5", str(data), "-o", str(tmp_path / "b.json"), "--method", "wls",
                 "--bootstrap", "4", "--json"]) == 0
    boot = json.loads(capsys.readouterr().out)["bootstrap"]
    assert boot["replicates"] == 4 and len(boot["std"]) == 36 and all(s > 0 for s in boot["std"])
    assert main(["identify", "ur5", str(data), "-o", str(out), "--scheduler", "local"]) == 2
    assert "only with --bootstrap" in capsys.readouterr().err
    assert main(["identify", "ur5", str(data), "-o", str(out), "--prior-weight", "lots"]) == 2
    assert "'auto'" in capsys.readouterr().err


def test_cli_refuses_meaningless_data(tmp_path, capsys, ur5_motion):
    """Issue 20, items 16 and 19: all-zero torques, q in degrees and an absurd --com-bound are
    usage errors (exit 2, one line), never a model or an internal error."""
    from manipdyn.cli import main

    arm, ex = ur5_motion
    tau = arm.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    zero, deg = tmp_path / "zero.csv", tmp_path / "deg.csv"
    write_measurements_csv(zero, ex.t, ex.q, 0 * tau, qd=ex.qd, qdd=ex.qdd)
    write_measurements_csv(deg, ex.t, np.degrees(ex.q), tau, qd=np.degrees(ex.qd), qdd=np.degrees(ex.qdd))
    out = tmp_path / "x.toml"
    cases = [([str(zero)], "every torque of every joint is 0"),
             ([str(deg)], "outside the model's joint limits"),
             ([str(zero), "--com-bound", "1e308"], "--com-bound: expected a number in")]
    for extra, msg in cases:
        assert main(["identify", "ur5", extra[0], "-o", str(out)] + extra[1:]) == 2, extra
        err = capsys.readouterr().err
        assert msg in err and len(err.strip().splitlines()) == 1
        assert not out.exists()
    assert main(["identify", "ur5", str(deg), "-o", str(out), "--deg"]) == 0


def test_validate_refuses_tip_with_a_base_model(tmp_path, capsys, ur5_motion):
    from manipdyn.cli import main

    data = _noisy_log(tmp_path, ur5_motion, 2)
    base = tmp_path / "w.json"
    assert main(["identify", "ur5", str(data), "-o", str(base), "--method", "wls"]) == 0
    capsys.readouterr()
    assert main(["validate", str(base), str(data), "--tip", "foo"]) == 2
    assert "--tip: a base model" in capsys.readouterr().err


def test_identify_json_lists_each_body_beside_the_prior(tmp_path):
    """``links`` in ``identify --json``: each link's mass, COM and principal moments, fitted and
    prior: exact for the prior's own parameters (the bodies of ``arm.chain()``, to rounding), None
    where a body has no mass, and present in a real identification's report."""
    import warnings

    from manipdyn.identification.results.result import link_table
    from manipdyn.model.parameters import arm_parameters

    arm = md.load("ur5")
    table = link_table(arm_parameters(arm), arm)
    assert [b["link"] for b in table] == [1, 2, 3, 4, 5, 6]
    for b, j in zip(table, arm.chain()[0]):
        assert b["mass"] == pytest.approx(j.body.mass, rel=1e-12) and b["mass"] == b["prior_mass"]
        np.testing.assert_allclose(b["com"], j.body.com, atol=1e-12)
        np.testing.assert_allclose(b["principal_moments"], np.linalg.eigvalsh(j.body.inertia), atol=1e-12)
    pi = arm_parameters(arm).copy()
    pi[10:20] = 0.0                       # a massless link 2: no COM, no moments
    assert link_table(pi, arm)[1]["com"] is None and link_table(pi, arm)[1]["principal_moments"] is None
    ex = excitation(arm, duration=6.0, harmonics=3, rate=100.0, iterations=0, seed=4)
    write_measurements_csv(tmp_path / "log.csv", ex.t, ex.q, arm.inverse_dynamics(ex.q, ex.qd, ex.qdd),
                           qd=ex.qd, qdd=ex.qdd)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = md.identify(arm, str(tmp_path / "log.csv"), band_folds=0)
    rep = r.report()
    assert len(rep["links"]) == 6 and rep["links"][2]["prior_mass"] == pytest.approx(arm.chain()[0][2].body.mass)
