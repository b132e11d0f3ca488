"""Friction through rest (issue 45, item 1): a joint at rest holds any torque within its static band.

A synthetic UR5 whose friction has a static level 1.5 times its Coulomb level and a Stribeck decay
between them, and which at rest holds a static friction of the sign of its last motion (a fraction of
``Fs`` drawn per rest), is fitted on Fourier excitations and scored on a point-to-point run with rests
(quintic moves between postures, one second held at each).  On today's main the identified model
predicted ``Fc sign(noise)`` at rest, its band held 64 % of the point-to-point run pooled (unflagged
samples 72 %) with the truth's friction terms, and 62 % with viscous and Coulomb only.
"""

from __future__ import annotations

import numpy as np
import pytest

import manipdyn as md
from manipdyn._support.errors import ModelError
from manipdyn.model.friction import Friction, FrictionTerms
from manipdyn.model.friction_rest import (StaticFriction, at_rest_velocity, held_static_torque, last_motion_sign,
                                          rest_mask)

pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
from manipdyn.identification import excitation, identify, read_log, write_measurements_csv  # noqa: E402
from manipdyn.identification.results.provenance import carried_trust  # noqa: E402
from manipdyn.identification.results.validation import validate  # noqa: E402

#: torque noise per joint, N m (as tests/test_bands.py's synthetic UR5)
SIGMA = np.array([0.06, 0.5, 0.15, 0.02, 0.004, 0.001])
#: the truth's Coulomb levels, N m; static 1.5x, reached through a Stribeck decay at 0.05 rad/s
FC = np.array([1.5, 2.0, 1.2, 0.5, 0.3, 0.2])
FS = 1.5 * FC
#: the measured velocity's noise, rad/s (an encoder's differentiated signal)
QD_NOISE = 2e-3


def _truth():
    prior = md.load("ur5")
    law = Friction(viscous=0.5 * FC, coulomb=FC, stribeck_level=FS - FC, stribeck_velocity=np.full(6, 0.05),
                   smoothing=1e-3)
    return md.Manipulator(prior.links, convention=prior.convention, gravity=prior.gravity, friction=law)


def _coloured(rng, shape, phi=0.5):
    w = rng.standard_normal(shape)
    e = np.empty_like(w)
    e[0] = w[0]
    for k in range(1, len(w)):
        e[k] = phi * e[k - 1] + np.sqrt(1 - phi**2) * w[k]
    return e


def point_to_point(arm, seed, postures=8, rate=100.0, move=2.0, hold=1.0):
    """``t, q, qd, qdd``: quintic moves between seeded postures (within half the joint limits, |q| <= 2
    rad), each held ``hold`` s at exactly zero velocity."""
    rng = np.random.default_rng(seed)
    lim = np.asarray(arm.qlim, dtype=np.float64)
    lo, hi = np.maximum(0.5 * lim[:, 0], -2.0), np.minimum(0.5 * lim[:, 1], 2.0)
    qs = [rng.uniform(lo, hi) for _ in range(postures)]
    s = np.arange(int(round(move * rate))) / (move * rate)
    p, dp, ddp = (10 * s**3 - 15 * s**4 + 6 * s**5, (30 * s**2 - 60 * s**3 + 30 * s**4) / move,
                  (60 * s - 180 * s**2 + 120 * s**3) / move**2)
    parts = []
    for a, b in zip(qs[:-1], qs[1:]):
        parts.append((a + p[:, None] * (b - a), dp[:, None] * (b - a), ddp[:, None] * (b - a)))
        k = int(hold * rate)
        parts.append((np.repeat(b[None], k, axis=0), np.zeros((k, 6)), np.zeros((k, 6))))
    q, qd, qdd = (np.concatenate([x[i] for x in parts]) for i in range(3))
    return np.arange(len(q)) / rate, q, qd, qdd


