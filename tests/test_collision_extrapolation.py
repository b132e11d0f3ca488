"""Collision thresholds that widen where the state leaves the fit data (issue 45 item 4;
manipdyn/control/collision/extrapolation.py): ``T_j sqrt((1 + g_j u) / (1 + g_j))``, the record, the choice of ``g``, the events
against per-sample thresholds, and a refusal where the model has no leverage reference."""

from __future__ import annotations

import numpy as np
import pytest

import manipdyn as md
from manipdyn.control.collision.events import detect_events
from manipdyn.control.collision.extrapolation import acceleration, choose_leverage_gain, threshold_levels
from manipdyn.identification.uncertainty.thresholds import CollisionThresholds, fit_thresholds, leverage_factor

DT = 0.008


def _record(T, g=None):
    n = len(T)
    return CollisionThresholds(np.asarray(T, float), 1.0, 100.0, 0.005, 0.5, 0.1, np.zeros(n), np.zeros(n),
                               np.asarray(T, float) / 2, "test", 20.0, g)


def test_the_record_keeps_its_gain_and_the_levels_follow_the_formula():
    thr = _record([2.0, 1.0], [0.5, 0.0])
    u = np.array([[0.0, 3.0], [4.0, 9.0]])
    # threshold is the level at u = 1 (a typical fitted sample): T sqrt((1 + g u) / (1 + g))
    assert np.allclose(thr.levels(u), [[2.0 / np.sqrt(1.5), 1.0], [2.0 * np.sqrt(3.0 / 1.5), 1.0]])
    assert np.allclose(thr.levels(np.ones((1, 2))), thr.threshold)
    back = CollisionThresholds.from_dict(thr.to_dict(), 2, "test")
    assert np.array_equal(back.leverage_gain, [0.5, 0.0]) and back.scales_with_leverage
    # every gain 0: the constant thresholds, nothing stored
    assert _record([2.0, 1.0], [0.0, 0.0]).leverage_gain is None
    assert "leverage_gain" not in _record([2.0, 1.0], [0.0, 0.0]).to_dict()
    with pytest.raises(md.ModelError, match="leverage_gain"):
        _record([2.0, 1.0], [-1.0, 0.0])
    with pytest.raises(md.ModelError, match="leverage_gain"):
        _record([2.0, 1.0], [1.0])


def test_the_gain_grows_only_where_the_held_out_error_grows_with_the_leverage():
    """Joint 1's held-out error grows as sqrt(1 + 3 u), joint 2's does not: g > 0 on joint 1 only, and joint 1's
    held-out mean threshold falls by more than 5 %."""
    rng = np.random.default_rng(0)
    N = 40000
    u = np.column_stack([np.where((np.arange(N) // 2000) % 5 == 0, 30.0, 0.3), np.full(N, 1.0)])
    u[:, 1] = u[:, 0]                                        # the same states, joint 2's error does not care
    e = rng.normal(size=(N, 2))
    r = np.column_stack([e[:, 0] * np.sqrt(1 + 3.0 * u[:, 0]), e[:, 1]])

    def record_at(g):
        return fit_thresholds(r / leverage_factor(np.full(2, g), u), DT, 1.0, gain=100.0, source="held out")

    thr = choose_leverage_gain(record_at, [u])
    assert thr.leverage_gain is not None and thr.leverage_gain[0] > 0 and thr.leverage_gain[1] == 0, thr.leverage_gain
    const = record_at(0.0)
    assert np.mean(thr.levels(u)[:, 0]) < 0.95 * const.threshold[0]
    assert thr.threshold[1] == const.threshold[1]
    assert "leverage ratio" in thr.source
    # none of the joints' errors care: the constant record itself
    flat = choose_leverage_gain(lambda g: fit_thresholds(e / leverage_factor(np.full(2, g), u), DT, 1.0, gain=100.0),
                                [u])
    assert flat.leverage_gain is None


def test_events_are_read_against_the_thresholds_of_each_sample():
    """A residual of 3 N m on joint 1 crosses T sqrt(1 / 2) = 2.12 (T = 3 at u = 1, g = 1) where u = 0, and not
    T sqrt(5 / 2) = 4.74 where u = 4."""
    arm = md.load("ur5")
    t = np.arange(400) * DT
    r = np.zeros((400, 6))
    r[100:150, 0] = 3.0
    r[250:300, 0] = 3.0
    u = np.zeros((400, 6))
    u[200:, 0] = 4.0
    thr = _record(np.full(6, 3.0), [1.0, 0, 0, 0, 0, 0])
    ev = detect_events(arm, t, np.zeros((400, 6)), r, thr.levels(u), 0.005, 0.5, wrench=False)
    assert [round(e.onset, 3) for e in ev] == [round(t[100], 3)]
    assert ev[0].peak_ratio == pytest.approx(3.0 / (3.0 * np.sqrt(0.5)))


def test_a_model_without_a_leverage_reference_is_refused_where_the_thresholds_scale():
    arm = md.load("ur5")
    q, qd = np.zeros((50, 6)), np.zeros((50, 6))
    T, u = threshold_levels(_record(np.ones(6)), arm, q, qd, DT)
    assert u is None and np.array_equal(T, np.ones(6))
    with pytest.raises(md.ModelError, match="leverage reference"):
        threshold_levels(_record(np.ones(6), [1.0] * 6), arm, q, qd, DT)


def test_the_acceleration_is_the_smoothed_derivative():
    t = np.arange(500) * DT
    qd = np.column_stack([np.sin(t), t**2])
    qdd = acceleration(qd, DT)
    assert np.allclose(qdd[20:-20], np.column_stack([np.cos(t), 2 * t])[20:-20], atol=1e-3)
    assert acceleration(qd[:3], DT).shape == (3, 2)
