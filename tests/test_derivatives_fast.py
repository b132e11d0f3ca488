"""The Pinocchio engine's single-state derivative shortcuts and their unchecked twins (issue 34 item 4).

``install_derivative_shortcuts`` puts three closures on each engine (the RNEA, ABA and gravity
derivatives of one state) and gives ``engine.unchecked`` the same code without its tests.
Held here to: the unchecked calls give the checked calls' bits; a single state gives the
same bits whichever path it takes (a list goes down the general path); every non-finite
entry of every argument is refused by name, as are batches of the wrong shape and masked
entries; Pinocchio's gravity derivative is a new array (the shortcut does not copy it); and
``pivots_positive``, which lets the ABA shortcut skip its singular-D test, is a true lower
bound of ABA's pivots (Pinocchio's own UDU^T factorisation of D(q) gives the same pivots).
Nothing about time is asserted (benchmarks/bench_derivatives.py measures it).
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

import manipdyn as md
from manipdyn.engines.pinocchio.derivatives import pivots_positive
from manipdyn.model.friction import Friction

import arms

CALLS = {"inverse_dynamics_derivatives": ("q", "qd", "qdd"),
         "forward_dynamics_derivatives": ("q", "qd", "tau"),
         "gravity_derivative": ("q",)}


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(name)


def _with_friction(kind):
    """A random 5-joint arm with rotors and: the links' table, a joint-side law, a motor-side law, or
    a joint-side law with coupled rotors (whose forward derivatives take the drive path)."""
    base = arms.random_arm(3, n=5, rotors=True)
    rng = np.random.default_rng(11)
    if kind == "table":
        import dataclasses
        links = [dataclasses.replace(l, friction_viscous=float(rng.uniform(0.1, 2)),
                                     friction_coulomb=float(rng.uniform(0.1, 1))) for l in base.links]
        return md.Manipulator(links, base.convention, name="table")
    law = {"joint law": Friction(viscous=rng.random(5), coulomb=rng.random(5), smoothing=0.05,
                                 sigmoid_A=rng.random(5), sigmoid_alpha=1 + 20 * rng.random(5),
                                 sigmoid_p3=0.1 * rng.normal(size=5), offset=rng.normal(size=5)),
           "motor law": Friction(viscous=1e-3 * rng.random(5), coulomb=1e-2 * rng.random(5), side="motor"),
           "coupled": Friction(viscous=1e-3 * rng.random(5), sigmoid_A=rng.random(5), sigmoid_alpha=1 + 5 * rng.random(5),
                               sigmoid_p3=0.1 * rng.normal(size=5))}[kind]
    coupling = [[5, 4, 32.0]] if kind == "coupled" else []
    tr = md.Transmission.from_gear_ratios([l.gear_ratio for l in base.links], coupling=coupling)
    return md.Manipulator(base.links, base.convention, transmission=tr, friction=law, name=kind)


ARMS = {"ur5": _load("ur5"), "puma560": _load("puma560"), "panda": _load("panda"), "stanford": _load("stanford"),
        **{k: _with_friction(k) for k in ("table", "joint law", "motor law", "coupled")}}


def _args(arm, names, seed=0):
    rng = np.random.default_rng(seed)
    q, qd, qdd = arm.random_state(rng), rng.uniform(-2, 2, arm.n), rng.uniform(-3, 3, arm.n)
    tau = arm.lagrange.inverse_dynamics(q, qd, qdd)
    return [{"q": q, "qd": qd, "qdd": qdd, "tau": tau}[k] for k in names]


def _same_bits(a, b):
    a, b = (x if isinstance(x, tuple) else (x,) for x in (a, b))
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes()


@pytest.mark.parametrize("arm_name", sorted(ARMS))
@pytest.mark.parametrize("method", sorted(CALLS))
def test_unchecked_derivatives_are_the_checked_bits(arm_name, method):
    arm = ARMS[arm_name]
    P = arm.pinocchio
    for seed in range(3):
        args = _args(arm, CALLS[method], seed)
        _same_bits(getattr(P.unchecked, method)(*args), getattr(P, method)(*args))


@pytest.mark.parametrize("arm_name", sorted(ARMS))
@pytest.mark.parametrize("method", sorted(CALLS))
def test_one_state_gives_the_same_bits_on_either_path(arm_name, method):
    """A list (the general path, validated) and an ndarray (the shortcut): the same numbers, bit for bit."""
    arm = ARMS[arm_name]
    f = getattr(arm.pinocchio, method)
    args = _args(arm, CALLS[method], 5)
    _same_bits(f(*[a.tolist() for a in args]), f(*args))
    _same_bits(f(*[np.repeat(a, 2)[::2] for a in args]), f(*args))       # strided: Pinocchio reads it right


@pytest.mark.parametrize("arm_name", ["ur5", "panda", "joint law"])
@pytest.mark.parametrize("method", sorted(CALLS))
def test_nan_and_inf_in_every_entry_are_refused_by_name(arm_name, method):
    arm = ARMS[arm_name]
    f = getattr(arm.pinocchio, method)
    names = CALLS[method]
    for target, name in enumerate(names):
        for i in range(arm.n):
            for bad in (np.nan, np.inf, -np.inf):
                args = _args(arm, names)
                args[target][i] = bad
                with pytest.raises(md.StateError, match=rf"^{name}: entry {i} is {bad!r}"):
                    f(*args)


@pytest.mark.parametrize("method", sorted(CALLS))
def test_batches_scalars_wrong_lengths_and_masks_take_the_general_path(method):
    arm = ARMS["panda"]
    P = arm.pinocchio
    f = getattr(P, method)
    names = CALLS[method]
    args = _args(arm, names, 2)
    one = f(*args)
    # a batch of one, shape (1, n): the general path's (1, n, n) answers, the single state's numbers
    batch = f(*[a[None] for a in args])
    for x, y in zip(batch if isinstance(batch, tuple) else (batch,), one if isinstance(one, tuple) else (one,)):
        assert x.shape == (1,) + y.shape
        np.testing.assert_allclose(x[0], y, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(y).max()))
    last = names[-1]
    with pytest.raises(md.StateError, match=rf"^{last}: got shape \({arm.n - 1},\)"):
        f(*args[:-1], args[-1][:-1])
    with pytest.raises(md.StateError, match=rf"^{last}: got shape \(\)"):
        f(*args[:-1], np.array(0.5))
    masked = np.ma.masked_array(args[-1], mask=[False] * (arm.n - 1) + [True])
    with pytest.raises(md.StateError, match=rf"^{last}: .*masked"):
        f(*args[:-1], masked)
    # nothing masked: the data is the state
    _same_bits(f(*args[:-1], np.ma.masked_array(args[-1], mask=False)), one)
    # big-endian is converted, never misread
    _same_bits(f(*[a.astype(">f8") for a in args]), one)


def test_huge_finite_states_get_the_general_paths_answer():
    """Entries beyond the shortcut's bound go down the general path: its answer or its overflow error."""
    arm = ARMS["ur5"]
    P = arm.pinocchio
    q, qd, qdd = _args(arm, ("q", "qd", "qdd"))
    big = qdd.copy()
    big[2] = 1e60
    ref = P.inverse_dynamics_derivatives(q.tolist(), qd.tolist(), big.tolist())     # general path
    _same_bits(P.inverse_dynamics_derivatives(q, qd, big), ref)
    huge = qd.copy()
    huge[1] = 1e200
    with pytest.raises(md.StateError, match="overflow"):
        P.inverse_dynamics_derivatives(q, huge, qdd)