def _torques(truth, q, qd, qdd, seed):
    """The truth's torques: its law while moving, at rest a held fraction (one draw in [0.5, 1] per rest) of
    ``Fs`` with the sign of the last motion; plus coloured noise."""
    rng = np.random.default_rng(1000 + seed)
    rest = qd == 0.0
    hold = np.ones_like(qd)
    for j in range(6):
        starts = np.flatnonzero(np.diff(np.concatenate([[0], rest[:, j].astype(int)])) == 1)
        for a in starts:
            b = a + int(np.argmax(~rest[a:, j])) if np.any(~rest[a:, j]) else len(qd)
            hold[a:b, j] = rng.uniform(0.5, 1.0)
    tau = truth.inverse_dynamics(q, qd, qdd) + held_static_torque(qd, np.zeros(6), FS, hold)
    return tau + SIGMA * _coloured(rng, q.shape)


def _write(path, truth, t, q, qd, qdd, seed):
    tau = _torques(truth, q, qd, qdd, seed)
    noisy = qd + QD_NOISE * np.random.default_rng(2000 + seed).standard_normal(qd.shape)
    write_measurements_csv(path, t, q, tau, qd=noisy)      # qd measured with noise, filtered on reading


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("rest")
    truth = _truth()
    out = {}
    for s in (1, 2):
        ex = excitation(md.load("ur5"), duration=20.0, harmonics=3, rate=100.0, iterations=0, seed=s, ramp=0)
        out[f"fourier{s}"] = d / f"fourier{s}.csv"
        _write(out[f"fourier{s}"], truth, ex.t, ex.q, ex.qd, ex.qdd, s)
    for s in (11, 12):
        out[f"ptp{s}"] = d / f"ptp{s}.csv"
        _write(out[f"ptp{s}"], truth, *point_to_point(truth, s), s)
    out["dir"] = d
    return out


# -- the law at rest ------------------------------------------------------------------------------------------
def test_rest_mask_and_the_still_velocity():
    qd = np.array([[0.001, 0.0], [0.5, 0.0], [0.002, -0.3], [0.0, 0.001], [-0.4, 0.0]])
    rest = rest_mask(qd, [0.01, 0.01])
    assert rest.tolist() == [[True, True], [False, True], [True, False], [True, True], [False, True]]
    assert np.array_equal(at_rest_velocity(qd, 0.01), np.where(rest, 0.0, qd))
    # the sign of the last motion: 0 before any, the current one while moving, kept through a rest
    assert last_motion_sign(qd, 0.01).tolist() == [[0, 0], [1, 0], [1, -1], [1, -1], [-1, -1]]
    held = held_static_torque(qd, [0.01, 0.01], [2.0, 3.0], 0.5)
    assert held.tolist() == [[0, 0], [0, 0], [1.0, 0], [1.0, -1.5], [0, -1.5]]
    with pytest.raises(ModelError, match="rest threshold"):
        rest_mask(qd, [-1.0, 0.0])
    with pytest.raises(ModelError, match="hold"):
        held_static_torque(qd, 0.01, [1.0, 1.0], 1.5)


def test_the_static_record_widens_flags_and_round_trips():
    s = StaticFriction(threshold=[0.01, 0.01], level=[1.0, 2.0], measured=np.array([True, False]),
                       rest_fraction=[0.3, 0.0], slow=[0.0, 0.05])
    qd = np.array([[0.0, 0.0], [0.5, 0.03], [0.5, 0.5]])
    # at rest the band gains Fs; joint 2 also slower than its fit data ran (0.03 < 0.05)
    assert s.widths(qd, [0.5, 0.5]).tolist() == [[1.5, 2.5], [0.5, 2.5], [0.5, 0.5]]
    # flags only where the fit never rested (joint 2)
    assert s.flags(qd).tolist() == [[False, True], [False, True], [False, False]]
    back = StaticFriction.from_dict(s.to_dict(), 2, "rest")
    assert back.to_dict() == s.to_dict()
    with pytest.raises(ModelError, match="rest: threshold: expected 3 numbers"):
        StaticFriction.from_dict(s.to_dict(), 3, "rest")
    bad = dict(s.to_dict(), static_level=[1.0, -2.0])
    with pytest.raises(ModelError, match="static_level|level"):
        StaticFriction.from_dict(bad, 2, "rest")
    from manipdyn.formats.trust import check_trust

    with pytest.raises(ModelError, match="rest.static_level"):
        check_trust({"format": "manipdyn-trust/1", "rest": bad})


