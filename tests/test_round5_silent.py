"""Issue 38 (round five), items 1, 4, 5, 6, 12, 13, 14, 16: silent choices and numbers that
contradicted each other.  Each test failed on the code before the fix."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main


# -- item 1: a vendor URDF's tool frame is no longer chosen silently -----------------------------
def test_item1_default_tool_frame_names_the_frames_passed_over(capsys):
    arm, notes = md.load_with_notes("erd:ur10_robot")
    assert arm.tip == "wrist_3_link"                       # the rule is unchanged: the last moving link
    note = next(n for n in notes if "tool frame" in n)
    assert "'tool0'" in note and "'ee_link'" in note and "tip=" in note
    tool0 = md.load("erd:ur10_robot", tip="tool0")
    assert not any("tool frame" in n for n in tool0.notes)   # a tip the user chose is no guess
    q = np.zeros(6)
    gap = np.linalg.norm(tool0.fkine(q)[:3, 3] - arm.fkine(q)[:3, 3])
    assert f"'tool0' ({gap:.4g} m, 90 deg away)" in note    # the note's distance is the frames' own
    with pytest.warns(md.ModelNoteWarning, match="tool0"):    # where fkine/jacobian/IK users see it
        md.load("erd:ur10_robot")
    assert main(["check", "erd:ur10_robot", "--samples", "2", "--timing-calls", "0"]) == 0
    assert "note: " in capsys.readouterr().out.split("passed over")[0]
    assert main(["check", "erd:ur10_robot", "--samples", "2", "--timing-calls", "0", "--strict"]) == 1
    assert "tool frame taken by default" in capsys.readouterr().out


def test_item1_a_single_leaf_or_an_explicit_tip_adds_no_note():
    with warnings.catch_warnings():
        warnings.simplefilter("error", md.ModelNoteWarning)
        arm = md.load("erd:panda", tip="panda_hand")
    assert arm.notes == () or not any("tool frame" in n for n in arm.notes)


# -- items 4 and 6: validate's band misses side by side, rounding, and every flag's reason -----
def _scored(name, coverage_hits, n_samples=500, leverage_joint=None):
    """A ValidationResult on synthetic samples: joint j's error lies inside its band on
    ``coverage_hits[j]`` of ``n_samples`` samples; ``leverage_joint`` (0-based) lies beyond
    the fit by leverage on 30 % of them while every joint stays inside its fitted range."""
    from manipdyn.identification.results.validation import ValidationResult
    from manipdyn.identification.uncertainty.coverage import fitted_range

    rng = np.random.default_rng(0)
    n = len(coverage_hits)
    t = np.arange(n_samples) * 0.01
    q, qd = rng.uniform(-1, 1, (n_samples, n)), rng.uniform(-1, 1, (n_samples, n))
    measured = rng.uniform(-5, 5, (n_samples, n))
    band = np.ones((n_samples, n))
    err = np.full((n_samples, n), 0.5)
    for j, hits in enumerate(coverage_hits):
        err[hits:, j] = 2.0                                 # outside the band of half-width 1
    predicted = measured - err
    coverage = np.mean(np.abs(err) <= band, axis=0)

    class Data:
        pass

    data = Data()
    data.q, data.qd, data.tau = q, qd, measured
    ex = fitted_range(q, qd, measured).outside(data)        # the fit's range is the data's own: 0 % outside
    beyond = np.zeros((n_samples, n), dtype=bool)
    if leverage_joint is not None:
        beyond[: int(0.3 * n_samples), leverage_joint] = True
    ex.beyond, ex.leverage_ratio = beyond, np.where(beyond, 4.0, 0.5)
    rms = np.sqrt(np.mean(err**2, axis=0))
    return ValidationResult(model=name, rms=rms, relative_rms=rms / np.sqrt(np.mean(measured**2, axis=0)),
                            r2=np.zeros(n), mean_error=err.mean(axis=0), t=t, measured=measured,
                            predicted=predicted, band=band, coverage=coverage, band_method="test band",
                            extrapolation=ex)


def test_item4_side_by_side_keeps_band_misses_and_rounds_below_the_threshold():
    from manipdyn.identification.results.comparison import format_side_by_side

    a = _scored("a", [500, 500, 399])                       # joint 3 holds 399/500 = 79.8 %
    b = _scored("b", [500, 500, 500])
    single = a.format()
    line = next(x for x in single.splitlines() if x.startswith("BAND MISSES joint 3"))
    assert "holds 79.8 %" in line and "(under 80 %)" in line  # not "holds 80 % ... (under 80 %)"
    both = format_side_by_side([a, b])
    assert "BAND MISSES joint 3: the 95 % band holds 79.8 %" in both
    assert both.count("BAND MISSES") == 1                   # b misses nothing
    assert a.to_dict()["band_95_missed"] == [3]             # the same joint the JSON names


def test_item6_validate_page_gives_each_flag_its_reason():
    from manipdyn.identification.results.html import validation_page
    from manipdyn.identification.results.scoring import Validation

    r = _scored("m", [500, 399, 500, 500, 500, 500, 500], leverage_joint=6)
    assert r.extrapolation.fraction[6] == 0.0 and r.extrapolation.flagged[6]   # joint 7: 0 % outside, flagged

    class Data:                                             # one log, read as it was
        t, sources, segments = r.t, ["log.csv"], [len(r.t)]

    page = validation_page(Validation(results=[r], data=Data()))
    assert "why flagged" in page and "beyond the fit by leverage" in page
    row7 = page[page.index(">joint 7<"):].split("</tr>")[0]
    assert "EXTRAPOLATES" in row7 and "by leverage: 30.0 %" in row7 and "up to 4 times" in row7
    row2 = page[page.index(">joint 2<"):].split("</tr>")[0]
    assert "BAND MISSES" in row2 and "holds 79.8 %" in row2


# -- item 5: the Monte-Carlo page says what the CLI prints, names the worst by the table's figure --
def test_item5_montecarlo_page_has_the_draws_line_the_notes_and_true_scales(tmp_path):
    pytest.importorskip("matplotlib")
    from manipdyn import montecarlo as mc
    from manipdyn.control.montecarlo.plot import draw_report

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.ModelNoteWarning)
        arm, notes = md.load_with_notes("puma560")
    assert notes                                            # the Puma's impossible links
    rep = mc.run(mc.study(arm, runs=2, seed=1, controllers=("pd",), duration=0.05), scheduler="sync")
    page = rep.report_html(tmp_path / "mc.html")             # the library call: the arm's own notes
    text = open(page, encoding="utf-8").read()
    effect = rep.effect()["text"]
    assert effect and "holds joint" in effect
    import html as _html
    assert _html.escape(effect[1:60]) in text               # what the draws do to the arm
    for n in notes:
        assert _html.escape(n) in text
    fig = draw_report(rep, title=False)
    scales = {ax.get_xscale() for ax in fig.axes[:len(rep.metrics)]}
    caption = text[text.index("Fraction of runs"):].split("</figcaption>")[0]
    for m, ax in zip(rep.metrics, fig.axes):
        assert (f"{ax.get_xscale()} scale" in caption), (m, ax.get_xscale(), caption)
    if scales == {"linear"}:
        assert "log scale" not in caption


def test_item5_verdict_names_the_worst_by_the_tables_p90():
    from types import SimpleNamespace

    from manipdyn.control.montecarlo.html import _verdict

    def entry(p90, diverged):
        return {"rms_error": {"p90": p90}, "diverged": diverged, "saturated": 0}

    rep = SimpleNamespace(study=SimpleNamespace(runs=100),
                          controllers={"pd": entry(1.44, 0), "ct": entry(0.05, 0), "lqr": entry(0.922, 3)})
    text, level = _verdict(rep)
    assert "computed torque tracks best" in text.split(";")[0]
    worst = text.split(";")[1].split(" rad)")[0]
    assert "PD" in worst and "1.44" in worst and "LQR" not in worst   # the table's largest p90 is PD's
    assert "LQR in 3 of 100 runs" in text and level == "bad"


# -- item 12: excite's period is --period; --duration, its old name, says what the file holds ----
def _csv_span(path):
    t = np.loadtxt(path, delimiter=",", skiprows=1, usecols=0)
    return t[-1] - t[0], len(t)


def test_item12_excite_period_option_and_the_deprecated_duration(tmp_path, capsys):
    pytest.importorskip("scipy", reason="excite needs the identify extra")
    base = ["excite", "ur5", "--iterations", "0", "--rate", "50", "--harmonics", "2"]
    out = tmp_path / "bare.csv"
    assert main([*base, "--period", "2", "--ramp", "0", "-o", str(out)]) == 0
    span, count = _csv_span(out)
    assert count == 100 and span == pytest.approx(2 - 1 / 50)         # one period, no ramp: 2 s at 50 Hz
    assert "--duration" not in capsys.readouterr().err
    ramped = tmp_path / "ramped.csv"
    assert main([*base, "--period", "2", "--ramp", "1", "-o", str(ramped), "--json"]) == 0
    import json
    rep = json.loads(capsys.readouterr().out)
    assert rep["period"] == 2 and rep["duration"] == 4                 # ramp + period + ramp
    assert _csv_span(ramped)[0] == pytest.approx(4, abs=1 / 50)
    old = tmp_path / "old.csv"
    assert main([*base, "--duration", "2", "--ramp", "1", "-o", str(old)]) == 0
    err = capsys.readouterr().err
    assert "--duration is deprecated" in err and "(2 s)" in err and "(4 s with the ramps)" in err
    assert np.array_equal(np.loadtxt(old, delimiter=",", skiprows=1), np.loadtxt(ramped, delimiter=",", skiprows=1))
    assert main([*base, "--duration", "2", "--period", "2", "-o", str(old)]) == 2
    from manipdyn.cli import build_parser
    sub = build_parser()._subparsers._group_actions[0].choices["excite"]
    helps = {a.option_strings[0]: a.help for a in sub._actions if a.option_strings}
    assert "period" in helps["--period"] and "ramp + period + ramp" in helps["--period"]
    assert helps["--duration"].startswith("deprecated")


# -- item 13: arm.with_payload on every kind of arm; the old name still works, and warns ---------
PAYLOAD_I = np.array([[0.010, 0.001, -0.002], [0.001, 0.012, 0.0005], [-0.002, 0.0005, 0.008]])


@pytest.mark.parametrize("spec, tip", [("erd:ur5_robot", "tool0"), ("erd:panda", "panda_hand"), ("puma560", None)])
def test_item13_with_payload_on_every_arm(spec, tip):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.ModelNoteWarning)
        arm = md.load(spec, tip=tip) if tip else md.load(spec)
    com = np.array([0.01, 0.02, 0.05])
    heavy = arm.with_payload(2.0, com, PAYLOAD_I)
    assert type(heavy) is type(arm) and heavy.name == f"{arm.name}+2kg"
    rng = np.random.default_rng(0)
    q = arm.random_state(rng, 4)
    qd, qdd = rng.normal(size=(4, arm.n)), rng.normal(size=(4, arm.n))
    # the two engines read the new arm alike (the URDF text Pinocchio reads, the chain the trace form reads)
    np.testing.assert_allclose(heavy.lagrange.inverse_dynamics(q, qd, qdd), heavy.pinocchio.inverse_dynamics(q, qd, qdd),
                               atol=1e-11)                     # measured: <= 5e-14 N m on these arms
    # static check against the unloaded arm's own Jacobian: the payload's weight at its COM
    for qk in q:
        T, Jt = arm.fkine(qk), arm.jacobian(qk)
        r = T[:3, :3] @ com
        Jp = Jt[:3] + np.stack([np.cross(Jt[3:, j], r) for j in range(arm.n)], axis=1)
        np.testing.assert_allclose(heavy.gravity_torque(qk) - arm.gravity_torque(qk), -Jp.T @ (2.0 * arm.gravity),
                                   atol=1e-12)                 # measured: <= 1.1e-14 N m
    if isinstance(arm, md.URDFArm):                            # the payload is in the text: a file keeps it
        from manipdyn.formats.urdf.reader import load_urdf

        back = load_urdf(heavy.urdf_text, tip=heavy.tip)
        np.testing.assert_array_equal(back.mass_matrix(q), heavy.mass_matrix(q))
    import manipdyn.control as control

    with pytest.warns(DeprecationWarning, match="arm.with_payload"):
        old = control.with_payload(arm, 2.0, com, PAYLOAD_I)
    np.testing.assert_array_equal(old.inverse_dynamics(q, qd, qdd), heavy.inverse_dynamics(q, qd, qdd))


# -- item 14: a URDF written from an erd:panda-route model loads with the tip it was read with ----
def test_item14_written_urdf_keeps_the_tip_by_name(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.ModelNoteWarning)
        arm = md.load("erd:panda", tip="panda_hand")
        md.save(arm, tmp_path / "panda_route.toml")              # the model file an identification writes
        model = md.load(tmp_path / "panda_route.toml")
    assert model.tip == "panda_hand"
    assert main(["urdf", str(tmp_path / "panda_route.toml"), str(tmp_path)]) == 0
    written = next(p for p in tmp_path.glob("*.urdf"))
    text = written.read_text(encoding="utf-8")
    assert "Tool frame (fkine, jacobian(frame='tool')): link 'panda_hand'" in text
    back = md.load(written, tip="panda_hand")                    # the tip it was fitted with
    q = arm.random_state(np.random.default_rng(1), 3)
    np.testing.assert_allclose(back.fkine(q), arm.fkine(q), atol=1e-12)        # measured: 4e-16
    np.testing.assert_allclose(back.mass_matrix(q), arm.mass_matrix(q), atol=1e-12)


def test_item14_dh_arms_keep_their_tool_link():
    text = md.to_urdf(md.load("ur5"))
    assert '<link name="tool"/>' in text and "Tool frame" not in text  # the bundled urdf/ files are unchanged


# -- item 16: manipdyn mjcf measures MuJoCo's forward dynamics where frictionloss holds Coulomb ---
def _ur5_with_coulomb(tmp_path):
    ur5 = md.load("ur5")
    coulomb = np.array([3.0, 3.0, 2.0, 1.0, 1.0, 1.0])
    law = md.Friction(viscous=np.full(6, 0.5), coulomb=coulomb, smoothing=0.01)
    md.save(md.Manipulator(ur5.links, convention=ur5.convention, name="ur5_fric", friction=law),
            tmp_path / "ur5_fric.toml")
    return tmp_path / "ur5_fric.toml", coulomb


def test_item16_mjcf_prints_the_measured_forward_dynamics_difference(tmp_path, capsys):
    pytest.importorskip("mujoco")
    import re

    model, coulomb = _ur5_with_coulomb(tmp_path)
    assert main(["mjcf", str(model), str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "not MuJoCo's forward dynamics" in out             # the formula line no longer passes for the dynamics
    line = next(x for x in out.splitlines() if "frictionloss, measured" in x)
    torque = line.split("M (qacc - qdd), N m or N: ")[1].split(";")[0]
    diff = np.array([float(v) for v in re.findall(r"joint\d (\S+?)(?:,|$)", torque)])
    assert diff.shape == (6,)
    assert diff.max() > 1e-3                                    # a soft constraint: not 0
    # MuJoCo's frictionloss force lies between 0 and the level, so its deficit cannot exceed the level
    assert np.all(diff <= coulomb * (1 + 1e-9))
    text = (tmp_path / "out" / "ur5_fric.xml").read_text(encoding="utf-8")
    assert "not measured here" in text                          # the file's comment says it plainly


def test_item16_without_mujoco_it_says_not_measured(tmp_path, capsys, monkeypatch):
    import manipdyn.engines.mujoco as mjpkg

    model, _ = _ur5_with_coulomb(tmp_path)
    monkeypatch.setattr(mjpkg, "available", lambda: False)
    assert main(["mjcf", str(model), str(tmp_path / "out")]) == 0
    assert "forward dynamics on this file are not measured" in capsys.readouterr().out
