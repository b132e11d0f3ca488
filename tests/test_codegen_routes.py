"""Issue 34, item 2: the generated C's RNEA derivatives from the recursive derivative algorithm.

``manipdyn.engines.c.derivatives`` writes ``d tau / d (q, qd)`` as a recursion over the chain
(Carpentier and Mansard's, derived in ARCHITECTURE.md) and keeps it where it has fewer
operations than the reverse-mode Jacobian of the unrolled RNEA.  Here: the recursion agrees
with the Jacobian it replaces on every kind of arm the model holds (revolute and prismatic
joints, rotors through a coupled transmission, every friction law with its smoothing), at
the accelerations given and at the forward dynamics' own; on the 6- and 7-joint arms it is
the route chosen and is shorter.  The C it becomes is checked against Pinocchio and the
other engines by tests/test_codegen.py and tests/test_codegen_derivatives.py.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from tests.arms import random_arm

pytest.importorskip("casadi", reason="the generated C's graphs need CasADi (pip install -e '.[codegen]')")

from manipdyn.engines.c import source  # noqa: E402  (after the skip: the module needs CasADi)
from manipdyn.engines.c.derivatives import ROUTES, derivative_route  # noqa: E402
from manipdyn.engines.c.graph import ArmGraph  # noqa: E402

# Relative to the largest entry of each Jacobian: both routes are exact derivatives of the same
# float64 dynamics, differing only by rounding in a few hundred operations (seen: below 2e-15).
TOL = 1e-12


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(name)


def _coupled(law: str):
    """A random 4-joint arm with rotors through a coupled (off-diagonal) transmission and a friction law."""
    from tests.test_codegen import _coupled_arm

    return _coupled_arm(law)


def _functions(arm):
    """``{route: casadi.Function (q, qd, qdd, tau) -> (dtau_dq, dtau_dqd at qdd, the same at qdd_x)}``."""
    import casadi as ca

    out = {}
    for route in ROUTES:
        g = ArmGraph(arm)
        num = [float(x) for x in g.pi]
        V = lambda xs: ca.vertcat(*[ca.SX(x) for x in xs])          # noqa: E731
        fr = g.friction(num, g.qd)
        tau = V([a + b + c for a, b, c in zip(g.rnea(num, g.qd, g.qdd), g.rotor_torque(num, g.qdd), fr)])
        # accelerations that are expressions of the inputs, as the forward dynamics' qdd is in
        # ArmGraph.functions: the path by which the ABA derivatives are built
        qdd_x = [0.5 * g.tau_in[k] + ca.sin(g.q[k]) * g.qd[(k + 1) % g.n] for k in range(g.n)]
        _, dq, dv = derivative_route(g, num, tau, fr, route=route)
        _, fq, fv = derivative_route(g, num, tau, fr, qdd=qdd_x, route=route)
        out[route] = ca.Function(route, [g.q, g.qd, g.qdd, g.tau_in], [dq, dv, fq, fv])
    return out


def _assert_routes_agree(arm, samples=4, seed=0):
    fs = _functions(arm)
    rng = np.random.default_rng(seed)
    n = arm.n
    for _ in range(samples):
        x = [rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-3, 3, n), rng.uniform(-20, 20, n)]
        ref = [np.array(m) for m in fs["reverse"](*x)]
        got = [np.array(m) for m in fs["recursive"](*x)]
        for name, a, b in zip(("dtau_dq", "dtau_dqd", "dtau_dq at qdd_x", "dtau_dqd at qdd_x"), got, ref):
            assert np.all(np.isfinite(a)), (arm.name, name)
            err = np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(b)))
            assert err < TOL, (arm.name, name, err)


@pytest.mark.parametrize("name", md.models())
def test_bundled_arms_recursive_equals_reverse_mode(name):
    _assert_routes_agree(_load(name))


@pytest.mark.parametrize("seed", range(0, 40, 3))
def test_random_arms_revolute_and_prismatic_recursive_equals_reverse_mode(seed):
    _assert_routes_agree(random_arm(seed, rotors=True), seed=seed)


@pytest.mark.parametrize("law", ["smooth", "asymmetric+offset motor", "deadband sharp", "stribeck", "sigmoid motor"])
def test_coupled_rotors_and_every_friction_law_recursive_equals_reverse_mode(law):
    _assert_routes_agree(_coupled(law), seed=3)


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_six_and_seven_joint_arms_get_the_shorter_recursive_graph(name):
    """The issue: the Panda's RNEA derivatives were the Jacobian of the unrolled RNEA (7.4k
    operations).  Counted by the generator itself: the recursion is at least a quarter shorter
    on the Panda (4.1k against 7.4k when written; the margin leaves room for CasADi's
    simplifier), and it is the route ``generate`` picks unasked, for both derivative functions."""
    arm = _load(name)
    auto = source.generate(arm, derivatives=True)
    rev = source.generate(arm, derivatives=True, route="reverse")
    assert auto.routes == {"inverse_dynamics_derivatives": "recursive", "forward_dynamics_derivatives": "recursive"}
    assert rev.routes["inverse_dynamics_derivatives"] == "reverse"
    for fn in ("inverse_dynamics_derivatives", "forward_dynamics_derivatives"):
        assert auto.flops[fn] < rev.flops[fn], (fn, auto.flops[fn], rev.flops[fn])
    if name == "panda":
        assert auto.flops["inverse_dynamics_derivatives"] < 0.75 * rev.flops["inverse_dynamics_derivatives"]
    # nothing else in the file changes with the route
    others = set(auto.flops) - {"inverse_dynamics_derivatives", "forward_dynamics_derivatives"}
    assert {k: auto.flops[k] for k in others} == {k: rev.flops[k] for k in others}


def test_an_unknown_route_is_refused_by_name():
    with pytest.raises(md.ModelError, match="route"):
        source.generate(random_arm(1, n=2), route="forward")
