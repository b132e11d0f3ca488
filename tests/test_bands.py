"""Bands that hold and what the data never saw (issue 24, items 3 and 4; issue 27, item 12):
``identify`` records the fitted states and a band from blocked hold-outs of the fit data,
``validate`` scores the band, flags the joints that extrapolate, scores several models side
by side, writes ``--predictions`` and prints the data notes."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

import manipdyn as md
from manipdyn._support.errors import ModelError

pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
from manipdyn.cli import main  # noqa: E402
from manipdyn.identification import excitation, write_measurements_csv  # noqa: E402
from manipdyn.identification.uncertainty.bands import PredictionBand, conformal_half_width  # noqa: E402
from manipdyn.identification.uncertainty.coverage import StateRange, fitted_range  # noqa: E402

#: the noise level per joint of the synthetic UR5, N m: about 1 % of each joint's peak torque
#: along these excitations (joint 6 carries almost no torque: its noise alone)
SIGMA = np.array([0.06, 0.5, 0.15, 0.02, 0.004, 0.001])


def _coloured(rng, shape, phi=0.5):
    """Unit-variance AR(1) noise along axis 0 (correlation phi between neighbouring samples)."""
    w = rng.standard_normal(shape)
    e = np.empty_like(w)
    e[0] = w[0]
    for k in range(1, len(w)):
        e[k] = phi * e[k - 1] + np.sqrt(1 - phi**2) * w[k]
    return e


def _log(path, arm, seed, shift=None):
    """A 10 s, 100 Hz excitation of ``arm`` (seeded), its exact torques plus coloured noise of SIGMA,
    written with measured qd and qdd (nothing filtered).  ``shift``: added to q (n,) before the torques."""
    ex = excitation(arm, duration=10.0, harmonics=3, rate=100.0, iterations=0, seed=seed, ramp=0)   # 1000 samples
    q = ex.q + (0.0 if shift is None else np.asarray(shift))
    tau = arm.inverse_dynamics(q, ex.qd, ex.qdd) + SIGMA * _coloured(np.random.default_rng(100 + seed), q.shape)
    write_measurements_csv(path, ex.t, q, tau, qd=ex.qd, qdd=ex.qdd)
    return q, ex.qd, tau


def test_band_holds_on_another_trajectory_with_the_right_model(tmp_path, capsys):
    """Issue 24 item 3, synthetic target: the nominal 95 % band, computed from the fit log alone,
    holds 93 to 97 % of another trajectory's samples (pooled over the joints) when the model class
    is right and the noise is coloured (AR(1), 0.5 between neighbours).  Measured: 95.8 % on these
    seeds (94.4 to 97.0 % per joint) with the posture regions held out (95.2 % from the blocks alone); the same set-up over six seed pairs (fit on excitation 2k+1, score on 2k+2, k = 0..5,
    ``python -m benchmarks.bench_bands``) gave 92.98 % (seeds 3 -> 4, a hair under the target) to
    96.0 %, a mean of 94.9 %.  6000 samples with a
    correlation time of ~3 give a standard error near 0.5 %, and the 95 % quantile of 1000
    held-out residuals moves each joint's coverage by about 0.7 %: 93-97 is the issue's target,
    and about 2.5 of these standard errors either way.  Per joint, 85 % is far below what any of
    the six gave (91.4 % the lowest)."""
    arm = md.load("ur5")
    fit_log, new_log = tmp_path / "fit.csv", tmp_path / "new.csv"
    _log(fit_log, arm, 1)
    _, _, tau_new = _log(new_log, arm, 2)
    model = tmp_path / "ur5_id.json"
    assert main(["identify", "ur5", str(fit_log), "-o", str(model), "--method", "wls"]) == 0
    capsys.readouterr()
    pred_csv = tmp_path / "pred.csv"
    assert main(["validate", str(model), str(new_log), "--json", "--predictions", str(pred_csv)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["band_method"].startswith("held-out posture regions (4,")   # one trajectory (bands.py)
    assert 0.93 <= out["band_95_pooled"] <= 0.97, out["band_95_coverage"]
    assert all(c >= 0.85 for c in out["band_95_coverage"]), out["band_95_coverage"]
    # the predictions file: t, tau, pred, lo, hi per sample; the band read back from it holds as reported
    with open(pred_csv, newline="") as fh:
        rows = list(csv.reader(fh))
    n = 6
    assert rows[0] == ["t"] + [f"{k}{j}" for k in ("tau", "pred", "lo", "hi", "x") for j in range(1, n + 1)]
    table = np.array(rows[1:], dtype=float)
    tau, pred, lo, hi = (table[:, 1 + k * n:1 + (k + 1) * n] for k in range(4))
    np.testing.assert_allclose(tau, tau_new, rtol=0, atol=1e-9)
    assert np.all(lo <= pred) and np.all(pred <= hi)
    np.testing.assert_allclose(np.mean((lo <= tau) & (tau <= hi), axis=0), out["band_95_coverage"], atol=1e-12)


def test_the_band_and_the_fitted_range_travel_with_a_model_file(tmp_path, capsys):
    """A .toml model carries both in its [sources]; md.load reads them back unchanged, and a
    hand-broken record is ignored with a note rather than failing validate."""
    arm = md.load("ur5")
    fit_log = tmp_path / "fit.csv"
    q, qd, tau = _log(fit_log, arm, 3)
    model = tmp_path / "ur5_id.toml"
    assert main(["identify", "ur5", str(fit_log), "-o", str(model), "--band-folds", "4", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    band = PredictionBand.from_dict(rep["provenance"]["prediction_band"], 6, "report")
    assert band.folds == 4 and band.samples == len(q)
    loaded = md.load(str(model))
    back = PredictionBand.from_text(loaded.sources["prediction_band"], 6, "model")
    np.testing.assert_allclose(back.half_width, band.half_width, rtol=1e-5)
    rng = StateRange.from_text(loaded.sources["fitted_range"], 6, "model")
    assert np.all(rng.q[:, 0] <= q.min(axis=0)) and np.all(rng.q[:, 1] >= q.max(axis=0))
    assert np.all(rng.tau[:, 1] - tau.max(axis=0) <= 1e-4)     # rounded outwards to 1e-4, no further
    # validating on the fit log itself: nothing outside, nothing flagged
    assert main(["validate", str(model), str(fit_log), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [row["outside_fraction"] for row in out["extrapolation"]] == [0.0] * 6
    # a broken record: validate still scores, says so, and has no band
    text = model.read_text()
    assert "[trust.prediction_band]\n" in text
    text = text.replace("[trust.prediction_band]\n", "[trust.prediction_band]\nfolds = \"garbage\"\n", 1)
    text = text.replace("\nfolds = 4\n", "\n", 1)
    broken = tmp_path / "broken.toml"
    broken.write_text(text)
    assert main(["validate", str(broken), str(fit_log), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert "band_95_coverage" not in out and any("prediction_band" in x for x in out["model_notes"])
    # no band asked for
    assert main(["identify", "ur5", str(fit_log), "-o", str(model), "--band-folds", "0"]) == 0
    capsys.readouterr()
    assert "prediction_band" not in md.load(str(model)).sources
    assert "prediction_band" not in md.load(str(model)).trust and "fitted_range" in md.load(str(model)).trust
    assert main(["identify", "ur5", str(fit_log), "-o", str(model), "--band-folds", "1"]) == 2
    assert "--band-folds" in capsys.readouterr().err


def test_validate_flags_the_joint_that_leaves_the_fitted_states(tmp_path, capsys):
    """Issue 24 item 4: a log whose q2 is shifted 0.6 rad past anything the fit saw is flagged on
    joint 2, with the fraction of samples outside counted as a plain comparison with the fit
    log's extremes would count it; the text report names the joint."""
    arm = md.load("ur5")
    fit_log, shifted = tmp_path / "fit.csv", tmp_path / "shifted.csv"
    q_fit, _, _ = _log(fit_log, arm, 4)
    q_new, _, _ = _log(shifted, arm, 4, shift=[0.0, 0.6, 0.0, 0.0, 0.0, 0.0])
    model = tmp_path / "id.json"
    assert main(["identify", "ur5", str(fit_log), "-o", str(model), "--method", "wls", "--band-folds", "0"]) == 0
    capsys.readouterr()
    assert main(["validate", str(model), str(shifted), "--json"]) == 0
    ex = json.loads(capsys.readouterr().out)["extrapolation"]
    assert len(ex) == 6 and [row["joint"] for row in ex] == list(range(1, 7))
    assert ex[1]["extrapolates"] is True
    expected = np.mean(q_new[:, 1] > np.ceil(q_fit[:, 1].max() * 1e4) / 1e4)
    assert ex[1]["q"]["outside_fraction"] == pytest.approx(expected) and expected > 0.1
    assert ex[1]["q"]["fitted"][1] >= q_fit[:, 1].max()
    assert all(ex[j]["q"]["outside_fraction"] == 0.0 for j in (0, 2, 3, 4, 5))
    assert main(["validate", str(model), str(shifted)]) == 0
    text = capsys.readouterr().out
    assert "EXTRAPOLATES joint 2: q2 in" in text