def test_gravity_derivative_is_a_new_array_each_call():
    """computeGeneralizedGravityDerivatives returns its result by value, so the shortcut does not copy it:
    an answer must survive the next call and share no memory with it or with pin.Data."""
    P = ARMS["ur5"].pinocchio
    q1, q2 = _args(ARMS["ur5"], ("q",), 1)[0], _args(ARMS["ur5"], ("q",), 2)[0]
    g1 = P.gravity_derivative(q1)
    kept = g1.copy()
    g2 = P.gravity_derivative(q2)
    P.inverse_dynamics_derivatives(q2, q2, q2)
    P.forward_dynamics_derivatives(q2, q2, q2)
    np.testing.assert_array_equal(g1, kept)
    assert not np.shares_memory(g1, g2) and g1.flags.owndata and g1.flags.writeable
    assert not np.array_equal(g1, g2)


def test_forward_answers_share_no_memory_with_each_other_or_the_next_call():
    P = ARMS["panda"].pinocchio
    q, qd, tau = _args(ARMS["panda"], ("q", "qd", "tau"))
    for E in (P, P.unchecked):
        first = E.forward_dynamics_derivatives(q, qd, tau)
        kept = [x.copy() for x in first]
        E.forward_dynamics_derivatives(q + 1, qd, tau)
        E.inverse_dynamics_derivatives(q + 1, qd, tau)
        for x, k in zip(first, kept):
            np.testing.assert_array_equal(x, k)
        assert not any(np.shares_memory(a, b) for i, a in enumerate(first) for b in first[i + 1:])


