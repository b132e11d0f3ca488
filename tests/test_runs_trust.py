"""Issue 37, items 1 to 3 on synthetic logs: runs are the unit of trust.

1. With two or more distinct trajectories the band is calibrated on held-out runs, repeats of one
   trajectory held out together (and named); with one trajectory it says it is within one.
2. The options ``identify`` sets from the data are chosen on the same folds, and replace the default
   only when they win by more than the folds' spread; one note says so.
3. ``validate``'s per-sample flags hold the joint's own range, the held-out leverage and rest, and
   ``--json`` reports the band's coverage on flagged and unflagged samples.

The real arm (KUKA LWR4+) is in tests/test_runs_trust_realdata.py."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

import manipdyn as md

pytest.importorskip("cvxpy", reason="identification needs the identify extra")

from manipdyn.cli import main  # noqa: E402
from manipdyn.identification import excitation, write_measurements_csv  # noqa: E402
from manipdyn.identification.inputs.trajectories import repeat_groups  # noqa: E402
from manipdyn.identification.uncertainty.bands import PredictionBand, calibrate_band  # noqa: E402

SIGMA = np.array([0.5, 0.5, 0.3, 0.1, 0.1, 0.1])      # UR5 torque noise, N m (tests/test_bands.py's)


def _coloured(rng, shape, phi=0.5):
    e = rng.standard_normal(shape)
    out = np.empty(shape)
    out[0] = e[0]
    for k in range(1, shape[0]):
        out[k] = phi * out[k - 1] + np.sqrt(1 - phi**2) * e[k]
    return out


def _log(path, arm, seed, noise_seed=None, hold=None):
    """A 10 s, 100 Hz excitation (seeded) with its exact torques plus coloured noise; ``hold``: a joint
    (0-based) kept at rest at its mean position (a log that pauses where the excitation never does)."""
    ex = excitation(arm, duration=10.0, harmonics=3, rate=100.0, iterations=0, seed=seed, ramp=0)
    q, qd, qdd = ex.q.copy(), ex.qd.copy(), ex.qdd.copy()
    if hold is not None:
        q[:, hold], qd[:, hold], qdd[:, hold] = np.mean(q[:, hold]), 0.0, 0.0
    rng = np.random.default_rng(100 + (seed if noise_seed is None else noise_seed))
    tau = arm.inverse_dynamics(q, qd, qdd) + SIGMA * _coloured(rng, q.shape)
    write_measurements_csv(path, ex.t, q, tau, qd=qd, qdd=qdd)
    return ex


@pytest.fixture(scope="module")
def three_runs(tmp_path_factory):
    """The UR5 fitted on three distinct excitations (wls: the right model class), and a fourth to score."""
    d = tmp_path_factory.mktemp("runs")
    arm = md.load("ur5")
    logs = [d / f"run{k}.csv" for k in (1, 2, 3)]
    for k, path in enumerate(logs):
        _log(path, arm, 11 + k)
    new = d / "new.csv"
    _log(new, arm, 20)
    r = md.identify(arm, [str(p) for p in logs], method="wls")
    model = d / "ur5_id.json"
    r.save(model)
    return arm, logs, new, r, model


def test_the_band_of_three_trajectories_is_calibrated_on_held_out_runs(three_runs):
    """Item 1 and the synthetic target: the band of three runs comes from each run predicted by a fit on
    the other two; it holds 93 to 97 % of a fourth trajectory with the right model class, and is no more
    than 1.3 times as wide as the within-run band of the same data.  Measured: 95.3 % pooled (per joint
    94.0 to 96.2 %), the half-width 1.00 to 1.02 times the blocked band's (1.008 on average)."""
    arm, logs, new, r, model = three_runs
    band = PredictionBand.from_dict(r.provenance["prediction_band"], 6, "provenance")
    assert band.trajectories == 3 and not band.within_one_trajectory
    assert r.provenance["prediction_band"]["method"] == "held-out trajectories"
    assert any(x.startswith("runs: 3 distinct trajectories among 3 runs") for x in r.report()["fit_notes"])
    d = r.data
    within = calibrate_band(arm, d.q, d.qd, d.qdd, d.tau, method="wls", segments=d.segments, regions=False)
    assert within.within_one_trajectory
    ratio = band.half_width / within.half_width
    assert np.all(ratio >= 1.0 - 1e-12)        # at least the within-run band (bands.py: the larger of the two)
    assert float(np.mean(band.half_width)) <= 1.3 * float(np.mean(within.half_width)), ratio
    v = md.validate(str(model), [str(new)]).results[0]
    # 93-97 %: the target (tests/test_bands.py gives its standard error, ~0.5 % pooled, for 6000 samples)
    assert 0.93 <= v.pooled_coverage <= 0.97, v.coverage
    assert min(v.coverage) >= 0.85, v.coverage
    assert not any("within one trajectory" in x for x in v.notes)


def test_repeats_of_one_trajectory_are_found_and_held_out_together(tmp_path):
    """Item 1: runs repeating one trajectory (the same excitation, other noise) are one group, named in the
    notes; with only such runs the band is within one trajectory, and validate and the report say so."""
    arm = md.load("ur5")
    a, b, c = tmp_path / "a.csv", tmp_path / "b.csv", tmp_path / "c.csv"
    ea = _log(a, arm, 5)
    eb = _log(b, arm, 5, noise_seed=6)
    ec = _log(c, arm, 7)
    assert repeat_groups([(ea.t, ea.q), (eb.t, eb.q), (ec.t, ec.q)]) == [[0, 1], [2]]
    # shifted in time by 1.3 s (a log started later): still the same trajectory
    assert repeat_groups([(ea.t[130:], ea.q[130:]), (eb.t, eb.q)]) == [[0, 1]]
    r = md.identify(arm, [str(a), str(b), str(c)], method="wls")
    note = next(x for x in r.report()["fit_notes"] if x.startswith("runs: "))
    assert "2 distinct trajectories among 3 runs" in note and "a.csv and b.csv" in note
    assert r.provenance["prediction_band"]["trajectories"] == 2
    one = md.identify(arm, [str(a), str(b)], method="wls")
    assert one.provenance["prediction_band"]["trajectories"] == 1
    assert "WITHIN ONE TRAJECTORY" in one.format()
    model = tmp_path / "one.json"
    one.save(model)
    v = md.validate(str(model), [str(c)]).results[0]
    assert any("within one trajectory" in x and "has not seen how another trajectory differs" in x
               for x in v.notes)
    assert "within one trajectory" in v.band_method