def test_validate_scores_several_models_side_by_side(tmp_path, capsys):
    """Issue 24 item 4: ``validate A B LOG`` puts both in one table with the best per joint marked,
    in one figure; the JSON names the best per joint.  The truth beats a model whose masses are
    20 % off on the joints that hold the arm against gravity (2 to 4); ``validate MODEL LOG``
    keeps its single-model form."""
    arm = md.load("ur5")
    log = tmp_path / "d.csv"
    _log(log, arm, 5)
    truth = tmp_path / "truth.toml"
    md.save(arm, truth)
    off = md.Manipulator(arm.links, convention=arm.convention, gravity=np.asarray(arm.gravity) * 1.2,
                         name="heavier")      # every gravity torque 20 % too large
    heavier = tmp_path / "heavier.toml"
    md.save(off, heavier)
    fig = tmp_path / "both.png"
    assert main(["validate", str(heavier), str(truth), str(log), "--plot", str(fig)]) == 0
    text = capsys.readouterr().out
    assert "2 models on 1000 samples" in text and fig.stat().st_size > 0
    rows = [line.split() for line in text.splitlines() if line[:5].strip().isdigit()]
    # the torque table, then the forward dynamics' (issue 44 item 4), 6 joints each
    assert len(rows) == 12 and all(r[2].endswith("*") for r in rows[1:4]), text
    assert main(["validate", str(heavier), str(truth), str(log), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [m["model"] for m in out["models"]] == ["heavier", "ur5"]
    assert [b["index"] for b in out["best"][1:4]] == [1, 1, 1]
    assert main(["validate", str(truth), str(log), "--json"]) == 0
    single = json.loads(capsys.readouterr().out)
    assert single["model"] == "ur5" and len(single["rms"]) == 6
    assert main(["validate", str(truth), str(heavier), str(log), "--predictions", str(tmp_path / "p.csv")]) == 2
    assert "--predictions: one MODEL" in capsys.readouterr().err
    before = log.read_bytes()
    assert main(["validate", str(truth), str(log), "--predictions", str(log)]) == 2
    assert "would overwrite DATA" in capsys.readouterr().err and log.read_bytes() == before


def test_validate_prints_the_data_notes_as_identify_does(tmp_path, capsys):
    """Issue 27 item 12: resampling, duplicates and the window are said by validate too."""
    arm = md.load("ur5")
    log = tmp_path / "d.csv"
    _log(log, arm, 6)
    lines = log.read_text().splitlines()
    log.write_text("\n".join(lines[:50] + [lines[49]] + lines[50:]) + "\n")    # one row logged twice
    assert main(["validate", "ur5", str(log), "--t-range", "1:9"]) == 0
    text = capsys.readouterr().out
    assert "data: time: dropped 1 duplicate row" in text and "data: window:" in text
    assert text.index("data:") < text.index("model ur5")
    assert main(["validate", "ur5", str(log), "--json"]) == 0
    notes = json.loads(capsys.readouterr().out)["data_notes"]
    assert any("duplicate" in x for x in notes)


def test_records_refuse_what_they_cannot_read():
    band = PredictionBand(0.95, np.array([1.0, 2.0]), 5, 100, np.array([0.5, 1.0]))
    assert PredictionBand.from_text(band.to_text(), 2, "b").to_dict() == band.to_dict()
    with pytest.raises(ModelError, match="expected 3 numbers"):
        PredictionBand.from_dict(band.to_dict(), 3, "b")
    with pytest.raises(ModelError, match="finite numbers >= 0"):
        PredictionBand(0.95, np.array([1.0, -2.0]), 5, 100, np.array([0.5, 1.0]))
    with pytest.raises(ModelError, match="level"):
        PredictionBand(1.5, np.array([1.0]), 5, 100, np.array([0.5]))
    r = fitted_range(np.zeros((3, 2)), np.ones((3, 2)), np.arange(6.0).reshape(3, 2))
    assert StateRange.from_text(r.to_text(), 2, "r").to_dict() == r.to_dict()
    with pytest.raises(ModelError, match="r: key 'q'"):
        StateRange.from_dict({"q": [[0, 1]], "qd": [[0, 1]] * 2, "tau": [[0, 1]] * 2}, 2, "r")
    with pytest.raises(ModelError, match="min <= max"):
        StateRange(q=np.array([[1.0, 0.0]]), qd=np.zeros((1, 2)), tau=np.zeros((1, 2)))
    # the split-conformal rank: ceil((m + 1) 0.95) of m = 99 residuals is the 95th smallest
    res = np.arange(1.0, 100.0)[:, None]
    assert conformal_half_width(res)[0] == 95.0


def test_too_little_data_for_the_blocks_gives_no_band_and_says_so():
    """fit_record leaves the band out (the model still gets its fitted range) and notes why."""
    from manipdyn.formats.logs.measurements import Measurements
    from manipdyn.identification.results.provenance import fit_record

    arm = md.load("ur5")
    ex = excitation(arm, duration=0.9, harmonics=3, rate=100.0, iterations=0, seed=7, ramp=0)      # 90 samples
    tau = arm.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    data = Measurements(ex.t, ex.q, ex.qd, ex.qdd, tau)
    record, notes = fit_record(arm, data, folds=5, method="wls")
    assert "prediction_band" not in record and "fitted_range" in record
    assert len(notes) == 1 and "90 samples are too few for 5 blocks" in notes[0]


def test_refits_keep_the_runs_apart():
    """Stacked runs: each refit is told the sample counts of what it keeps of each run."""
    from manipdyn.identification.uncertainty.bands import _blocks, _kept_segments

    edges = _blocks(100, 5)
    test = np.zeros(100, dtype=bool)
    test[edges[1]:edges[2]] = True                       # samples 20..39 held out
    assert _kept_segments([30, 70], test) == [20, 60]
    test[:] = False
    test[:20] = True
    assert _kept_segments([20, 80], test) == [80]       # a run wholly held out is dropped
    assert _kept_segments(None, test) is None
    with pytest.raises(ModelError, match="adding up to the 100"):
        _kept_segments([20, 20], test)


def test_the_readme_says_which_model_to_trust():
    """Issue 24 item 6: the README's section, with the cross-trajectory protocol's commands and the
    motor-side form recommended for coupled wrists (its Panda figures are checked against a run
    in tests/test_bands_realdata.py)."""
    from pathlib import Path

    import guide

    section = guide.page("validation")          # the guide's page "Which model to trust" (issue 38 item 15)
    assert "--friction-terms viscous,coulomb,offset --friction-side motor --armature" in section
    assert "manipdyn validate panda_id.toml $LOG --t-range 10:21" in section
    assert "EXTRAPOLATES joint 2" in section


def test_the_pipelines_carry_the_band_and_write_the_predictions(tmp_path, monkeypatch):
    """After the merge of the pipelines (h-runs) with issue 24: ``md.identify(band_folds=K)`` puts the
    band from K blocked hold-outs of the stacked runs in the provenance, each refit told the sample
    counts it keeps of each run; ``md.validate(predictions=...)`` writes the CSV the CLI writes,
    refusing several models and a path that is a log."""
    from manipdyn.identification.estimation import fitting as estimation

    arm = md.load("ur5")
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    _log(a, arm, 7)
    _log(b, arm, 8)
    real_fit, calls = estimation.fit, []

    def recording_fit(*args, **kwargs):
        calls.append((len(args[1]), kwargs.get("segments")))
        return real_fit(*args, **kwargs)

    monkeypatch.setattr(estimation, "fit", recording_fit)     # the refits of bands.held_out_residuals
    r = md.identify(arm, [a, b], method="wls", band_folds=3)
    monkeypatch.undo()
    band = PredictionBand.from_dict(r.provenance["prediction_band"], 6, "provenance")
    assert band.folds == 3 and band.samples == 2000
    from manipdyn.identification.uncertainty.bands import _blocks

    assert calls[0] == (2000, [1000, 1000])             # the fit itself, then one refit per block
    edges = _blocks(1000, 3)         # block k is the k-th third of every run (issue 37: repeats held out together)
    kept = [[1000 - (edges[k + 1] - edges[k])] * 2 for k in range(3)]
    assert [seg for _, seg in calls[1:4]] == kept
    # two distinct trajectories: then each run predicted by a fit on the other
    assert [seg for _, seg in calls[4:6]] == [[1000], [1000]] and len(calls) == 6
    assert all(sum(seg) == n for n, seg in calls)
    assert band.trajectories == 2
    assert "95 % prediction band from 2 held-out trajectories" in r.format()
    assert "at least the within-run band of 3 blocked hold-outs" in r.format()
    assert "fitted_range" in r.provenance
    assert "prediction_band" not in md.identify(arm, [a], method="wls", band_folds=0).provenance
    with pytest.raises(ModelError, match="band_folds: expected 0"):
        md.identify(arm, [a], band_folds=1)
    model = tmp_path / "id.toml"
    r.save(model)
    out = tmp_path / "p.csv"
    v = md.validate(str(model), [b], predictions=out)
    with out.open() as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["t"] + [f"{k}{j}" for k in ("tau", "pred", "lo", "hi", "x") for j in range(1, 7)]
    table = np.array(rows[1:], dtype=float)
    res = v.results[0]
    assert len(table) == len(res.t)
    np.testing.assert_array_equal(table[:, 7:13], res.predicted)
    np.testing.assert_allclose(table[:, 19:25] - table[:, 7:13], res.band, rtol=1e-12)
    np.testing.assert_array_equal(table[:, 25:31], res.extrapolation.flags)
    assert not np.any(res.extrapolation.beyond & ~res.extrapolation.flags)     # a sample beyond by leverage is flagged
    # the half-width is the band's at each sample's leverage ratio (constant where its gain is 0)
    from manipdyn.identification.results.provenance import carried_trust

    u, _ = carried_trust(md.load_with_notes(str(model))[0]).leverage.ratio(arm, v.data.q, v.data.qd, v.data.qdd)
    np.testing.assert_allclose(res.band, band.widths(u), rtol=1e-9)
    with pytest.raises(ModelError, match="predictions: one MODEL"):
        md.validate(["ur5", str(model)], [b], predictions=out)
    before = b.read_bytes()
    with pytest.raises(ModelError, match="would overwrite DATA"):
        md.validate(str(model), [b], predictions=b)
    assert b.read_bytes() == before