def test_the_bands_speed_class_widens_slow_samples_and_round_trips():
    """The band's speed class (uncertainty/conformal.py): samples slower than ``slow_speed`` get at least
    ``slow_half_width``; at rest on a joint whose static level was measured the class gives way to that level
    (the fit's own rests held it), and where it was not, the class plus the law's breakaway; the trust record
    carries both numbers."""
    from manipdyn.identification.uncertainty.bands import PredictionBand
    from manipdyn.identification.uncertainty.conformal import slow_fields, slow_speeds

    band = PredictionBand(level=0.95, half_width=[0.5, 0.5], folds=5, samples=100, held_out_rms=[0.2, 0.2],
                          slow_speed=[0.1, 0.1], slow_half_width=[0.9, 0.9])
    rest = StaticFriction(threshold=[0.01, 0.01], level=[1.0, 2.0], measured=np.array([True, False]),
                          rest_fraction=[0.3, 0.0])
    qd = np.array([[0.0, 0.0], [0.05, 0.05], [0.5, 0.5]])
    assert band.sample_widths(None, qd).tolist() == [[0.9, 0.9], [0.9, 0.9], [0.5, 0.5]]
    assert band.sample_widths(None, qd, rest).tolist() == [[1.5, 2.9], [0.9, 0.9], [0.5, 0.5]]
    back = PredictionBand.from_dict(band.to_dict(), 2, "band")
    assert back.slow_speed.tolist() == [0.1, 0.1] and back.slow_half_width.tolist() == [0.9, 0.9]
    with pytest.raises(ModelError, match="go together"):
        PredictionBand(level=0.95, half_width=[0.5], folds=5, samples=100, held_out_rms=[0.2], slow_speed=[0.1])
    # the class: the slowest 5 % of the moving samples; its width never under the band's
    rng = np.random.default_rng(0)
    v = rng.uniform(-1, 1, (2000, 1))
    still = np.abs(v) < 0.01
    speed, slow = slow_speeds(v, still)
    assert np.isclose(speed[0], np.quantile(np.abs(v[~still]), 0.05)) and not np.any(slow & still)
    r = np.where(slow, 3.0, 0.1) * rng.standard_normal(v.shape)
    out = slow_fields(speed, slow, [r], 0.95, np.array([0.2]))
    assert out["slow_half_width"][0] > 3.0 and slow_fields(None, slow, [r], 0.95, np.array([0.2])) == {}


def test_fit_keeps_a_joint_at_rest_still_and_out_of_its_rows():
    """fit(rest=...): the rows of a joint at rest are out of its least squares, and predict gives the rigid
    part there, whatever the sign of the velocity's noise (today's main: Fc sign(noise))."""
    from manipdyn.identification import fit

    truth = _truth()
    t, q, qd, qdd = point_to_point(truth, 5, postures=6)
    ex = excitation(md.load("ur5"), duration=10.0, harmonics=3, rate=100.0, iterations=0, seed=3, ramp=0)
    q, qd, qdd = (np.concatenate([a, b]) for a, b in ((ex.q, q), (ex.qd, qd), (ex.qdd, qdd)))
    tau = _torques(truth, q, qd, qdd, 5)
    noisy = qd + QD_NOISE * np.random.default_rng(7).standard_normal(qd.shape)
    prior = md.load("ur5")
    # the Coulomb smoothing at the velocity's noise, as identify chooses it (inputs/choices.py)
    law = FrictionTerms(("viscous", "coulomb", "offset"), smoothing=QD_NOISE)
    r = fit(prior, q, noisy, qdd, tau, method="wls", friction=law, rest=3 * QD_NOISE)
    rest = rest_mask(noisy, 3 * QD_NOISE)
    assert 0.2 < rest.mean() < 0.5
    pred = r.predict(q, noisy, qdd)
    still = r.predict(q, np.where(rest, 0.0, noisy), qdd)
    np.testing.assert_array_equal(pred, still)          # the noise's sign changes nothing at rest
    # the rigid part at rest, not +-Fc on the noise's sign: per joint the median error to the truth's rigid
    # torque there is within a tenth of its Coulomb level plus its torque noise.  Measured: 0.002 to 0.056
    # N m; without rest= (today's main) 0.09 to 1.40 N m, over the bound on every joint
    rigid = truth.inverse_dynamics(q, np.where(rest, 0.0, qd), qdd)
    per = np.abs(pred - rigid)
    for j in range(6):
        assert np.median(per[rest[:, j], j]) < 0.1 * FC[j] + SIGMA[j], (j, np.median(per[rest[:, j], j]))
    # the static friction is out of the joints' noise levels (without rest=: 0.97 N m on joint 1, here 0.18)
    assert np.all(r.sigma < 0.5 * FC + SIGMA), r.sigma
    assert r.rest.tolist() == [3 * QD_NOISE] * 6


