"""The fast path's derivatives with a friction law (issue 34 item 4): the law's own numbers, fast.

:class:`manipdyn.model.friction_jacobian.SingleStateFriction` is the friction
law at one velocity, with its constants folded in; the Pinocchio engine's
single-state derivatives use it, and a law without coupled rotors runs ABA's
derivatives on ``tau - F(qd)`` instead of the drive path's CRBA, inverse and RNEA
derivatives.  Checked here against the law itself (:meth:`Friction.torque`,
:meth:`Friction.derivative`), against the trace form, and single state against
batch.  Nothing about time is asserted (benchmarks/bench_derivatives.py
measures it).

Tolerances: none for a motor-side plan against the law (the same array
operations in the same order: the same bits), 1e-14 of the largest entry for
a joint-side one (a loop over floats, the sigmoid through tanh); the cross-check's 1e-9 for the engines against
each other; 1e-12 relative for single states against batch rows (a batch's
velocities pass through a matrix product of another shape, a few ulp).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.check.crosscheck import TOLERANCE, draw_states
from manipdyn.model.friction import Friction
from manipdyn.model.friction_jacobian import SingleStateFriction
from tests.arms import random_arm

pytest.importorskip("pinocchio", reason="the fast path is Pinocchio's: pip install 'manipdyn[fast]'")

N = 5


def _laws(rng):
    return {
        "viscous": Friction(viscous=rng.random(N)),
        "viscous+coulomb smooth": Friction(viscous=rng.random(N), coulomb=rng.random(N), smoothing=0.05),
        "coulomb sharp+offset": Friction(viscous=rng.random(N), coulomb=rng.random(N), smoothing=0.0,
                                         offset=rng.normal(size=N)),
        "sigmoid": Friction(sigmoid_A=rng.random(N), sigmoid_alpha=1 + 50 * rng.random(N),
                            sigmoid_p3=0.1 * rng.normal(size=N)),
        "sigmoid+viscous motor": Friction(viscous=1e-3 * rng.random(N), sigmoid_A=1e-2 * rng.random(N),
                                          sigmoid_alpha=1 + 5 * rng.random(N), sigmoid_p3=0.1 * rng.normal(size=N),
                                          side="motor"),
        "asymmetric motor": Friction(coulomb_pos=rng.random(N), coulomb_neg=rng.random(N), side="motor",
                                     smoothing=0.5),
        "stribeck deadband": Friction(coulomb=rng.random(N), stribeck_level=rng.random(N), smoothing=0.02,
                                      stribeck_velocity=0.1 + rng.random(N), deadband=0.05),
    }


LAWS = list(_laws(np.random.default_rng(0)))


def _transmission(coupled: bool, G=(50.0, -80.0, 100.0, 30.0, 20.0)):
    return md.Transmission.from_gear_ratios(G, coupling=[[N, N - 1, 32.0]] if coupled else [])


@pytest.mark.parametrize("coupled", [False, True], ids=["diagonal", "coupled"])
@pytest.mark.parametrize("name", LAWS)
def test_single_state_plan_is_the_law(name, coupled):
    rng = np.random.default_rng(1)
    law = _laws(np.random.default_rng(0))[name]
    tr = _transmission(coupled)
    plan = SingleStateFriction(law, tr)
    # velocities on both sides of the kinks and the sigmoid's shift, and exactly zero
    for qd in [np.zeros(N), *(s * rng.normal(size=N) for s in (1e-3, 0.05, 1.0, 30.0))]:
        F, J = plan(qd)
        Fr, Jr = law.torque(qd, tr), law.derivative(qd, tr)
        assert F.shape == (N,) and J.shape in ((N,), (N, N))
        Jfull = np.diag(J) if J.ndim == 1 else J
        assert J.ndim == 2 or law.side == "joint"          # a diagonal only where dF/dqd is diagonal
        if plan.floats is None:
            # the law's own array operations in its order: the same bits
            np.testing.assert_array_equal(F, Fr)
            np.testing.assert_array_equal(Jfull, Jr)
        else:
            # joint side, one loop over floats (the sigmoid through tanh): a few ulp of the largest entry
            np.testing.assert_allclose(F, Fr, rtol=0, atol=1e-14 * max(1.0, np.abs(Fr).max()))
            np.testing.assert_allclose(Jfull, Jr, rtol=0, atol=1e-14 * max(1.0, np.abs(Jr).max()))


def test_a_motor_side_plan_needs_the_transmission():
    law = _laws(np.random.default_rng(0))["sigmoid+viscous motor"]
    with pytest.raises(md.ModelError, match="motor-side law needs the transmission"):
        SingleStateFriction(law, None)


def _arm(name, coupled):
    base = random_arm(3, n=N, rotors=True)
    law = _laws(np.random.default_rng(0))[name]
    tr = _transmission(coupled, [l.gear_ratio for l in base.links])
    return md.Manipulator(base.links, base.convention, transmission=tr, friction=law,
                          name=name)


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(b)))))


@pytest.mark.parametrize("coupled", [False, True], ids=["diagonal", "coupled"])
@pytest.mark.parametrize("name", LAWS)
def test_fast_path_derivatives_with_a_law_match_the_trace_form_single_and_batch(name, coupled):
    arm = _arm(name, coupled)
    P, L = arm.pinocchio, arm.lagrange
    q, qd, qdd = draw_states(arm, 4, seed=2)
    tau = L.inverse_dynamics(q, qd, qdd)
    inv_b, fwd_b = P.inverse_dynamics_derivatives(q, qd, qdd), P.forward_dynamics_derivatives(q, qd, tau)
    inv_l, fwd_l = L.inverse_dynamics_derivatives(q, qd, qdd), L.forward_dynamics_derivatives(q, qd, tau)
    for x, y in zip(inv_b + fwd_b, inv_l + fwd_l):
        assert _rel(x, y) <= TOLERANCE, _rel(x, y)
    for k in range(len(q)):                        # the single-state shortcut: the batch's numbers
        for x, y in zip(P.inverse_dynamics_derivatives(q[k], qd[k], qdd[k]) + P.forward_dynamics_derivatives(
                q[k], qd[k], tau[k]), [a[k] for a in inv_b + fwd_b]):
            np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(y).max()))
    # the friction really is in dqdd/dqd: without it the answer moves by far more than the tolerance
    J = arm.friction_model.derivative(qd[0], arm.transmission)
    assert _rel(fwd_b[1][0] + fwd_b[2][0] @ J, fwd_b[1][0]) > 1e3 * TOLERANCE or not np.any(J)


def test_bundled_panda_single_state_derivatives_match_the_trace_form():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        arm = md.load("panda")
    assert arm.friction_model is not None and "sigmoid" in arm.friction_model.terms
    q, qd, qdd = draw_states(arm, 3, seed=9)
    tau = arm.lagrange.inverse_dynamics(q, qd, qdd)
    for k in range(3):
        got = (arm.pinocchio.inverse_dynamics_derivatives(q[k], qd[k], qdd[k])
               + arm.pinocchio.forward_dynamics_derivatives(q[k], qd[k], tau[k]))
        ref = (arm.lagrange.inverse_dynamics_derivatives(q[k], qd[k], qdd[k])
               + arm.lagrange.forward_dynamics_derivatives(q[k], qd[k], tau[k]))
        for x, y in zip(got, ref):
            assert _rel(x, y) <= TOLERANCE, _rel(x, y)


@pytest.mark.parametrize("name", LAWS)
def test_the_jacobian_alone_is_the_jacobian_of_the_call(name):
    law = _laws(np.random.default_rng(0))[name]
    plan = SingleStateFriction(law, _transmission(True))
    for qd in np.random.default_rng(5).normal(size=(4, N)) * [[0.01], [0.1], [1.0], [10.0]]:
        np.testing.assert_array_equal(plan.jacobian(qd), plan(qd)[1])


def test_the_benchmarks_print_a_target_and_a_verdict_per_row():
    """benchmarks/bench_derivatives.py and fast_path_guards.py (issue 34): each row carries its
    target and a verdict; no time is asserted, only that the verdict follows the numbers."""
    import sys
    from pathlib import Path

    root = str(Path(__file__).resolve().parents[1])
    if root not in sys.path:
        sys.path.insert(0, root)
    from benchmarks import bench_derivatives as bd
    from benchmarks import fast_path_guards as fg

    r = bd.measure("panda", batch=3, rounds=1, target_s=0.0002)
    assert r["friction"] and r["inv"]["target"] == r["fwd"]["target"] == bd.TARGET_FRICTION
    assert r["grav"]["target"] == bd.TARGET_FAST
    for k in ("inv", "fwd", "grav"):
        assert r[k]["verdict"] == bd.verdict(r[k])
        # the checked call's own floor and the unchecked call are timed beside it (issue 34)
        assert r[k]["check_floor"] > 0 and r[k]["unchecked"] > 0
    assert bd.verdict({"ratio": 1.6, "best_ratio": 1.55, "target": 1.5, "check_floor": 1.52}) == "floor"
    assert bd.verdict({"ratio": 1.6, "best_ratio": 1.55, "target": 1.5, "check_floor": 1.45}) == "OVER"
    assert bd.verdict({"ratio": 1.9, "best_ratio": 1.8, "target": 2.0}) == "ok"
    assert bd.verdict({"ratio": 2.1, "best_ratio": 1.9, "target": 2.0}) == "ok (best)"
    assert bd.verdict({"ratio": 2.1, "best_ratio": 2.05, "target": 2.0}) == "OVER"
    assert fg.verdict(1.4, 1.3, 1.2) == "ok" and fg.verdict(1.6, 1.45, 1.2) == "ok (best)"
    assert fg.verdict(1.6, 1.55, 1.2) == "OVER" and fg.verdict(1.7, 1.6, 1.55) == "floor"
