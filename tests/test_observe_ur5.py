"""The detector on motions that stop (issue 45 item 4): ``observe`` on the UR5's runs with and without a push
(``ur5_kufieta2013`` in the real-data folder), with the thresholds the identified model carries.

The UR5 logs hold motor currents, not torques.  Until ``identify`` takes the scale from the prior's gravity
(issue 45 item 2), this test makes torques itself: ``tau_j = k_j i_j``, ``k_j`` the least-squares
coefficient of the current in a fit of ``erd:ur5_robot``'s rigid torque (from the logged q, qd and a
smoothed derivative of qd) on ``[i_j, qd_j, tanh(qd_j / 0.01), 1]`` over the fit runs No6 and No1.  The model
is then identified on those two runs (viscous, Coulomb, offset, armature), its thresholds from the band's
hold-outs (the two trajectories) with the gain chosen on them.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.control.collision.reading import read_observed

from common import REALDATA

UR5 = REALDATA / "ur5_kufieta2013"
FIT = ("No6_Acc_slow_Verify_Model", "No1")
FREE = ("No5_Acc_slow_no_disturbance", "No7_Acc_slow_Verify_Model_short", "No9_Singularity_Free_NoDist")
PUSHED = ("No5_Acc_slow_w_disturbance", "No7_Acc_slow_Verify_Model_short_with_disturbance",
          "No9_Singularity_Free_WDist", "No10_Standstill_WDist")
pytestmark = pytest.mark.skipif(not all((UR5 / f"{n}.csv").is_file() for n in FIT + FREE + PUSHED),
                                reason=f"the UR5 logs (ur5_kufieta2013) are absent from the real-data folder {REALDATA}")


def _read(name):
    a = np.genfromtxt(UR5 / f"{name}.csv", delimiter=",", names=True)
    cols = [np.column_stack([a[f"{k}{j}"] for j in range(1, 7)]) for k in ("q", "qd", "i")]
    return a["t"], *cols


def _write(path, t, q, qd, tau):
    hdr = ",".join(["t"] + [f"{k}{j}" for k in ("q", "qd", "tau") for j in range(1, 7)])
    np.savetxt(path, np.column_stack([t, q, qd, tau]), delimiter=",", header=hdr, comments="", fmt="%.8g")


@pytest.fixture(scope="module")
def ur5(tmp_path_factory):
    """``(model, folder)``: the torque logs and the identified model with its own thresholds (once: identify
    on 12,500 samples and its refits cost about 15 s of CPU)."""
    from scipy.signal import savgol_filter

    from manipdyn.control.collision import identified_thresholds, with_thresholds

    d = tmp_path_factory.mktemp("ur5_observe")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prior = md.load("erd:ur5_robot")
        rows = []
        for name in FIT:
            t, q, qd, i = _read(name)
            qdd = savgol_filter(np.gradient(qd, t, axis=0), 9, 2, axis=0)
            rows.append((np.asarray(prior.inverse_dynamics(q, qd, qdd)), i, qd))
        tau, cur, vel = (np.vstack([r[k] for r in rows]) for k in range(3))
        k = np.array([np.linalg.lstsq(np.column_stack([cur[:, j], vel[:, j], np.tanh(vel[:, j] / 0.01),
                                                       np.ones(len(cur))]), tau[:, j], rcond=None)[0][0]
                      for j in range(6)])
        for name in FIT + FREE + PUSHED:
            t, q, qd, i = _read(name)
            _write(d / f"{name}.csv", t, q, qd, i * k)
        fit = [str(d / f"{n}.csv") for n in FIT]
        res = md.identify(prior, fit, friction_terms="viscous,coulomb,offset", armature=True)
        thr = identified_thresholds(res, fit)
        arm = with_thresholds(res.arm, thr)
    return arm, d


def _events(arm, d, name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return md.observe(arm, str(d / f"{name}.csv"), direct=False, wrench=False).events


def test_the_logs_ends_are_read_without_the_filters_ringing(tmp_path):
    """Every run ends in motion; the observer's reader filtered at 0.4 x 125 Hz rang over the last 8 to 19
    samples (0.17 rad/s off the measured qd, against 0.03 to 0.06 rad/s inside): the observer called the ends
    collisions.  Now the read qd stays within the inside's scatter up to the last sample kept."""
    arm = md.load("ur5")
    for name in ("No5_Acc_slow_no_disturbance", "No9_Singularity_Free_NoDist"):
        t, q, qd, i = _read(name)
        _write(tmp_path / "log.csv", t, q, qd, i)          # the currents as torques: the scale plays no part here
        (o,) = read_observed(arm, str(tmp_path / "log.csv"))
        i = int(np.searchsorted(t, o.t[0] - 1e-9))
        err = np.abs(o.qd - qd[i:i + len(o.t)]).max(axis=1)
        inside = np.quantile(err[100:-100], 0.999)
        assert err[-30:].max() <= 2 * inside, (name, err[-30:].round(3), inside)


def test_the_runs_without_a_push_are_quiet_and_the_pushes_are_found(ur5):
    arm, d = ur5
    thr = arm.trust["collision"]
    assert "chosen from these data" in thr["source"]
    quiet = {n: len(_events(arm, d, n)) for n in FREE[:2]}
    assert quiet == {n: 0 for n in FREE[:2]}, quiet            # measured 0 and 0
    found = {n: len(_events(arm, d, n)) for n in PUSHED}
    # at least 3 of the 4 pushed runs (measured: 5, 2, 1, 1 events; No9_WDist's one is the motion's own, below)
    assert sum(v > 0 for v in found.values()) >= 3, found


@pytest.mark.xfail(strict=True, reason="No9's path passes postures where the model, fitted on No6 and No1, errs by "
                                       "more than joint 1's threshold (5.5 N m) for 1.8 s at constant speed, three "
                                       "times: 3 false events; not a start or a stop")
def test_no9_without_a_push_is_quiet(ur5):
    arm, d = ur5
    assert _events(arm, d, "No9_Singularity_Free_NoDist") == []
