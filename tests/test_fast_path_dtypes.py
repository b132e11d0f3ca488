"""The single-call shortcuts take only what Pinocchio reads right; the unchecked view matches them.

The shortcuts in manipdyn/engines/pinocchio/engine.py pass arrays straight to
Pinocchio and read finiteness off the answer.  These tests hold them to that:
every other dtype (big-endian float64 first: eigenpy reads its bytes as
little-endian, a silently wrong answer) goes down the general path and gives
the native answer; NaN and inf in *every* entry of every argument are refused
by name, on DH arms (revolute, prismatic) and a URDF arm.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

import manipdyn as md

import arms

CALLS = {
    "mass_matrix": ("q",),
    "coriolis_torque": ("q", "qd"),
    "gravity_torque": ("q",),
    "inverse_dynamics": ("q", "qd", "qdd"),
    "forward_dynamics": ("q", "qd", "tau"),
}


def _arms():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        puma = md.load("puma560")
        stanford = md.load("stanford")                  # a prismatic joint
        urdf = md.load(md.to_urdf(md.load("ur5")))        # read back from URDF text
    return {"puma560": puma, "stanford": stanford, "ur5-urdf": urdf, "random-P": arms.random_arm(3, n=6)}


ARMS = _arms()


def _args(arm, names, seed=0):
    rng = np.random.default_rng(seed)
    out = {}
    for nm in names:
        out[nm] = arm.random_state(rng) if nm == "q" else rng.uniform(-1.0, 1.0, arm.n)
    return out


@pytest.mark.parametrize("arm_name", sorted(ARMS))
@pytest.mark.parametrize("method", sorted(CALLS))
def test_nan_and_inf_in_every_entry_are_refused_by_name(arm_name, method):
    arm = ARMS[arm_name]
    names = CALLS[method]
    f = getattr(arm, method)
    for target in names:
        for i in range(arm.n):
            for bad in (np.nan, np.inf, -np.inf):
                args = _args(arm, names)
                args[target][i] = bad
                with pytest.raises(md.StateError, match=rf"^{target}: entry {i} is {bad!r}"):
                    f(*args.values())


@pytest.mark.parametrize("method", sorted(CALLS))
@pytest.mark.parametrize("convert", [
    pytest.param(lambda x: x.astype(">f8"), id="big-endian"),
    pytest.param(lambda x: np.repeat(x, 2)[::2], id="strided"),
    pytest.param(lambda x: x[::-1].copy()[::-1], id="negative-stride"),
    pytest.param(lambda x: np.asfortranarray(x), id="fortran"),
    pytest.param(lambda x: x.tolist(), id="list"),
])
def test_other_layouts_and_byte_orders_give_the_native_answer(method, convert):
    arm = ARMS["puma560"]
    names = CALLS[method]
    args = _args(arm, names, seed=4)
    native = getattr(arm, method)(*args.values())
    other = getattr(arm, method)(*[convert(a) for a in args.values()])
    np.testing.assert_array_equal(other, native)
    assert other.dtype == np.float64 and other.dtype.isnative


def test_big_endian_really_is_misread_by_raw_pinocchio():
    """Why the shortcut tests ``dtype is float64``: the raw call silently misreads '>f8'."""
    arm = ARMS["puma560"]
    eng = arm.pinocchio
    q = _args(arm, ("q",))["q"]
    wrong = pin.crba(eng.model, eng.data, q.astype(">f8"))
    assert not np.allclose(wrong, arm.mass_matrix(q))
    np.testing.assert_array_equal(arm.mass_matrix(q.astype(">f8")), arm.mass_matrix(q))


@pytest.mark.parametrize("arm_name", sorted(ARMS))
def test_unchecked_view_gives_the_checked_answers(arm_name):
    arm = ARMS[arm_name]
    u = arm.pinocchio.unchecked
    for method, names in CALLS.items():
        args = _args(arm, names, seed=7)
        np.testing.assert_array_equal(getattr(u, method)(*args.values()), getattr(arm, method)(*args.values()))


def test_unchecked_view_applies_friction_like_the_checked_path():
    links = [md.DHLink(a=0.3, mass=1.0, com=(-0.15, 0, 0), inertia=[0.001, 0.01, 0.01],
                       friction_viscous=0.5, friction_coulomb=0.2) for _ in range(2)]
    arm = md.Manipulator(links, convention="standard")
    q, qd, x = np.array([0.1, 0.2]), np.array([1.0, -2.0]), np.array([0.3, 0.4])
    u = arm.pinocchio.unchecked
    np.testing.assert_array_equal(u.inverse_dynamics(q, qd, x), arm.inverse_dynamics(q, qd, x))
    np.testing.assert_array_equal(u.forward_dynamics(q, qd, x), arm.forward_dynamics(q, qd, x))


def test_shortcut_answers_are_new_arrays():
    arm = ARMS["puma560"]
    args = _args(arm, CALLS["inverse_dynamics"])
    a = arm.inverse_dynamics(*args.values())
    b = arm.inverse_dynamics(*args.values())
    assert a is not b and not np.shares_memory(a, b)
