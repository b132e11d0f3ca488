"""Issue 46 item 18: Monte-Carlo defaults sized to the arm, and each diverged run's story.

Before, the default draws were absolute (0.5 N m of Coulomb friction, 0.05 N m of torque noise, a
2 kg payload: the same on every arm), and on the bundled UR5, whose last joint needs 2e-3 N m on the
demo path, every controller erred by about a radian (computed torque 0.96 rad median RMS, PD 1.23).
Now the defaults are fractions of each joint's torque scale (:mod:`manipdyn.control.montecarlo.sizing`),
the old draws are :data:`ABSOLUTE_DEFAULTS` (the same plants, bit for bit), and every diverged run
says what happened to it (:func:`manipdyn.control.montecarlo.diverged.explain`).
"""

from __future__ import annotations

import itertools
import json
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main
from manipdyn.control import montecarlo as mc
from manipdyn.control.montecarlo.distributions import RunDraw, run_rng


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(name)


@pytest.fixture(scope="module")
def ur5_default_report():
    """The guide's UR5 study at its defaults, on 4 runs (20 in the guide: the same first 4 plants)."""
    study = mc.study(_load("ur5"), 4, seed=1, controllers=("pd", "ct", "adaptive", "lqr"))
    return mc.run(study, scheduler="sync")


def test_default_ur5_study_separates_the_controllers(ur5_default_report):
    c = ur5_default_report.controllers
    rms = {k: c[k]["rms_error"]["max"] for k in c}
    # before: computed torque 0.96 rad median, PD 1.23, LQR 0.99, adaptive 0.30 (and 3 LQR runaways
    # in 20): every controller a radian off.  Now: well under a radian, and in the order the
    # controllers' knowledge of the arm predicts (PD knows no gravity, adaptive learns the plant)
    assert all(e["diverged"] == 0 for e in c.values())
    assert rms["ct"] < 0.5 and rms["lqr"] < 0.5
    assert rms["adaptive"] < 0.1 * rms["ct"]
    assert max(rms["ct"], rms["lqr"]) < 0.5 * c["pd"]["rms_error"]["p50"]


def test_default_draws_do_not_dwarf_the_gains(ur5_default_report):
    effect = ur5_default_report.effect()
    # before: 0.5 N m of Coulomb friction held the UR5's joint 6 37.8 rad off at Kp = wn^2 D_66
    assert effect["coulomb_offset"][0] < 0.2 and effect["noise_offset"][0] < 0.02
    text = str(ur5_default_report)
    assert "sized to the arm" in text and "(sized to its joints' torques)" in text
    assert "absolute, not scaled to it" not in text


def test_sized_draws_stay_within_their_fractions_of_each_joint():
    puma = _load("puma560")
    s = mc.study(puma, runs=50, seed=3, duration=2.0)
    z, b = s.sizes(), s.bounds()
    d = s.distributions
    assert (d.payload_rel, d.friction_viscous_rel, d.friction_coulomb_rel, d.torque_noise_rel) == (0.2, 0.1, 0.1, 0.01)
    np.testing.assert_array_equal(b.coulomb, 0.1 * z.torque)
    np.testing.assert_array_equal(b.noise, 0.01 * z.torque)
    np.testing.assert_array_equal(b.viscous, 0.1 * z.torque / z.speed)
    draws = [s.draw(k) for k in range(50)]
    fr = np.array([x.friction for x in draws])
    assert np.all(fr[:, 0] <= b.viscous) and np.all(fr[:, 1] <= b.coulomb) and fr.min() >= 0
    assert max(x.payload_mass for x in draws) <= b.payload_mass
    # the payload bound: at a corner of its box, its torque along the path is 0.2 tau_j on one joint
    # and at most that on the others
    from manipdyn.control.montecarlo.study import _reference_samples
    q, qd, qdd = _reference_samples(s.model, s.duration, s.dt)
    n = puma.n

    def torque(mass, com):
        dr = RunDraw(0, mass, np.array(com, dtype=float), np.ones(n), np.zeros((2, n)), np.zeros(n), np.zeros((1, n)))
        return mc.make_plant(puma, dr).pinocchio.inverse_dynamics(q, qd, qdd)
    base = torque(0.0, (0, 0, 0))
    cx, cy, cz = d.payload_com
    worst = np.zeros(n)
    for sx, sy, h in itertools.product((-1, 1), (-1, 1), (0, 1)):
        worst = np.maximum(worst, np.abs(torque(b.payload_mass, (sx * cx, sy * cy, h * cz)) - base).max(axis=0))
    ratio = worst / z.torque
    assert ratio.max() == pytest.approx(0.2, rel=1e-9) and int(np.argmax(ratio)) + 1 == z.payload_joint


def test_absolute_defaults_are_the_old_plants_bit_for_bit():
    """The draws of the defaults before issue 46, written out as they were drawn then."""
    ur5 = _load("ur5")
    s = mc.study(ur5, runs=3, seed=1, distributions=mc.ABSOLUTE_DEFAULTS, duration=0.5)
    for run in range(3):
        rng = run_rng(1, run)
        mass = 2.0 * rng.random()
        u = rng.uniform(-1.0, 1.0, 2)
        com = np.array([0.05 * u[0], 0.05 * u[1], 0.15 * rng.random()])
        scale = 1.0 + 0.2 * rng.uniform(-1.0, 1.0, 6)
        friction = np.array([0.5, 0.5])[:, None] * rng.random((2, 6))
        q0 = 0.01 * np.where(np.zeros(6, bool), 0.1, 1.0) * rng.standard_normal(6)
        noise = 0.05 * rng.standard_normal((s.steps + 1, 6))
        d = s.draw(run)
        assert d.payload_mass == mass
        for got, want in ((d.payload_com, com), (d.scale, scale), (d.friction, friction), (d.q0_offset, q0),
                          (d.torque_noise, noise)):
            np.testing.assert_array_equal(got, want)