# -- identify and validate on a point-to-point run ---------------------------------------------------------------
def _scores(model, path):
    data = read_log(path, 6)
    v = validate(model, data)
    err = v.measured - v.predicted
    inside = np.abs(err) <= v.band
    flags = v.extrapolation.flags
    return v, data, inside, flags


def test_band_holds_at_rest_on_a_point_to_point_run(logs, tmp_path):
    """Issue 45's synthetic target: fitted on Fourier runs with the truth's friction terms, scored on a
    point-to-point run, the band holds 90 to 98 % pooled.  Measured: 96.3 % pooled, 95.2 to 97.4 % per
    joint, rest samples 98.9 to 100 % (before the band's speed class and the rests kept out of the smoothing's
    and the shapes' refits: 95.9 %, 94.0 to 97.4 %; before the rest: 64.5 % pooled, 61.7 to 68.5 % per joint)."""
    out = tmp_path / "m.toml"
    r = identify("ur5", [logs["fourier1"], logs["fourier2"]], friction_terms="viscous,coulomb,stribeck,offset",
                 output=out)
    assert r.arm is not None, r.fit.arm_error
    assert any(n.startswith("rest: a joint whose |qd|") for n in r.report_dict["fit_notes"])
    model = md.load(out)                        # the trust record carries the rest: validate on a new log
    rest_rec = carried_trust(model).rest
    assert rest_rec is not None and not np.any(rest_rec.measured)      # the Fourier runs never rest
    # the stand-in static level: the fitted Coulomb plus Stribeck, near the truth's Fs (2.21 for 2.25 on
    # joint 1); 15 % covers the fit's error in the shapes (varpro) on 4000 noisy samples
    np.testing.assert_allclose(rest_rec.level, FS, rtol=0.15)
    v, data, inside, flags = _scores(model, logs["ptp12"])
    rest = rest_mask(data.qd, rest_rec.threshold)
    assert 0.3 < rest.mean() < 0.4                                   # a third of the run at rest
    # at rest the prediction is the rigid part (the still velocity), the band the static one
    np.testing.assert_allclose(v.predicted, model.inverse_dynamics(data.q, np.where(rest, 0.0, data.qd), data.qdd))
    hw = carried_trust(model).band.half_width
    assert np.all(v.band[rest] >= (np.broadcast_to(hw, rest.shape) + rest_rec.level)[rest] - 1e-12)
    assert np.all(flags[rest])                                       # where the fit never rested: flagged
    assert 0.90 <= v.pooled_coverage <= 0.98, v.coverage
    assert np.all(v.coverage >= 0.90), v.coverage      # measured 94.0 % the lowest
    assert np.mean(inside[rest]) >= 0.95


