"""Issue 30: every kind of model carries its trust record, and the band knows where it is.

Item 1: the record (band, fitted range, data sha256, options, leverage) goes through
``manipdyn.formats.trust`` on every route: a TOML model file (DH), one with an embedded URDF,
the bundled models' reader, a URDF written by ``md.to_urdf`` / ``manipdyn urdf``, and a base
model JSON; ``validate`` reads it from each.  Item 2: the leverage of each joint's regressor
row flags a joint whose own states stay in range while the others' leave theirs, the band grows
with it only where the held-out errors say so, and ``--predictions`` has ``x{i}`` columns.
"""

import json
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main
from manipdyn.formats.modelfile import parse_model
from manipdyn.formats.trust import TRUST_FORMAT, check_trust, trust_comment
from manipdyn._support.errors import ModelError

from test_bands import _log


def _identified(tmp_path, prior="ur5", **kw):
    """An identification of the UR5 on a seeded synthetic log (its trust record complete)."""
    arm = md.load("ur5")
    log = tmp_path / "fit.csv"
    _log(log, arm, 11)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return md.identify(prior, [log], band_folds=3, **kw), log


def _same_record(a, b):
    assert a is not None and b is not None
    assert a == b, {k: (a.get(k), b.get(k)) for k in set(a) | set(b) if a.get(k) != b.get(k)}


def test_the_trust_record_round_trips_every_kind_of_model(tmp_path, capsys):
    r, log = _identified(tmp_path, friction_terms="viscous,coulomb,offset", method="consistent", smoothing=0.01)
    record = r.arm.trust
    assert record["format"] == TRUST_FORMAT
    assert {"data_sha256", "options", "fitted_range", "prediction_band", "leverage"} <= set(record)
    assert record["data_sha256"] == r.provenance["data_sha256"] and len(record["data_sha256"]) == 64
    # TOML model file (DH)
    toml = tmp_path / "id.toml"
    r.save(toml)
    _same_record(md.load_with_notes(str(toml))[0].trust, record)
    # what the bundled models' reader reads (the same parser, named as a bundled model)
    _same_record(parse_model(toml.read_text(), "bundled model id").trust, record)
    assert md.load("ur5").trust is None
    # a URDF written from the identified model (md.to_urdf, manipdyn urdf), read back by md.load
    urdf = tmp_path / "id.urdf"
    urdf.write_text(md.to_urdf(r.arm))
    back = md.load_with_notes(str(urdf))[0]
    assert back.trust["prediction_band"] == record["prediction_band"]
    assert any("friction law" in d for d in back.trust["doubts"])      # what a URDF cannot hold is said
    assert main(["urdf", str(toml), str(tmp_path / "u")]) == 0
    capsys.readouterr()
    assert md.load_with_notes(str(tmp_path / "u" / "id.urdf"))[0].trust["leverage"] == record["leverage"]
    # a TOML model file with the URDF embedded (a URDF arm with a friction law), and its base model JSON
    urdf_prior = tmp_path / "ur5.urdf"
    urdf_prior.write_text(md.to_urdf(md.load("ur5")))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ru = md.identify(str(urdf_prior), [log], band_folds=3, friction_terms="viscous,coulomb,offset",
                         method="consistent", smoothing=0.01,
                         output=tmp_path / "idu.toml", base_json=tmp_path / "idu.json")
    text = (tmp_path / "idu.toml").read_text()
    assert "urdf = '''" in text and "[trust]" in text and text.count(TRUST_FORMAT) == 1   # once, in [trust]
    _same_record(md.load_with_notes(str(tmp_path / "idu.toml"))[0].trust, ru.arm.trust)
    base = json.loads((tmp_path / "idu.json").read_text())
    _same_record(base["trust"], ru.arm.trust)
    # validate reads the band from each kind: text, --json, --predictions
    for model in (toml, tmp_path / "idu.toml", tmp_path / "idu.json", tmp_path / "u" / "id.urdf"):
        assert main(["validate", str(model), str(log), "--json", "--predictions", str(tmp_path / "p.csv")]) == 0
        out = json.loads(capsys.readouterr().out)
        assert out["band_95_pooled"] is not None, model
        # one trajectory: its posture regions held out, with the blocks (bands.py), whatever the file's kind
        assert out["band_method"].startswith("held-out posture regions (4,"), model
        assert "within one trajectory" in out["band_method"], model
        assert all("beyond_fit_fraction" in row for row in out["extrapolation"]), model
        header = (tmp_path / "p.csv").read_text().splitlines()[0].split(",")
        assert header[-6:] == [f"x{j}" for j in range(1, 7)] and "lo1" in header, model


def test_a_broken_record_is_refused_by_name():
    with pytest.raises(ModelError, match="key 'format'"):
        check_trust({"format": "other/1"}, "here")
    with pytest.raises(ModelError, match="finite"):
        check_trust({"format": TRUST_FORMAT, "x": float("nan")}, "here")
    # '--' inside a string cannot end the XML comment
    body = trust_comment({"format": TRUST_FORMAT, "data": "a--b.csv"})
    assert "--" not in body
    from manipdyn.formats.save import to_toml

    text = to_toml(md.load("ur5"))
    text += '\n[trust]\nformat = "manipdyn-trust/0"\n'
    with pytest.raises(ModelError, match="m.toml: key 'trust'"):
        parse_model(text, "m.toml")


