"""Issue 45, item 2, on the real UR5 (../shared/realdata/ur5_kufieta2013, measured outside the project):
motor currents with no torque constants given and no payload run, the scale from erd:ur5_robot's masses.

Fit on No6_Acc_slow_Verify_Model and No1 as the issue's command does; score on the held-out runs beside
the UR controller's own target torque (columns m1..m6), read as one more model.  What the issue targets
and the data do not give (measured, and said in the xfail reason): No4_Acc alone agreeing with the fit's
constants.  Joint 2's RMS below the controller's and the band's 90 to 98 % pooled, missed before the prior
weight was chosen by default and joints at rest were left out of their rows, now hold.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import manipdyn as md

from common import ENV, REALDATA

UR5 = REALDATA / "ur5_kufieta2013"
FIT = ("No6_Acc_slow_Verify_Model.csv", "No1.csv")
HELD_OUT = ("No3_Acc.csv", "No4_Acc.csv", "No5_Acc_slow_no_disturbance.csv", "No7_Acc_slow_Verify_Model_short.csv",
            "No9_Singularity_Free_NoDist.csv")
pytestmark = pytest.mark.skipif(not all((UR5 / f).is_file() for f in FIT + HELD_OUT), reason=(
    f"the UR5 logs are absent (No6_Acc_slow_Verify_Model.csv and the others not found in {UR5}; set ${ENV} to "
    "the folder that holds ur5_kufieta2013/)"))
pytest.importorskip("cvxpy", reason="identification needs the identify extra")
OPTIONS = dict(friction_terms="viscous,coulomb,offset", identify_torque_constants=True)


@pytest.fixture(scope="module")
def scored(tmp_path_factory):
    """The README's command with --identify-torque-constants, then validate on the held-out runs with
    --compare-column 'm=UR controller target torque' (about 25 s of CPU)."""
    from manipdyn.cli import main

    out = tmp_path_factory.mktemp("ur5") / "M.toml"
    try:
        md.load("erd:ur5_robot")
    except md.ModelError as exc:
        pytest.skip(f"erd:ur5_robot: {exc}")
    r = md.identify("erd:ur5_robot", [str(UR5 / f) for f in FIT], output=str(out), **OPTIONS)
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["validate", str(out), *(str(UR5 / f) for f in HELD_OUT),
                     "--compare-column", "m=UR controller target torque", "--json"]) == 0
    return r, out, json.loads(buf.getvalue())


def test_the_scale_comes_from_joints_2_and_3_and_matches_the_readmes_rest_figure(scored):
    """Joints 2 and 3 carry the gravity that varies (joint 1's axis is vertical, joint 6 carries none); k2
    within 10 % of the README's independent figure, 0.078 A per N m over No6's rests (R^2 0.96; 10 %: the
    static friction's scatter there, and the fit's gravity against the prior's, differ by that much between
    halves and joints), and each scale motor's standard deviation finite and under 15 % of its value (the
    measured spread of the factor between joints 2 and 3 is about 10 %)."""
    r, out, _ = scored
    tc = r.torque_constants
    assert tc.scale == "gravity" and list(tc.reference) == [2, 3]
    assert abs(tc.values[1] * 0.078 - 1) < 0.10, tc.values
    assert np.all(np.isfinite(tc.std[1:3])) and np.all(tc.std[1:3] < 0.15 * tc.values[1:3]), tc.std
    line = tc.as_dict()["summary"]
    assert md.load(str(out)).trust["torque_constants"] == line
    assert line in r.report()["fit_notes"]


def _rms(rep):
    models = {m["model"]: m for m in rep["models"]}
    return np.array(models["M"]["rms"]), np.array(models["UR controller target torque"]["rms"])


def test_the_model_beats_the_ur_controllers_torque_where_it_saw_the_postures(scored):
    """Per joint RMS (N m, i.e. in current through the same k_t) at or below the UR controller's target
    torque on joints 1, 3, 4, 5, 6 (measured: 0.41 to 0.79 of it)."""
    _, _, rep = scored
    ours, ur = _rms(rep)
    assert np.all(ours[[0, 2, 3, 4, 5]] <= ur[[0, 2, 3, 4, 5]]), (ours, ur)


# measured before the prior weight was chosen by default and joints at rest were left out of their rows (issues
# 44, 45): joint 2 at 22.1 N m against the controller's 14.4 (held-out q2 beyond the fit's); it now holds
def test_the_model_beats_the_ur_controllers_torque_on_every_joint(scored):
    _, _, rep = scored
    ours, ur = _rms(rep)
    assert np.all(ours <= ur), (ours, ur)


def test_where_the_band_holds_under_85_percent_the_flags_warned(scored):
    """The issue's rule: on every joint whose band holds under 85 %, unflagged samples hold 85 % or more,
    flagged ones miss at least twice as often, and at most 3x as many samples are flagged as missed."""
    _, _, rep = scored
    m = next(x for x in rep["models"] if x["model"] == "M")
    for j, cov in enumerate(m["band_95_coverage"]):
        if cov >= 0.85:
            continue
        flagged, unflagged, frac = (m["band_95_coverage_flagged"][j], m["band_95_coverage_unflagged"][j],
                                    m["flagged_fraction"][j])
        assert unflagged >= 0.85, (j + 1, unflagged)
        assert 1 - flagged >= 2 * (1 - unflagged), (j + 1, flagged, unflagged)
        assert frac <= 3 * (1 - cov), (j + 1, frac, cov)


# measured before the same two changes: pooled 81.1 % (joint 2 27 %); it now holds
def test_the_band_holds_90_to_98_percent_pooled(scored):
    _, _, rep = scored
    m = next(x for x in rep["models"] if x["model"] == "M")
    assert 0.90 <= m["band_95_pooled"] <= 0.98


@pytest.mark.xfail(strict=True, reason="measured: No4_Acc alone gives k2 14.4 against the fit's 12.2 (18 %; No6 alone 12.4) and "
                   "does not determine k3 (a 10 % change moves its residual by under one standard deviation)")
def test_no4_alone_agrees_with_the_fit_within_3_percent_on_joints_2_and_3(scored):
    r, _, _ = scored
    alone = md.identify("erd:ur5_robot", str(UR5 / "No4_Acc.csv"), band_folds=0, **OPTIONS).torque_constants
    assert np.all(np.isfinite(alone.std[1:3]))
    assert np.all(np.abs(alone.values[1:3] / r.torque_constants.values[1:3] - 1) <= 0.03), alone.values
