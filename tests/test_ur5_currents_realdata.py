"""Issue 45, item 2, on the real UR5 (../shared/realdata/ur5_kufieta2013, measured outside the project):
motor currents with no torque constants given and no payload run, the scale from erd:ur5_robot's masses.

Fit on No6_Acc_slow_Verify_Model and No1 as the issue's command does; score on the held-out runs beside
the UR controller's own target torque (columns m1..m6), read as one more model.  What the issue targets
and the data do not give (measured, and said in the xfail reason): No4_Acc alone agreeing with the fit's
constants within 3 %; what the tool owes there instead, its uncertainty covering the gap, is tested.
Joint 2's RMS below the controller's and the band's 90 to 98 % pooled, missed before the prior
weight was chosen by default and joints at rest were left out of their rows, now hold.

Why No4_Acc alone cannot give k2 and k3 within 3 % (measured at its rests, where neither inertia, the
acceleration estimate nor the moving friction law enters; a rest: every |qd| under 1e-3 rad/s for 25
samples or more, its first quarter skipped, ``i_j = g_j(q) / k_j + offset`` fitted over a run's rests):

* it rests in two postures only (No6: three), so a rest fit is one slope between them;
* that slope gives k2 15.8, k3 3.53 (No6's postures: 13.3, 6.65; No3_Acc, the same motion as No4:
  17.3, 3.51), and the same with the UR controller's own target torque as the gravity (14.6, 3.18 against
  No6's 12.1, 7.35): the currents' ratio to gravity differs by posture set with either model's gravity;
* the static friction held at one posture scatters 0.41 A (joint 2) and 0.30 A (joint 3) between rests,
  against a gravity difference between No4's postures of 2.1 and 0.70 A (at the fit's constants), and
  neither the last motion's sign nor a load-proportional term explains it (pooled over the 50 rests of
  the runs without a push, in 11 postures, the residual stays 0.56 A on joint 2 and goes from 0.40 to
  0.39 A on joint 3); on joint 3 of No4 the last motion's sign at rest is the posture's (every rest
  but the log's first follows a move towards it the same way), so a held level by that sign cannot be
  told from gravity there;
* on the moving samples, the relative fit does not determine k3 / k2 (doubling or halving it raises the
  residual's sum of squares by 4.1 and 2.4 residual variances; No6: 8 to 9 for a 3 % change), and the gravity
  factor of its first and second halves (slow moves, then fast) is 1.53 and 1.14.

Estimators tried on No4 alone, none within 3 % of No6 alone on joints 2 and 3 (k2, k3; No6 in brackets):
the joints at rest out of their rows in steps 2 and 3, 12.8 (std 500) and 0.12 [14.1, 7.83]; the prior's
gravity held as known and the inertial parameters free (rests out, or with a held level by the last
motion's sign), 8.3 to 10.5 and 1.1 to 2.7 [10.2 to 12.2, 4.5 to 6.9]; samples with |qdd| over 10 or 4
rad/s^2 out (5 to 6 %), k3 0 [unchanged]; the scale from the prior's gravity parameters (first moments)
rather than its torque over the run's postures, k2 1.6 [11.7]: No4's two postures leave most of them free;
the gravity's slope over stretches at constant speed (a joint over 0.2 rad/s for 25 samples or more, |qdd| of
joints 1 to 3 under 1 rad/s^2, an offset per stretch for its friction), k2 11.9 +- 0.5 and k3 11.2 +- 1.2
[12.0 +- 0.3, 8.8 +- 0.3], but with 0.5 or 2 rad/s^2 as the bound, k2 13.5 or 10.9 [12.5, 9.0]: its
agreement on k2 at one bound is the bound's, not the data's.
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


@pytest.fixture(scope="module")
def no4_alone():
    """The torque constants found from No4_Acc alone (about 17 s of CPU)."""
    return md.identify("erd:ur5_robot", str(UR5 / "No4_Acc.csv"), band_folds=0, **OPTIONS).torque_constants


def test_no4_alone_says_k3_is_not_determined_and_k2s_deviation_covers_the_fits(scored, no4_alone):
    """What No4_Acc alone can give (module docstring): k3 said not determined (an infinite standard deviation and
    a note), and k2's distance to the fit's within two of its standard deviations (a 95 % interval; measured:
    14.4 +- 2.2 against 12.2, 0.96 of one)."""
    r, _, _ = scored
    alone = no4_alone
    assert not np.isfinite(alone.std[2]) and any("[1, 3" in x and "not determined" in x for x in alone.notes), alone
    assert np.isfinite(alone.std[1]) and abs(alone.values[1] - r.torque_constants.values[1]) <= 2 * alone.std[1]


@pytest.mark.xfail(strict=True, reason=(
    "measured: No4_Acc alone gives k2 14.4 +- 2.2 against the fit's 12.2 (No6 alone 12.4) and does not determine "
    "k3; at rest, its two postures give k2 15.8, k3 3.5 against No6's 13.3, 6.7 with the prior's gravity (14.6, 3.2 "
    "against 12.1, 7.4 with the UR controller's own torque), the held static friction's scatter 0.41 and 0.30 A "
    "against a gravity difference between them of 2.1 and 0.70 A (module docstring)"))
def test_no4_alone_agrees_with_the_fit_within_3_percent_on_joints_2_and_3(scored, no4_alone):
    r, _, _ = scored
    alone = no4_alone
    assert np.all(np.isfinite(alone.std[1:3]))
    assert np.all(np.abs(alone.values[1:3] / r.torque_constants.values[1:3] - 1) <= 0.03), alone.values


def test_the_guides_table_is_this_run(scored):
    """docs/guide/work.md's first table is this run, to its printed digits (3 significant for N m and N m/A,
    0.1 % for the band, 1 % for the flags): a change to reading or fitting moves them, so update the page."""
    import re

    import guide

    r, _, rep = scored
    ours, ur = _rms(rep)
    m = next(x for x in rep["models"] if x["model"] == "M")
    page = guide.page("work")

    def same(label, values, fmt):
        cells = guide.row(label, page)
        assert [float(c.split()[0]) for c in cells] == [float(fmt.format(v)) for v in values], (label, cells, values)

    same("RMS of the model fitted on No6 and No1 (N m)", ours, "{:.3g}")
    same("RMS of the UR controller's target torque on the five held-out runs (N m)", ur, "{:.3g}")
    same("95 % band of the model fitted on No6 and No1 holds", 100 * np.array(m["band_95_coverage"]), "{:.1f}")
    same("its samples flagged beyond the fit data", 100 * np.array(m["flagged_fraction"]), "{:.0f}")
    same("that band holds on the unflagged samples", 100 * np.array(m["band_95_coverage_unflagged"]), "{:.1f}")
    pooled = re.search(r"Pooled over the five held-out runs the band holds ([0-9.]+) %", page)
    assert pooled and float(pooled.group(1)) == round(100 * m["band_95_pooled"], 1), pooled
    tc = r.torque_constants
    cells = guide.row("k_t (N m/A), scale from joints 2 and 3", page)
    for j, c in enumerate(cells):
        if np.isfinite(tc.std[j]):
            value, std = (float(x) for x in c.split(" +- "))
            assert (value, std) == (float(f"{tc.values[j]:.3g}"), float(f"{tc.std[j]:.2g}")), (j + 1, c)
        else:
            assert c == f"{tc.values[j]:.2g} (not determined)", (j + 1, c)
