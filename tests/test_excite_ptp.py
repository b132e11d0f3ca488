"""Issue 45 item 3: ``manipdyn excite --ptp N``, a point-to-point run through N postures with rests.

It rests (velocity and acceleration exactly zero, the posture held, over every rest), keeps the limits
the Fourier design keeps, is smooth (velocity and acceleration continuous: their steps shrink with the
sample period), is the same for the same seed, and is written in the file ``synthesize`` reads.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main
from manipdyn.formats.logs.trajectory import read_trajectory
from manipdyn.identification import point_to_point
from manipdyn.identification.experiments.trajectory import DEFAULT_AMAX, DEFAULT_VMAX

from common import err_line


def _excite(tmp_path, name, *extra):
    out = tmp_path / name
    rc = main(["excite", "ur5", "--ptp", "4", "--rest", "0.5", "--rate", "50", "-o", str(out), *extra])
    assert rc == 0
    return out


def test_excite_ptp_writes_a_run_that_rests_between_moves(tmp_path, capsys):
    path = _excite(tmp_path, "ptp.csv", "--json")
    report = json.loads(capsys.readouterr().out)
    tr = read_trajectory(path, 6)                                  # synthesize's reader: the excite format
    still = np.all(tr.qd == 0, axis=1) & np.all(tr.qdd == 0, axis=1)
    # runs of samples with every joint still: the start and one per posture, each at least the rest long
    edges = np.flatnonzero(np.diff(np.concatenate(([0], still.astype(int), [0]))))
    runs = list(zip(edges[::2], edges[1::2]))
    assert len(runs) == 4 + 1
    for a, b in runs:
        assert tr.t[b - 1] - tr.t[a] >= 0.5 - 1e-9                # the rest's length, 25 sample periods
        assert np.all(tr.q[a:b] == tr.q[a])                         # held, not drifting
    # four distinct postures, and the moves between them move every joint (synchronised moves)
    held = np.array([tr.q[a] for a, _ in runs])
    assert np.all(np.abs(np.diff(held, axis=0)) > 0)
    assert report["postures"] == 4 and len(report["moves"]) == 4
    assert 0 < report["fraction_at_rest"] < 1
    # the base regressor over the run is full rank: the moves and the held postures excite every base parameter
    assert report["n_base"] == 36 and 1 < report["condition_number"] < 1e4


@pytest.mark.parametrize("limits", [(), ("--vmax", "0.8", "--amax", "2")])
def test_excite_ptp_keeps_the_limits(tmp_path, limits):
    arm = md.load("ur5")
    tr = read_trajectory(_excite(tmp_path, "lim.csv", *limits), 6)
    vmax = float(limits[1]) if limits else DEFAULT_VMAX["revolute"]
    amax = float(limits[3]) if limits else DEFAULT_AMAX["revolute"]
    lo, hi = arm.qlim[:, 0], arm.qlim[:, 1]
    span = hi - lo
    assert np.all(tr.q >= lo + 0.05 * span) and np.all(tr.q <= hi - 0.05 * span)   # the 5 % margin
    # within the limits, and using them (the moves are as short as they allow): the peak of the fastest
    # joint is within 2 % of a limit on every move (a sample falls within 1 / 50 s of the peak)
    assert np.abs(tr.qd).max() <= vmax * (1 + 1e-9) and np.abs(tr.qdd).max() <= amax * (1 + 1e-9)
    assert max(np.abs(tr.qd).max() / vmax, np.abs(tr.qdd).max() / amax) > 0.98


def test_excite_ptp_is_smooth():
    """Continuous velocity and acceleration: the largest step between samples shrinks with the sample
    period (a jump would stay the jump).  By the mean value theorem the velocity's step is at most
    amax / rate; the septic profile's jerk is bounded too, so the acceleration's step is O(1 / rate)."""
    arm = md.load("panda")
    steps = {}
    for rate in (100.0, 1000.0):
        run = point_to_point(arm, 3, rest=0.2, rate=rate, seed=3)
        steps[rate] = (np.abs(np.diff(run.qd, axis=0)).max(), np.abs(np.diff(run.qdd, axis=0)).max())
        assert steps[rate][0] <= DEFAULT_AMAX["revolute"] / rate * (1 + 1e-9)
        # the positions agree with the velocities (trapezoid rule, error O(1 / rate^2))
        mid = 0.5 * (run.qd[1:] + run.qd[:-1]) / rate
        assert np.abs(np.diff(run.q, axis=0) - mid).max() < 1e-3 * (100.0 / rate) ** 2
    # tenfold rate: the acceleration's largest step tenfold smaller (within 20 %: the moves' lengths are
    # rounded to whole samples, so they differ slightly between the rates)
    assert steps[1000.0][1] < 0.12 * steps[100.0][1]
    assert steps[1000.0][0] < 0.12 * steps[100.0][0]


def test_excite_ptp_is_deterministic_by_seed(tmp_path):
    a = _excite(tmp_path, "a.csv", "--seed", "7").read_bytes()
    b = _excite(tmp_path, "b.csv", "--seed", "7").read_bytes()
    c = _excite(tmp_path, "c.csv", "--seed", "8").read_bytes()
    assert a == b
    assert a != c
    arm = md.load("ur5")
    p7, p8 = point_to_point(arm, 4, seed=7).postures, point_to_point(arm, 4, seed=8).postures
    assert np.array_equal(p7[0], p8[0]) and not np.allclose(p7[1:], p8[1:])   # same start, other postures


def test_postures_spread_over_the_limits():
    """The greedy maximin postures are farther apart than as many random draws, seed by seed."""
    arm = md.load("panda")
    lo, hi = arm.qlim[:, 0], arm.qlim[:, 1]
    for seed in range(5):
        P = point_to_point(arm, 6, seed=seed).postures
        rnd = np.vstack([P[0], np.random.default_rng(seed).uniform(lo, hi, (6, arm.n))])

        def closest(X):
            z = (X - lo) / (hi - lo)
            d = np.linalg.norm(z[:, None] - z[None], axis=2)
            return d[np.triu_indices(len(X), 1)].min()

        assert closest(P) > closest(rnd)


@pytest.mark.parametrize("n", ["0", "-3", "1000000000000", "1001"])
def test_excite_ptp_refuses_a_bad_count(tmp_path, capsys, n):
    out = tmp_path / "bad.csv"
    assert main(["excite", "ur5", f"--ptp={n}", "-o", str(out)]) == 2
    line = err_line(capsys)
    assert "--ptp" in line and "postures from 1 to" in line and n in line
    assert not out.exists()


@pytest.mark.parametrize("argv, named", [
    (["--ptp", "3", "--harmonics", "4"], "--harmonics"),
    (["--ptp", "3", "--period", "4"], "--period"),
    (["--rest", "1"], "--rest"),
    (["--ptp", "3", "--rest", "-1"], "--rest"),
    (["--ptp", "3", "--rest", "0.001"], "--rest"),
    (["--ptp", "1000", "--rest", "5"], "--ptp"),                     # over the samples' limit
])
def test_excite_ptp_refuses_options_that_do_not_apply(tmp_path, capsys, argv, named):
    assert main(["excite", "ur5", "-o", str(tmp_path / "x.csv"), *argv]) == 2
    assert err_line(capsys).startswith(f"manipdyn excite: error: {named}")


def test_a_move_takes_some_samples_however_high_the_limits():
    """Limits far beyond the moves' needs would make each move one sample (a jump between postures with
    zero velocity on both sides); it takes MIN_MOVE_SAMPLES samples instead, and still moves."""
    from manipdyn.identification.experiments.ptp import MIN_MOVE_SAMPLES

    run = point_to_point(md.load("ur5"), 3, rest=0.1, rate=100.0, vmax=1e6, amax=1e6)
    for a, b in run.moves:
        inside = (run.t > a + 1e-9) & (run.t < b - 1e-9)
        assert inside.sum() == MIN_MOVE_SAMPLES - 1 and np.all(np.any(run.qd[inside] != 0, axis=1))


def test_limits_near_zero_are_refused_not_overflowed(tmp_path, capsys):
    assert main(["excite", "ur5", "--ptp", "2", "--vmax", "1e-300", "-o", str(tmp_path / "x.csv")]) == 2
    assert "MAX_EXCITATION_SAMPLES" in err_line(capsys)