def _warned(inside, flags, j) -> bool:
    """Issue 45's rule for a joint whose band holds under 85 %: unflagged samples hold 85 % or more, flagged ones
    miss at least twice as often, and at most 3x as many samples are flagged as missed."""
    i, f = inside[:, j], flags[:, j]
    if not np.any(f) or np.all(f):
        return False
    miss_f, miss_u = 1 - np.mean(i[f]), 1 - np.mean(i[~f])
    return np.mean(i[~f]) >= 0.85 and miss_f >= 2 * miss_u and np.sum(f) <= 3 * np.sum(~i)


def test_band_holds_with_coulomb_only_at_the_slowest_speeds(logs, tmp_path):
    """With viscous and Coulomb only (no Stribeck to reach the static level), the law under-predicts the friction
    of every start and stop, and at rest its breakaway (the fitted Coulomb level) is a lower bound of the static
    one.  The band's speed class (uncertainty/conformal.py: the held-out error of the fit's slowest 5 % of moving
    samples, where the Fourier runs' reversals show the breakaway the law left out) covers both: issue 45's
    target, 90 to 98 % pooled or the misses warned on every joint under 85 %.  Measured: pooled 96.3 %, joints
    91.6 96.2 95.6 97.2 97.3 100.0 %, rest samples 96.9 to 100 %, slow moving ones (under 0.1 rad/s) 83 to 99 %.
    Before the speed class: pooled 82.1 %, joints 72.0 91.7 83.8 82.7 72.8 89.6 %, slow moving samples 34 to
    60 % and unflagged, and joints 3 and 4 unwarned (joint 3: unflagged samples held 78.9 %, flagged ones
    missed 0.7x as often).  Today's main: pooled 62 %."""
    r = identify("ur5", [logs["fourier1"], logs["fourier2"]], friction_terms="viscous,coulomb,offset")
    band, rest_rec = carried_trust(r).band, carried_trust(r).rest
    # the class is wider than the band on every joint (the slow samples' error is the law's missing breakaway)
    assert np.all(band.slow_half_width > band.half_width), (band.slow_half_width, band.half_width)
    v, data, inside, flags = _scores(r, logs["ptp12"])
    rest = rest_mask(data.qd, rest_rec.threshold)
    # at rest where the fit never rested: the slow class plus the law's breakaway level
    np.testing.assert_allclose(v.band[rest], (np.broadcast_to(band.slow_half_width, rest.shape)
                                              + rest_rec.level)[rest])
    assert 0.90 <= v.pooled_coverage <= 0.98, v.coverage
    for j in range(6):
        assert v.coverage[j] >= 0.85 or _warned(inside, flags, j), (j, v.coverage)


def test_a_fit_that_rested_measures_the_static_level(logs, tmp_path):
    """Fitted on a Fourier run and a point-to-point run, the rest rows are out of the least squares and the
    static level is measured on them (the 95th percentile of |tau - rigid part| at rest, near the truth's
    held levels up to Fs); rest samples of a new point-to-point run are then not flagged by the rest."""
    r = identify("ur5", [logs["fourier1"], logs["ptp11"]], friction_terms="viscous,coulomb,stribeck,offset")
    rec = carried_trust(r).rest
    assert np.all(rec.measured)
    assert np.all(rec.rest_fraction > 0.1)
    # the held fraction is drawn in [0.5, 1] per rest: the 95th percentile of |static + noise| lies between
    # 0.75 Fs and Fs plus the noise's reach (3 sigma, coloured)
    assert np.all(rec.level >= 0.75 * FS) and np.all(rec.level <= FS + 3 * SIGMA), rec.level
    v, data, inside, flags = _scores(r, logs["ptp12"])
    assert not np.any(rec.flags(data.qd))
    assert 0.90 <= v.pooled_coverage <= 0.99, v.coverage


