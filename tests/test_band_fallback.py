"""A band from runs that cannot each be predicted by a fit on the others (issue 45, motions of a robot at work).

Two runs of different trajectories, one of which leaves a joint still: the fit on both determines every base
parameter, the fit on the still run alone does not.  The band was then dropped whole ("no prediction band
from blocked hold-outs"), and with it the collision thresholds; the UR5's runs No1 and No2 (No2 barely moves
joints 1 and 6) met exactly that.  Now the band is calibrated within the runs (posture regions and blocks),
says so, and says why.
"""

from __future__ import annotations

import numpy as np
import pytest

import manipdyn as md

pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
from manipdyn.identification import excitation, write_measurements_csv  # noqa: E402

SIGMA = np.array([0.06, 0.5, 0.15, 0.02, 0.004, 0.001])     # N m, as tests/test_bands.py's synthetic UR5


def _log(path, arm, seed, still=None):
    ex = excitation(arm, duration=10.0, harmonics=3, rate=100.0, iterations=0, seed=seed, ramp=0)
    q, qd, qdd = ex.q.copy(), ex.qd.copy(), ex.qdd.copy()
    if still is not None:                                   # this joint held at its mid-range all run long
        q[:, still], qd[:, still], qdd[:, still] = 0.3, 0.0, 0.0
    tau = arm.inverse_dynamics(q, qd, qdd) + SIGMA * np.random.default_rng(seed).standard_normal(q.shape)
    write_measurements_csv(path, ex.t, q, tau, qd=qd, qdd=qdd)


def test_a_run_that_cannot_be_fitted_alone_leaves_a_band_within_the_runs(tmp_path):
    arm = md.load("ur5")
    _log(tmp_path / "full.csv", arm, 1)
    _log(tmp_path / "still.csv", arm, 2, still=5)           # joint 6 never moves: its friction is unseen
    r = md.identify("ur5", [tmp_path / "full.csv", tmp_path / "still.csv"], friction_terms="viscous,coulomb",
                    smoothing=0.01, prior_weight=0)        # the data alone: a refit on the still run is no fit
    notes = r.report_dict["fit_notes"]
    why = [n for n in notes if n.startswith("band: the 2 trajectories cannot each be predicted")]
    assert why and "calibrated within the runs instead" in why[0], notes
    band = r.provenance["prediction_band"]
    assert band is not None                                # main dropped it: "no prediction band from ..."
    assert not any(n.startswith("no prediction band") for n in notes), notes
    assert any("calibrated within one trajectory" in n for n in notes)     # and it says what it is
    # the collision thresholds come from the same hold-outs: the blocks' refits (main had none to read)
    from manipdyn.control.collision import identified_thresholds

    thr = identified_thresholds(r, [tmp_path / "full.csv", tmp_path / "still.csv"])
    assert "blocked hold-outs" in thr.source and np.all(np.isfinite(thr.threshold)), thr.source
