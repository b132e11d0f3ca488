"""simulate's inner loop: validated once, then Controller.step and the unchecked ABA.

The fast loop must give what the general one gives (any callable controller,
any object with ``forward_dynamics`` as the plant), which calls the checked
paths every step.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.control.demo import demo_path, make_controller


@pytest.fixture(scope="module")
def puma():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load("puma560")


class _CheckedOnly:
    """A plant offering only the checked forward dynamics (no ``pinocchio`` engine)."""

    def __init__(self, arm):
        self.n, self.name, self.joint_types = arm.n, "checked plant", arm.joint_types
        self.forward_dynamics = arm.pinocchio.forward_dynamics


@pytest.mark.parametrize("kind", ["pd", "pdg", "ct", "adaptive"])
def test_fast_loop_gives_what_the_checked_loop_gives(puma, kind):
    path = demo_path(puma, 1.0)
    fast = md.simulate(puma, make_controller(kind, puma), path, 1.0)
    ref_ctrl = make_controller(kind, puma)
    ref_ctrl.reset(path)
    slow = md.simulate(puma, lambda t, q, qd: ref_ctrl(t, q, qd), path, 1.0, plant=_CheckedOnly(puma))
    # the same arithmetic but for the reference, evaluated for all samples at once
    # in the fast loop and per step by the controller in the slow one: ulps, which
    # a stable loop carries along without growth (seen: 1e-15 rad, 1e-11 N m)
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.tau, slow.tau, rtol=1e-12, atol=1e-9)


def test_non_native_initial_state_is_converted(puma):
    path = demo_path(puma, 0.2)
    ctrl = make_controller("ct", puma)
    q0 = path(0.0)[0] + 0.01
    a = md.simulate(puma, ctrl, path, 0.2, q0=q0)
    b = md.simulate(puma, ctrl, path, 0.2, q0=q0.astype(">f8"))
    np.testing.assert_array_equal(a.q, b.q)


def test_non_finite_reference_is_refused_before_the_run(puma):
    path = demo_path(puma, 0.2)

    def bad(t):
        q, qd, qdd = path(t)
        qdd = np.array(qdd, dtype=float)
        qdd[..., 2] = np.nan
        return q, qd, qdd

    with pytest.raises(ValueError, match=r"^trajectory: qdd_d at t = 0 s is not finite"):
        md.simulate(puma, make_controller("pd", puma), bad, 0.2)
