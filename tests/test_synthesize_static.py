"""Issue 45 item 3: ``manipdyn synthesize`` with a truth that has static friction and a Stribeck decay.

A real joint at rest holds a torque within its static band [-Fs, Fs], usually of the last motion's sign;
a synthesized log at rest shows that, not Coulomb's sign(0) = 0.  Moving, friction is Coulomb plus the
Stribeck term, and the ``--truth`` file holds that law.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import manipdyn as md
from manipdyn._support.errors import ModelError
from manipdyn.cli import main
from manipdyn.identification.experiments.static_friction import rest_torque, static_levels, with_static_friction

from common import err_line


@pytest.fixture(scope="module")
def logged(tmp_path_factory):
    d = tmp_path_factory.mktemp("static")
    assert main(["excite", "ur5", "--ptp", "5", "--rest", "0.5", "--rate", "50", "--seed", "2",
                 "-o", str(d / "ptp.csv")]) == 0
    assert main(["synthesize", "ur5", str(d / "ptp.csv"), "-o", str(d / "log.csv"), "--perturb", "--seed", "4",
                 "--noise", "0", "--static-friction", "1.5", "--stribeck-velocity", "0.05",
                 "--truth", str(d / "truth.toml"), "--derivatives", "--json"]) == 0
    return d


def _log(d):
    data = np.loadtxt(d / "log.csv", delimiter=",", skiprows=1)
    return data[:, 0], data[:, 1:7], data[:, 7:13], data[:, 13:19], data[:, 19:25]


def test_at_rest_the_torque_is_the_rigid_one_plus_a_held_friction_of_the_last_motions_sign(logged, capsys):
    t, q, qd, qdd, tau = _log(logged)
    truth = md.load(logged / "truth.toml")
    fs = static_levels(truth)
    fc = np.asarray(truth.friction_model.coulomb)
    assert np.allclose(fs, 1.5 * fc) and np.all(fc > 0)            # Fs = 1.5 x Coulomb, per joint
    off = tau - truth.gravity_torque(q)                              # at rest the rigid torque is gravity's
    checked = 0
    for j in range(6):
        rest = qd[:, j] == 0
        starts = np.flatnonzero(rest & ~np.concatenate(([False], rest[:-1])))
        levels = []
        for s in starts:
            if s == 0:
                continue                                             # no motion before: anywhere in the band
            e = s + np.argmax(~rest[s:]) if np.any(~rest[s:]) else len(rest)
            last = np.sign(qd[s - 1, j])
            held = off[s:e, j]
            assert np.all(held == held[0])                           # one level per rest
            assert abs(held[0]) <= fs[j] * (1 + 1e-9)                 # within the static band
            assert np.sign(held[0]) == last                          # of the last motion's sign
            levels.append(abs(held[0]) / fs[j])
            checked += 1
        assert len(set(np.round(levels, 12))) == len(levels)         # drawn per rest, not one constant
    assert checked >= 6 * 5
    # the Coulomb law alone would give sign(0) = 0 there: the held friction is really there
    still = np.all(qd == 0, axis=1) & (t > 0.6)
    assert np.abs(off[still]).mean(axis=0).min() > 0.05 * fs.min()


def test_moving_the_truth_files_law_is_the_logged_one(logged):
    t, q, qd, qdd, tau = _log(logged)
    truth = md.load(logged / "truth.toml")
    assert truth.friction_model.stribeck_level is not None
    moving = np.all(qd != 0, axis=1)
    assert moving.sum() > 100
    # exact (noise 0): the log's torque moving is the truth file's inverse dynamics, Stribeck included
    assert np.allclose(tau[moving], truth.inverse_dynamics(q[moving], qd[moving], qdd[moving]), rtol=1e-9, atol=1e-9)
    # slowing down, friction rises from Coulomb to the breakaway level: Fc + (Fs - Fc) exp(-(v / vs)^2)
    law = truth.friction_model
    fc, fs = np.asarray(law.coulomb), static_levels(truth)
    for v, share in ((0.01, np.exp(-0.04)), (0.05, np.exp(-1.0)), (0.5, np.exp(-100.0))):
        f = law.torque(np.full((1, 6), v))[0] - law.viscous * v
        assert np.allclose(f, fc + (fs - fc) * share, rtol=1e-12)


def test_the_options_are_recorded(logged):
    desc = md.load(logged / "truth.toml").description
    assert "static friction 1.5 x Coulomb" in desc and "Stribeck" in desc and "velocity 0.05" in desc


def test_json_reports_the_levels(tmp_path, capsys):
    assert main(["excite", "ur5", "--ptp", "1", "--rest", "0.2", "--rate", "50", "-o", str(tmp_path / "p.csv")]) == 0
    capsys.readouterr()
    assert main(["synthesize", "ur5", str(tmp_path / "p.csv"), "-o", str(tmp_path / "l.csv"), "--perturb",
                 "--static-friction", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)["static_friction"]
    assert out["ratio"] == 2 and out["stribeck_velocity"] == 0.05
    assert np.allclose(out["static"], 2 * np.asarray(out["coulomb"]))


@pytest.mark.parametrize("argv, named", [
    (["--static-friction", "0.5"], "--static-friction"),
    (["--static-friction", "nan"], "--static-friction"),
    (["--static-friction", "1.5", "--stribeck-velocity", "0"], "--stribeck-velocity"),
    (["--stribeck-velocity", "0.1"], "--stribeck-velocity"),
])
def test_bad_static_options_are_refused(logged, tmp_path, capsys, argv, named):
    assert main(["synthesize", "ur5", str(logged / "ptp.csv"), "-o", str(tmp_path / "x.csv"), "--perturb", *argv]) == 2
    assert err_line(capsys).startswith(f"manipdyn synthesize: error: {named}")
    assert not (tmp_path / "x.csv").exists()


def test_a_truth_without_coulomb_friction_is_refused(logged, tmp_path, capsys):
    """ur5 itself has no friction: there is no Coulomb level to scale (without --perturb)."""
    assert main(["synthesize", "ur5", str(logged / "ptp.csv"), "-o", str(tmp_path / "x.csv"),
                 "--static-friction", "1.5"]) == 2
    line = err_line(capsys)
    assert "--static-friction" in line and "no joint-side symmetric Coulomb friction" in line
    assert not (tmp_path / "x.csv").exists()


def test_rest_torque_is_seeded_and_bounded():
    rng = np.random.default_rng(0)
    qd = np.repeat(rng.standard_normal((40, 3)), 5, axis=0) * (rng.random((200, 3)) > 0.4)
    fs = np.array([1.0, 2.0, 0.5])
    a, b, c = rest_torque(qd, fs, 1), rest_torque(qd, fs, 1), rest_torque(qd, fs, 2)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert np.all(a[qd != 0] == 0) and np.all(np.abs(a) <= fs)
    with pytest.raises(ModelError, match="ratio"):
        with_static_friction(md.load("ur5"), 0.9)


@pytest.mark.parametrize("argv, named", [(["--static-friction", "1e12"], "--static-friction"),
                                         (["--static-friction", "2", "--stribeck-velocity", "1e-300"],
                                          "--stribeck-velocity")])
def test_absurd_levels_are_refused(logged, tmp_path, capsys, argv, named):
    assert main(["synthesize", "ur5", str(logged / "ptp.csv"), "-o", str(tmp_path / "x.csv"), "--perturb", *argv]) == 2
    assert err_line(capsys).startswith(f"manipdyn synthesize: error: {named}")
