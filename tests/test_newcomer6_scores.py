"""Issue 46 (a newcomer, round six): what a score says about the model and the data it is on.

Item 2 (a model scored on its own fit data, said), and the identified-model parts of items 5 and 7.
"""

from __future__ import annotations

import json
import re
import warnings

import pytest

import manipdyn as md
from manipdyn.cli import main

from test_bands import _log

pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """The UR5 identified on two seeded synthetic logs (fit1, fit2), a third log (other) held out."""
    d = tmp_path_factory.mktemp("fit")
    arm = md.load("ur5")
    logs = {k: d / f"{k}.csv" for k in ("fit1", "fit2", "other")}
    for seed, path in zip((11, 12, 13), logs.values()):
        _log(path, arm, seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = md.identify("ur5", [logs["fit1"], logs["fit2"]], band_folds=3)
    model = d / "id.toml"
    r.save(model)
    return d, model, logs, r


# -- 2. a model scored on its own fit data -------------------------------------------------------
def test_item2_validate_says_when_the_model_is_scored_on_its_fit_data(fitted, capsys):
    """Issue 46 item 2: ``validate lwr4_id.toml run1.csv`` (fit on runs 1 and 2) printed a band holding
    99.4 % without a word.  Every fit log (the second as much as the first: the provenance names two
    sha256) is said, in the text and the JSON; a held-out log is not."""
    d, model, logs, _ = fitted
    for which in ("fit1", "fit2"):
        assert main(["validate", str(model), str(logs[which])]) == 0
        out = capsys.readouterr().out
        assert "FIT DATA" in out and f"{which}.csv" in out, out[:600]
    assert main(["validate", str(model), str(logs["other"])]) == 0
    assert "FIT DATA" not in capsys.readouterr().out
    assert main(["validate", str(model), str(logs["other"]), str(logs["fit2"]), "--json"]) == 0
    notes = json.loads(capsys.readouterr().out)["fit_data"]
    assert len(notes) == 1 and "fit2.csv" in notes[0] and "other.csv" not in notes[0]


def test_item2_validate_report_verdict_says_fit_data(fitted, capsys):
    pytest.importorskip("matplotlib", reason="the report's figures need the plot extra")
    d, model, logs, _ = fitted
    page = d / "v.html"
    assert main(["validate", str(model), str(logs["fit1"]), "--report", str(page)]) == 0
    capsys.readouterr()
    text = page.read_text()
    verdict = text[text.index("Verdict"):]
    assert "FIT DATA" in verdict[:4000]


def test_item2_replay_says_when_the_model_is_replayed_on_its_fit_data(fitted, capsys):
    d, model, logs, _ = fitted
    assert main(["replay", str(model), str(logs["fit2"]), "--horizon", "0.02", "--every", "50"]) == 0
    out = capsys.readouterr().out
    assert "FIT DATA" in out and "fit2.csv" in out
    assert main(["replay", str(model), str(logs["other"]), "--horizon", "0.02", "--every", "50", "--json"]) == 0
    assert not any("FIT DATA" in x for x in json.loads(capsys.readouterr().out)["notes"])


def test_item2_the_shared_helper_for_observe(fitted):
    """``fit_data_logs`` / ``fit_data_note``: what observe --calibrate calls (by sha256, and by the fit
    window when the model was fitted on one)."""
    from manipdyn.identification.results.heldout import fit_data_logs, fit_data_note

    d, model, logs, r = fitted
    arm = md.load(str(model))
    assert fit_data_logs(arm, [logs["other"], logs["fit2"], logs["fit1"]]) == [logs["fit2"], logs["fit1"]]
    assert fit_data_note(arm, [logs["other"]]) is None
    assert "fit1.csv" in fit_data_note(arm, [logs["fit1"]], what="thresholds")
    assert fit_data_logs(md.load("ur5"), [logs["fit1"]]) == []        # a published model: nothing to say


# -- 3. "at its floor" for a radius 50 times below it ----------------------------------------------
def test_item3_a_radius_far_below_the_floor_is_not_said_to_be_at_it():
    """Issue 46 item 3: ``identify ur5 ur5_free.csv --friction`` printed ``link 4 radius of gyration
    0.000216 m at its floor 0.011 m``.  A body on its floor is "at its floor"; one far below it is
    said to be below, with the floor not holding, and the doubts say it too."""
    import numpy as np

    from manipdyn.identification.estimation.sdp import Bounds
    from manipdyn.identification.results.doubts import floor_doubts
    from manipdyn.model.parameters import arm_parameters
    from manipdyn.model.plausible import smallest_gyration

    arm = md.load("ur5")
    pi = arm_parameters(arm)
    rg = smallest_gyration(pi, arm.n)
    floor = rg / 2.0                          # every body above its floor: not listed
    floor[0] = rg[0]                          # link 1 exactly on its floor
    floor[3] = rg[3] * 50                     # link 4 fifty times below it (the ratio)
    lines = Bounds(gyration=floor).active(pi, arm.n)
    at = [x for x in lines if x.startswith("link 1 ")]
    below = [x for x in lines if x.startswith("link 4 ")]
    assert len(lines) == 2 and "at its floor" in at[0]
    assert "at its floor" not in below[0] and "below its floor" in below[0] and "does not hold" in below[0]
    doubts = floor_doubts(lines)
    assert any(d.startswith("link 1:") and "at the plausibility floor" in d for d in doubts)
    assert any(d.startswith("link 4:") and "below the plausibility floor" in d for d in doubts)


# -- 4. a published model that is not a physical arm ------------------------------------------------
def _unphysical_ur5(path):
    """The UR5 as a URDF with link 2's ixx negative and link 3's izz beyond ixx + iyy (no rigid body)."""
    import re

    text = md.to_urdf(md.load("ur5"))
    tags = re.findall(r"<inertia [^>]*/>", text)
    text = text.replace(tags[1], re.sub(r'ixx="[^"]*"', 'ixx="-0.01"', tags[1]), 1)
    text = text.replace(tags[2], re.sub(r'izz="[^"]*"', 'izz="0.2"', tags[2]), 1)
    path.write_text(text)
    return path


def test_item4_validate_and_identify_say_the_model_is_not_a_physical_arm(fitted, capsys):
    """Issue 46 item 4: ``check kuka_lwr4_gaz.urdf`` names the links; ``validate`` and ``identify`` (with it as
    the prior) said nothing.  Both say it now, from one function (:func:`not_physical_note`)."""
    from manipdyn.model.plausible import not_physical_note

    d, model, logs, _ = fitted
    bad = _unphysical_ur5(d / "bad_ur5.urdf")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        arm = md.load(str(bad))
    note = not_physical_note(arm, "bad_ur5.urdf", "the prior")
    assert note.startswith("the prior bad_ur5.urdf is not a physical arm: link 2 has negative principal moments; "
                           "link 3 breaks the triangle inequality"), note
    assert not_physical_note(md.load("ur5")) is None
    assert main(["validate", str(bad), str(logs["other"])]) == 0
    out = capsys.readouterr().out
    assert "not a physical arm" in out and "link 2" in out
    assert main(["identify", str(bad), str(logs["fit1"]), "--band-folds", "0", "--no-thresholds",
                 "-o", str(d / "from_bad.urdf")]) == 0
    out = capsys.readouterr().out
    assert "the prior bad_ur5.urdf is not a physical arm" in out


# -- 5. units that pass --------------------------------------------------------------------------
def _in_millinewton_metres(src, dst):
    import numpy as np

    head = src.read_text().splitlines()[0].split(",")
    a = np.loadtxt(src, delimiter=",", skiprows=1)
    a[:, [k for k, c in enumerate(head) if c.startswith("tau")]] *= 1000.0
    np.savetxt(dst, a, delimiter=",", header=",".join(head), comments="")
    return dst


def test_item5_torques_in_mNm_are_said_by_validate_and_identify(fitted, capsys):
    """Issue 46 item 5: torques logged in mN m gave R^2 -2.47 with no hint, and identify wrote a model.
    Both say the ratio (1000), the likely unit, and that there is no unit option (convert the columns);
    identify warns (SuspiciousValueWarning) besides its note."""
    d, model, logs, _ = fitted
    mnm = _in_millinewton_metres(logs["other"], d / "other_mNm.csv")
    assert main(["validate", "ur5", str(mnm)]) == 0
    out = capsys.readouterr().out
    assert "UNITS?" in out and re.search(r"\b(999\.\d|1000(\.\d)?) times", out) and "mN m read as N m" in out
    assert main(["validate", "ur5", str(logs["other"])]) == 0
    assert "UNITS?" not in capsys.readouterr().out           # N m: nothing said
    with pytest.warns(md.SuspiciousValueWarning, match=r"times what the prior predicts.*mN m read as N m"):
        r = md.identify("ur5", [mnm], band_folds=0)
    assert r.report()["fit_notes"][0].startswith("UNITS?")


# -- 7. the reports leave out what the text says ------------------------------------------------------
def test_item7_identify_report_has_the_thresholds_and_the_bands_true_method(fitted, capsys):
    """Issue 46 item 7: ``identify --report`` had no collision thresholds, and gave the band's method as
    "blocked, 5 folds" when it came from 2 held-out trajectories."""
    pytest.importorskip("matplotlib", reason="the report's figures need the plot extra")
    from manipdyn._support.html import read_tables

    d, model, logs, _ = fitted
    page = d / "id2.html"
    assert main(["identify", "ur5", str(logs["fit1"]), str(logs["fit2"]), "-o", str(d / "id2.toml"),
                 "--report", str(page)]) == 0
    out = capsys.readouterr().out
    printed = re.search(r"collision thresholds \(.*?\): \[([^\]]+)\] N m", out)
    assert printed, out[-800:]
    text = page.read_text()
    rows = read_tables(text)["collision_thresholds"][1:]
    assert [f"{x:.3g}" for _, x in rows] == [s.strip() for s in printed.group(1).split(",")]
    assert "blocked, 5 folds" not in text and "2 held-out trajectories" in text


def test_item7_two_model_report_draws_every_band_under_every_line(fitted, capsys):
    """Two-model ``validate --report`` drew the second model over the first's band: the bands are drawn
    first (under every predicted line), edged in their model's colour, and the caption says whose."""
    pytest.importorskip("matplotlib", reason="the report's figures need the plot extra")
    import matplotlib

    matplotlib.use("Agg")
    import numpy as np

    from manipdyn.identification.results import html as page

    t = np.linspace(0, 1, 50)
    meas = np.zeros((50, 1))
    series = [("a", np.ones((50, 1)), np.full((50, 1), 0.5)), ("b", np.full((50, 1), 1.2), None)]
    fig = page._draw(t, meas, series, ["N m"])
    ax = fig.axes[0]
    band_z = max(c.get_zorder() for c in ax.collections)
    line_z = min(line.get_zorder() for line in ax.get_lines() if line.get_linestyle() == "-")
    assert band_z < line_z
    d, model, logs, _ = fitted
    out = d / "two.html"
    assert main(["validate", str(model), "ur5", str(logs["other"]), "--report", str(out)]) == 0
    capsys.readouterr()
    assert "95 % band of id only" in out.read_text()
