"""Issue 45 on the real UR5 (../shared/realdata/ur5_kufieta2013, measured outside the project): a fit on runs
that never rest, scored on the robot's work.

No1 and No2 move all the time (0 % at rest); six other runs are point-to-point work with 8 to 39 % at rest.
Fitted on No1 and No2 (currents, the scale from erd:ur5_robot's masses), the model is scored on the six,
beside the UR controller's own target torque read through the same torque constants: the issue's target for
"other real arms" (a point-to-point run held out from a fit on runs that do not stop: every joint at or
below the published model, the band holding or warning), on the one such arm the repository can reach.

No2 barely moves joints 1 and 6 (peak 0.30 and 0.04 rad/s): a fit on No2 alone does not determine their
friction, so the band cannot hold either run out whole; it is calibrated within the runs and says so
(tests/test_band_fallback.py).  Before that, this fit had no band and no collision thresholds at all.
"""

from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest

import manipdyn as md

from common import ENV, REALDATA

UR5 = REALDATA / "ur5_kufieta2013"
FIT = ("No1.csv", "No2.csv")
WORK = ("No6_Acc_slow_Verify_Model.csv", "No3_Acc.csv", "No4_Acc.csv", "No5_Acc_slow_no_disturbance.csv",
        "No7_Acc_slow_Verify_Model_short.csv", "No9_Singularity_Free_NoDist.csv")
pytestmark = pytest.mark.skipif(not all((UR5 / f).is_file() for f in FIT + WORK), reason=(
    f"the UR5 logs are absent (No1.csv and the others not found in {UR5}; set ${ENV} to the folder that holds "
    "ur5_kufieta2013/)"))
pytest.importorskip("cvxpy", reason="identification needs the identify extra")


@pytest.fixture(scope="module")
def scored(tmp_path_factory):
    """identify on No1 and No2 as the README's UR5 command does, validate on the six working runs (about
    30 s of CPU)."""
    from manipdyn.cli import main

    out = tmp_path_factory.mktemp("ur5_work") / "W.toml"
    try:
        md.load("erd:ur5_robot")
    except md.ModelError as exc:
        pytest.skip(f"erd:ur5_robot: {exc}")
    r = md.identify("erd:ur5_robot", [str(UR5 / f) for f in FIT], output=str(out),
                    friction_terms="viscous,coulomb,offset", identify_torque_constants=True)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["validate", str(out), *(str(UR5 / f) for f in WORK),
                     "--compare-column", "m=UR controller target torque", "--json"]) == 0
    rep = json.loads(buf.getvalue())
    return r, {m["model"]: m for m in rep["models"]}


def test_every_joint_at_or_below_the_ur_controller_on_the_work_it_never_saw(scored):
    """Measured: 5.10 5.68 7.26 1.74 2.23 0.183 N m against the controller's 12.3 10.9 10.7 1.98 4.69 0.264
    (0.41 to 0.88 of it), over 24,979 samples of six runs (docs/guide/work.md, read back below)."""
    _, models = scored
    ours, ur = np.array(models["W"]["rms"]), np.array(models["UR controller target torque"]["rms"])
    assert np.all(ours <= ur), (ours, ur)


def test_the_band_holds_on_the_work_and_says_it_was_calibrated_within_the_runs(scored):
    """The issue's rule: 90 to 98 % pooled, or on every joint under 85 % the flags warned.  Measured: 95.1 %
    pooled, 92.8 to 97.6 % per joint, the rests widened by the static level the fit's own rests gave."""
    r, models = scored
    notes = r.report_dict["fit_notes"]
    assert any(n.startswith("band: the 2 trajectories cannot each be predicted") for n in notes), notes
    m = models["W"]
    assert 0.90 <= m["band_95_pooled"] <= 0.98, m["band_95_coverage"]
    for j, cov in enumerate(m["band_95_coverage"]):
        if cov < 0.85:
            assert m["band_95_coverage_unflagged"][j] >= 0.85, (j + 1, m["band_95_coverage_unflagged"][j])
            assert 1 - m["band_95_coverage_flagged"][j] >= 2 * (1 - m["band_95_coverage_unflagged"][j]), j + 1
            assert m["flagged_fraction"][j] <= 3 * (1 - cov), (j + 1, m["flagged_fraction"][j], cov)


def test_the_guides_rows_are_this_run(scored):
    """docs/guide/work.md's "fitted on motion, scored on work" rows are this run, to their printed digits."""
    import re

    import guide

    _, models = scored
    page = guide.page("work")
    for label, values, fmt in (
            ("RMS of the model fitted on No1 and No2 (N m)", models["W"]["rms"], "{:.3g}"),
            ("RMS of the UR controller's target torque on the six runs of work (N m)",
             models["UR controller target torque"]["rms"], "{:.3g}"),
            ("95 % band of the model fitted on No1 and No2 holds", 100 * np.array(models["W"]["band_95_coverage"]),
             "{:.1f}")):
        cells = guide.row(label, page)
        assert [float(c.split()[0]) for c in cells] == [float(fmt.format(v)) for v in values], (label, cells)
    pooled = re.search(r"Pooled over the six runs of work the band holds ([0-9.]+) %", page)
    assert pooled and float(pooled.group(1)) == round(100 * models["W"]["band_95_pooled"], 1), pooled