# -- the real UR5's rests ------------------------------------------------------------------------------------------
def test_the_ur5_rests_are_found_from_its_velocity_noise():
    """On the UR5's No6 run (125 Hz, point-to-point with 20 rests), the rest threshold from the log's
    velocity noise (3 x what the filter removed from qd: 4.3e-3 to 6.1e-2 rad/s) holds every sample the
    README calls at rest (every joint under 1e-3 rad/s, 23 % of the run) at rest on every joint; each joint
    alone is at rest 51 to 83 % of the run (the moves are mostly one or two joints at a time)."""
    from common import REALDATA

    path = REALDATA / "ur5_kufieta2013" / "No6_Acc_slow_Verify_Model.csv"
    if not path.is_file():
        pytest.skip(f"the real-data folder is absent ({path.name} not found in {path.parent})")
    from manipdyn.identification.inputs.rest import rest_threshold

    data = read_log(path, 6, columns="tau=m{i},i=unused{i}")
    threshold, note = rest_threshold(data)
    assert np.all((threshold > 1e-3) & (threshold < 0.1)), threshold
    raw = np.genfromtxt(path, delimiter=",", names=True)
    t = raw["t"]
    qd = np.stack([raw[f"qd{j}"] for j in range(1, 7)], axis=1)
    still = np.all(np.abs(qd) < 1e-3, axis=1)
    assert 0.2 < np.mean(still) < 0.3                      # the README's 23 %
    # the read log is filtered and trimmed at its ends: match its samples by time
    k = np.searchsorted(t, data.t)
    rest = rest_mask(data.qd, threshold)
    assert np.mean(np.all(rest[still[k]], axis=1)) > 0.99
    assert np.all(np.mean(rest, axis=0) >= np.mean(still)), np.mean(rest, axis=0)


@pytest.fixture(scope="module")
def new_ptp(tmp_path_factory):
    """A point-to-point run no fit sees (seed 13): its log, and the truth's error on its exact states (the
    noise plus the held static friction, what no model of the law can predict)."""
    truth = _truth()
    t, q, qd, qdd = point_to_point(truth, 13)
    path = tmp_path_factory.mktemp("new") / "ptp13.csv"
    _write(path, truth, t, q, qd, qdd, 13)
    own = _torques(truth, q, qd, qdd, 13) - truth.inverse_dynamics(q, qd, qdd)
    return path, t, own


@pytest.mark.parametrize("terms", ["viscous,coulomb,offset", "viscous,coulomb,stribeck,offset"])
def test_a_fit_on_fourier_and_ptp_runs_predicts_a_new_ptp_run_as_the_truth(logs, new_ptp, terms):
    """Issue 45's synthetic target: fitted on two Fourier runs and a point-to-point run, every joint's RMS on a new
    point-to-point run is within 1.2x the truth's own (the truth on the run's exact states: its noise plus the
    static friction it held at rest).  Measured (ratio to the truth's RMS, joints 1 to 6): viscous and Coulomb
    1.10 1.04 1.05 1.04 1.09 1.03; with Stribeck 1.08 1.03 1.04 1.03 1.08 1.03 (the rest of it is the filtered
    log's own error: the truth on the log's states, still at rest, scores 1.00 to 1.03 of the model).  The rests'
    static friction dominates the whole run's RMS, so the moving samples are checked too: with the truth's law
    they are within 1.5x the torque noise (measured 0.96 to 1.19x; before the smoothing's and the friction
    shapes' refits kept the rests out as the fit does, 2.9x on joint 5 and 16x on joint 6, the Stribeck velocity
    of joint 6 fitted at 0.011 rad/s for 0.05); without Stribeck 1.1 to 22x (0.26 N m on joint 1)."""
    r = identify("ur5", [logs["fourier1"], logs["fourier2"], logs["ptp11"]], friction_terms=terms)
    path, t, own = new_ptp
    v, data, inside, flags = _scores(r, path)
    truth = np.sqrt(np.mean(own[np.searchsorted(t, data.t - 1e-9)] ** 2, axis=0))    # the log's samples, trimmed
    ratio = v.rms / truth
    assert np.all(ratio <= 1.2), ratio
    rest = rest_mask(data.qd, carried_trust(r).rest.threshold)
    moving = np.array([np.sqrt(np.mean((v.measured - v.predicted)[~rest[:, j], j] ** 2)) for j in range(6)])
    if "stribeck" in terms:     # the law of the truth: on the moving samples within 1.5x the torque noise
        assert np.all(moving <= 1.5 * SIGMA), moving / SIGMA