def test_options_are_chosen_on_held_out_runs_with_one_note(three_runs, tmp_path):
    """Item 2: the Coulomb smoothing is chosen on the held-out trajectories; the noise level stays unless a
    candidate wins by more than one standard error of the folds, and a single note lists the candidates,
    their scores and spreads, and the choice (no second 'chosen from the noise level' note)."""
    arm, logs, _, _, _ = three_runs
    r = md.identify(arm, [str(p) for p in logs], friction_terms="viscous,coulomb", method="wls",
                    prior_weight=0.0)
    notes = [x for x in r.report()["fit_notes"] if x.startswith("Coulomb smoothing")]
    assert len(notes) == 1, notes
    assert "chosen by held-out trajectories (3 groups" in notes[0] and "(default)" in notes[0]
    table = r.report()["smoothing_selection"]
    assert all(len(row["fold_scores"]) == 3 and "spread" in row for row in table)
    default = next(row for row in table if "gain" in row and row["gain"] == 0.0)
    chosen = r.provenance["options"]["smoothing"]
    from manipdyn.identification.estimation.selection import MIN_GAIN

    winners = [row for row in table if row["gain"] > max(row["spread"], MIN_GAIN)]
    if winners:
        assert chosen == min(winners, key=lambda row: row["score"])["smoothing"]
    else:
        assert chosen == default["smoothing"]
    # a candidate's win inside the folds' spread does not move the choice (the rule, on a made-up table)
    from manipdyn.identification.estimation.selection import one_se_choice

    rows = [{"v": 1.0, "score": -1.00, "fold_scores": [-1.0, -1.1, -0.9]},
            {"v": 10.0, "score": -1.006, "fold_scores": [-1.05, -1.08, -0.888]}]
    assert one_se_choice(rows, "v", 1.0)[0]["v"] == 1.0
    rows[1]["fold_scores"] = [-1.02, -1.12, -0.92]         # the same win on every fold: it is taken
    assert one_se_choice(rows, "v", 1.0)[0]["v"] == 10.0
    rows[1]["fold_scores"] = [-1.003, -1.103, -0.903]      # ... unless it is too small to matter (MIN_GAIN)
    assert one_se_choice(rows, "v", 1.0)[0]["v"] == 1.0


def test_flags_hold_the_joints_own_range_and_rest_and_json_scores_them(three_runs, tmp_path, capsys):
    """Item 3: a joint resting where the fit never rested, and a joint beyond its own fitted range, are
    flagged per sample (x{i}) before the torque is seen, and the joint's EXTRAPOLATES verdict agrees;
    --json gives the band's coverage on flagged and unflagged samples and the fraction flagged."""
    arm, _, new, _, model = three_runs
    rest = tmp_path / "rest.csv"
    _log(rest, arm, 20, hold=4)                   # joint 5 held still: Coulomb decides there, never fitted
    pred = tmp_path / "p.csv"
    capsys.readouterr()
    main(["validate", str(model), str(rest), "--predictions", str(pred), "--json"])
    out = json.loads(capsys.readouterr().out)
    with pred.open() as f:
        rows = list(csv.reader(f))
    x = np.array([r[-6:] for r in rows[1:]], dtype=float)
    assert rows[0][-6:] == [f"x{j}" for j in range(1, 7)]
    assert np.all(x[:, 4] == 1.0)                     # every sample of the resting joint
    assert out["extrapolation"][4]["extrapolates"]
    assert out["flagged_fraction"][4] == 1.0
    for key in ("band_95_coverage_flagged", "band_95_coverage_unflagged"):
        assert len(out[key]) == 6
    assert out["band_95_coverage_unflagged"][4] is None
    # on another trajectory of the same kind the flags stay mostly quiet (they must not fire everywhere):
    # at most 10 % of any joint's samples, the issue's bound for the LWR4's held-out run (measured: 7.6 % on
    # joint 1, 0 to 6.8 % on the others, the leverage of a new excitation beyond the held-out runs')
    capsys.readouterr()
    main(["validate", str(model), str(new), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert max(out["flagged_fraction"]) <= 0.10, out["flagged_fraction"]
    assert out["band_95_pooled"] >= 0.93
    # a joint's own range: q3 moved 0.5 rad beyond what the fit saw is flagged on every such sample
    shifted = tmp_path / "shift.csv"
    ex = excitation(arm, duration=10.0, harmonics=3, rate=100.0, iterations=0, seed=20, ramp=0)
    q = ex.q.copy()
    q[:, 2] += 0.5 + float(np.ptp(q[:, 2]))
    write_measurements_csv(shifted, ex.t, q, arm.inverse_dynamics(q, ex.qd, ex.qdd), qd=ex.qd, qdd=ex.qdd)
    capsys.readouterr()
    main(["validate", str(model), str(shifted), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert out["flagged_fraction"][2] == 1.0 and out["extrapolation"][2]["extrapolates"]