def test_an_absolute_figure_given_means_what_it_says(capsys):
    d = mc.Distributions(friction_coulomb=0.5)                  # old code: 0.5 N m, nothing sized added
    assert d.friction_coulomb == 0.5 and d.friction_coulomb_rel == 0.0 and d.friction_viscous_rel == 0.1
    nominal = mc.Distributions(payload_mass=0, link_scale=0, friction_viscous=0, friction_coulomb=0, q0_offset=0,
                               torque_noise=0)                  # the guide's nominal rows: the plant is the model
    assert not nominal.sized and not nominal.noisy
    both = mc.Distributions(friction_coulomb=0.5, friction_coulomb_rel=0.1)
    z = mc.study(_load("puma560"), 1, distributions=both, duration=0.5).sizes()
    np.testing.assert_array_equal(both.bounds(z).coulomb, 0.5 + 0.1 * z.torque)
    with pytest.raises(ValueError, match="sizes"):
        mc.Distributions().bounds()
    # the command line: an absolute option given, even 0, turns its sized default off
    assert main(["montecarlo", "puma560", "--runs", "1", "--duration", "0.1", "--controllers", "ct", "--scheduler",
                 "sync", "--friction-coulomb", "0", "--torque-noise", "0.05", "--json", "--no-progress"]) == 0
    dist = json.loads(capsys.readouterr().out)["study"]["distributions"]
    assert dist["friction_coulomb"] == 0 and dist["friction_coulomb_rel"] == 0 and dist["torque_noise_rel"] == 0
    assert dist["torque_noise"] == 0.05 and dist["friction_viscous_rel"] == 0.1 and dist["payload_rel"] == 0.2
    with pytest.raises(SystemExit):
        main(["montecarlo", "--help"])
    assert "--friction-coulomb-rel" in capsys.readouterr().out


def test_a_diverged_lqr_run_says_what_happened_to_it(tmp_path):
    ur5 = _load("ur5")
    # the absolute draws (the old defaults): runs 0 and 4 of seed 1 are LQR runaways
    report = mc.run(mc.study(ur5, 5, seed=1, controllers=("lqr",), distributions=mc.ABSOLUTE_DEFAULTS),
                    scheduler="sync")
    whys = {w["run"]: w for w in report.diverged_runs()}
    assert {0, 4} <= set(whys)
    span = np.diff(ur5.qlim, axis=1)[0, 0]
    for run in (0, 4):
        w = whys[run]
        rec = next(r for r in report.per_run if r["run"] == run)
        assert rec["why"]["text"] == w["text"] and rec["cause"] == "runaway"
        # read off the run itself: the joint past its range, when, and how far
        log = report.study.replay(run, "lqr")
        e = np.abs(log.e)
        k = int(np.argmax((e > span).any(axis=1)))
        assert (w["criterion"], w["joint"], w["t"]) == ("range", int(np.argmax(e[k] > span)) + 1, log.t[k])
        assert w["off_path_t"] < w["t"] and w["sampled_loop"] <= 2.0 and w["substeps"] == 1
        assert w["heavier"] > 5 and w["payload_mass"] > 0.5       # an undeclared payload, many times the wrist
        assert "linearisation along the path" in w["text"]
        assert w["text"] in str(report)
    doc = json.loads(report.to_json())
    assert all(r["why"] is None for r in doc["per_run"] if not r["diverged"])
    assert doc["per_run"][0]["why"]["criterion"] == "range"
    page = (tmp_path / "r.html")
    report.report_html(page)
    html = page.read_text(encoding="utf-8")
    assert 'diverged-runs' in html and "study.replay(4, &#x27;lqr&#x27;)" in html
    assert "linearisation along the path" in html


def test_the_guides_ur5_table_is_what_its_commands_give(capsys):
    """docs/guide/montecarlo.md, 'Draws sized to the arm': the two 8-run UR5 studies of its block,
    run here, give the table's medians (printed to 3 significant digits)."""
    import re

    import guide

    text = guide.section("## Draws sized to the arm")
    (block,) = [b.text for b in guide.blocks("sh") if "--runs 8 --seed 1" in b.text]
    rows = {}
    for line in block.strip().splitlines():
        argv = line.split(">")[0].split()[1:]
        assert argv[:2] == ["montecarlo", "ur5"] and "--json" in argv
        assert main([*argv, "--no-progress"]) == 0
        doc = json.loads(capsys.readouterr().out)
        rows["absolute" if "--payload-mass" in argv else "sized"] = doc
    for label, key in (("| sized draws (the defaults) |", "sized"), ("| absolute draws (the defaults before", "absolute")):
        line = next(l for l in text.splitlines() if l.startswith(label))
        said = [float(x) for x in re.findall(r"\|\s*([0-9.]+)\s*(?=\|)", line)]
        got = [rows[key]["controllers"][k]["rms_error"]["p50"] for k in ("pd", "pdg", "ct", "adaptive", "lqr")]
        assert said == [float(f"{g:.3g}") for g in got], (key, said, got)
    lqr = rows["absolute"]["controllers"]["lqr"]
    assert lqr["diverged"] == 2 and lqr["diverged_because"] == {"runaway": 2}
    assert all(e["diverged"] == 0 for e in rows["sized"]["controllers"].values())
    assert "2\nof LQR's 8 runs run away (runs 0 and 4" in text
    assert [r["run"] for r in rows["absolute"]["per_run"] if r["diverged"]] == [0, 4]