def test_the_leverage_flags_only_beyond_what_the_band_was_checked_on(tmp_path, capsys):
    """q2 shifted 0.6 rad past the fit.  Issue 37: the leverage threshold is calibrated on the held-out
    blocks, not "beyond every fitted sample": joint 1's row is beyond every fitted sample here (its old
    flag) but not beyond what the blocks held out, and its band does hold there (right model class:
    measured 95.9 %), so joint 1 is not flagged by its leverage; joint 2, whose own q leaves the fitted
    range, is flagged per sample (x2) where q2 is beyond it, and its verdict agrees."""
    arm = md.load("ur5")
    fit_log, shifted = tmp_path / "fit.csv", tmp_path / "shifted.csv"
    _log(fit_log, arm, 4)
    _log(shifted, arm, 4, shift=[0.0, 0.6, 0.0, 0.0, 0.0, 0.0])
    model = tmp_path / "id.json"
    assert main(["identify", "ur5", str(fit_log), "-o", str(model), "--method", "wls"]) == 0
    capsys.readouterr()
    assert main(["validate", str(model), str(fit_log), "--json"]) == 0
    same = json.loads(capsys.readouterr().out)
    # on the fit data itself hardly a sample is beyond the fit (the threshold is the 99 % quantile of the
    # held-out samples' leverage, each against a fit without its block, which the full fit only lowers)
    assert all(row["beyond_fit_fraction"] <= 0.01 for row in same["extrapolation"]), same["extrapolation"]
    assert main(["validate", str(model), str(shifted), "--json", "--predictions", str(tmp_path / "p.csv")]) == 0
    out = json.loads(capsys.readouterr().out)
    j1, j2 = out["extrapolation"][0], out["extrapolation"][1]
    assert j1["leverage_extrapolates"] is False and j1["beyond_fit_fraction"] < 0.01
    assert out["band_95_coverage"][0] >= 0.93                  # the band the flag stayed quiet for holds
    assert j2["range_extrapolates"] and j2["extrapolates"]
    table = np.genfromtxt(tmp_path / "p.csv", delimiter=",", names=True)
    for j, row in enumerate(out["extrapolation"]):                 # x{i}: the fraction the json reports
        assert np.mean(table[f"x{j + 1}"]) == pytest.approx(out["flagged_fraction"][j])
        assert np.mean(table[f"x{j + 1}"]) >= row["beyond_fit_fraction"]
    box = np.array(out["extrapolation"][1]["q"]["fitted"])
    q2 = np.genfromtxt(shifted, delimiter=",", names=True)["q2"]
    far = q2 > box[1] + 0.1 * (box[1] - box[0])
    assert far.any() and np.all(table["x2"][far] == 1.0)          # every sample with q2 far beyond the fit


def test_the_band_does_not_widen_where_the_held_out_errors_do_not_grow(tmp_path):
    """Synthetic data of the right model class, interpolating: the band keeps 93-97 % pooled on another
    trajectory with a mean half-width within 1.3x the constant band's (issue 30 item 2).  With the right
    model the held-out errors do not grow with the leverage, so every gain stays 0 here (a gain must
    make the band 5 % narrower on the held-out samples to be taken); measured 95.2 % pooled, ratio 1.00
    from the blocks; with the posture regions held out (bands.py), 95.8 % and 1.015 times the blocks' band."""
    from manipdyn.identification.uncertainty.bands import calibrate_band

    arm = md.load("ur5")
    fit_log, new_log = tmp_path / "fit.csv", tmp_path / "new.csv"
    _log(fit_log, arm, 1)
    _log(new_log, arm, 2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = md.identify(arm, [fit_log], method="wls")
    v = md.validate(r, [new_log]).results[0]
    d = r.data
    constant = calibrate_band(arm, d.q, d.qd, d.qdd, d.tau, method="wls", leverage=False, regions=False)
    assert 0.93 <= v.pooled_coverage <= 0.97, v.coverage
    assert np.mean(v.band) <= 1.3 * np.mean(constant.half_width)


def test_a_band_that_misses_a_joint_is_flagged(tmp_path, capsys):
    """A model whose predictions are not the ones its band was calibrated with (here: the fitted arm with
    every gravity torque 30 % too large, carrying the fit's record) misses; validate says BAND MISSES."""
    r, log = _identified(tmp_path)
    arm = r.arm
    off = md.Manipulator(arm.links, convention=arm.convention, gravity=np.asarray(arm.gravity) * 1.3, name="off")
    off.trust = arm.trust
    path = tmp_path / "off.toml"
    md.save(off, path)
    assert main(["validate", str(path), str(log), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    missed = [j + 1 for j, c in enumerate(out["band_95_coverage"]) if c < 0.8]
    assert missed and out["band_95_missed"] == missed
    assert main(["validate", str(path), str(log)]) == 0
    assert f"BAND MISSES joint {missed[0]}" in capsys.readouterr().out