@pytest.mark.parametrize("name", ["ur5", "puma560", "panda"])
def test_pivots_positive_is_a_lower_bound_of_the_pivots(name):
    """ABA's pivots are the D of Pinocchio's UDU^T factorisation of D(q) (the same Schur complements,
    leaf first); each must be at least body k's moment about its own axis plus its rotor, the
    bound pivots_positive relies on.  1e-9 relative: rounding of a factorisation of a 6..7 x 6..7
    matrix whose entries are O(1..10) (a few hundred ulp), far below any real violation."""
    arm = ARMS[name]
    model = arm.pinocchio.model
    assert pivots_positive(model)
    data = model.createData()
    pin.computeJointJacobians(model, data, pin.neutral(model))
    c = []
    for k in range(1, model.njoints):
        S = np.asarray(pin.getJointJacobian(model, data, k, pin.LOCAL)).reshape(6, -1)[:, k - 1]
        c.append(float(S @ model.inertias[k].matrix() @ S) + float(model.armature[k - 1]))
    c = np.array(c)
    assert np.all(c > 0)
    rng = np.random.default_rng(4)
    for _ in range(50):
        q = arm.random_state(rng)
        pin.crba(model, data, q)
        pin.cholesky.decompose(model, data)
        assert np.all(np.asarray(data.D) >= c * (1 - 1e-9)), (np.asarray(data.D), c)


def test_pivots_positive_refuses_what_it_cannot_bound(tmp_path):
    """A prismatic joint (stanford) and a joint that moves no mass (D singular) keep the singular-D test."""
    from test_cli import NOMASS

    assert not pivots_positive(ARMS["stanford"].pinocchio.model)
    path = tmp_path / "nomass.urdf"
    path.write_text(NOMASS)
    with pytest.warns(md.PhysicalConsistencyWarning):
        arm = md.load(str(path))
    assert not pivots_positive(arm.pinocchio.model)
    with pytest.raises(md.SingularMassMatrixError):
        arm.pinocchio.forward_dynamics_derivatives(np.zeros(2), np.zeros(2), np.ones(2))


def test_the_straight_line_law_is_the_law_minus_the_torque():
    """tau_jacobian_floats(v, t) is (t - F, J) of torque_jacobian_floats, bit for bit, and F, J are the
    law's (1e-14 of the largest entry: tanh for the logistic, as tests/test_derivatives_friction.py)."""
    from manipdyn.model.friction_jacobian import SingleStateFriction

    law = ARMS["joint law"].friction_model
    plan = SingleStateFriction(law)
    rng = np.random.default_rng(8)
    for scale in (1e-3, 0.05, 1.0, 30.0):
        v, t = scale * rng.normal(size=5), rng.normal(size=5)
        F, J = plan.torque_jacobian_floats(v.tolist())
        T, J2 = plan.tau_jacobian_floats(v.tolist(), t.tolist())
        assert J2 == J and plan.jacobian_floats(v.tolist()) == J
        np.testing.assert_array_equal(np.array(T), t - np.array(F))
        Fr, Jr = law.torque(v), law.derivative(v)
        np.testing.assert_allclose(F, Fr, rtol=0, atol=1e-14 * max(1.0, np.abs(Fr).max()))
        np.testing.assert_allclose(np.diag(J), Jr, rtol=0, atol=1e-14 * max(1.0, np.abs(Jr).max()))
