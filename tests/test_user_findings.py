"""The README tried as a new user would (issue 13): one test per finding, through the CLI or the API.

Finding 1 (compare's verdicts) is in tests/test_compare_verdict.py; finding 8 (benchmarks) in
tests/test_bench_smoke.py.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main
from manipdyn.control import PD, ComputedTorque, Quintic
from manipdyn.formats.erd import urdf_path

PANDA = str(urdf_path("panda"))     # a tree: the arm, the hand and two fingers

TWO_LINKS = """
format = "manipdyn-model/1"
name = "two"
convention = "standard"
source = "made up for the test"
{units}
[[links]]
joint = "revolute"
a = {a1}
alpha = {alpha}
d = 0.0
theta = 0.0
mass = 1.0
com = [0.1, 0.0, 0.0]
inertia = {inertia}

[[links]]
joint = "revolute"
a = {a2}
alpha = 0.0
d = 0.0
theta = 0.0
mass = 1.0
com = [0.1, 0.0, 0.0]
inertia = {{ ixx = 0.01, iyy = 0.02, izz = 0.02 }}
"""


def model_text(units="", a1=0.4, a2=0.3, alpha=0.0, inertia="{ ixx = 0.01, iyy = 0.02, izz = 0.02 }"):
    return TWO_LINKS.format(units=units, a1=a1, a2=a2, alpha=alpha, inertia=inertia)


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


# -- 2. one way to name a tip ------------------------------------------------------------
@pytest.mark.parametrize("argv, option", [
    (["check", PANDA, "--samples", "2", "--timing-calls", "0"], "--tip LINK"),
    (["track", PANDA, "--duration", "0.01"], "--tip LINK"),
    (["compare", PANDA, "panda"], "--tip-a LINK"),
    (["compare", "panda", PANDA], "--tip-b LINK"),
])
def test_a_tree_urdf_names_the_option_and_the_leaf_links(argv, option, capsys, tmp_path):
    assert main(argv) == 2
    line = one_error_line(capsys)
    assert option in line and "tip='" not in line, line
    assert "the leaf links are 'panda_hand_tcp', 'panda_leftfinger', 'panda_rightfinger'" in line


def test_urdf_subcommand_takes_tip_too(capsys, tmp_path):
    assert main(["urdf", PANDA, str(tmp_path)]) == 2
    assert "--tip LINK" in one_error_line(capsys)
    assert main(["urdf", "--tip", "panda_link8", PANDA, str(tmp_path)]) == 0
    assert (tmp_path / "panda.urdf").is_file()


def test_misspelled_tip_gets_did_you_mean_and_every_link(capsys):
    assert main(["check", PANDA, "--tip", "panda_hnd", "--samples", "2"]) == 2
    line = one_error_line(capsys)
    assert "did you mean 'panda_hand'" in line
    links = re.search(r"all (\d+) links: (.*)$", line)
    assert links and int(links.group(1)) == 13
    assert links.group(2).count("'") == 2 * 13 and "'panda_hand'" in links.group(2)


def test_python_api_error_speaks_python():
    with pytest.raises(md.ModelError, match=r"tip='<link name>'.*'panda_leftfinger'"):
        md.load(PANDA)


def test_tip_with_no_urdf_is_a_usage_error(capsys):
    assert main(["check", "ur5", "--tip", "tool"]) == 2
    assert "--tip: only meaningful for a URDF file" in one_error_line(capsys)


# -- 3. model files accept what Python accepts ------------------------------------------
def test_three_diagonal_values_in_a_model_file():
    from manipdyn.formats.modelfile import parse_model

    a = parse_model(model_text(inertia="[0.01, 0.02, 0.02]"))
    b = parse_model(model_text())
    np.testing.assert_array_equal(a.links[0].inertia, b.links[0].inertia)
    np.testing.assert_array_equal(a.links[0].inertia, np.diag([0.01, 0.02, 0.02]))


def test_format_key_is_required():
    from manipdyn.formats.modelfile import parse_model

    text = model_text().replace('format = "manipdyn-model/1"\n', "")
    with pytest.raises(md.ModelError, match=r"missing key 'format'.*format = \"manipdyn-model/1\""):
        parse_model(text, "arm.toml")


# -- 4. every name validated before anything runs ----------------------------------------
def test_check_validates_every_name_first(capsys):
    assert main(["check", "ur5", "nosuch", "puma560", "--samples", "2", "--timing-calls", "0"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""                      # ur5 was not run
    assert "unknown model 'nosuch'" in captured.err


def test_urdf_validates_every_name_first(capsys, tmp_path):
    assert main(["urdf", "ur5", "nosuch", str(tmp_path)]) == 2
    assert list(tmp_path.iterdir()) == []


# -- 5. suspicious units and values ---------------------------------------------------------
def test_angle_over_two_pi_in_radians_is_flagged():
    from manipdyn.formats.modelfile import parse_model

    with pytest.warns(md.SuspiciousValueWarning, match=r"key 'alpha' = 90.0 is more than 2 pi .*rad"):
        arm = parse_model(model_text(alpha=90.0), "arm.toml")
    assert any("alpha" in n for n in arm.notes)
    with pytest.raises(md.ModelError, match=r"key 'alpha' = 90.0 .*\(strict\)"):
        parse_model(model_text(alpha=90.0), "arm.toml", strict=True)


def test_millimetres_in_a_metre_file_and_the_reverse_are_flagged():
    from manipdyn.formats.modelfile import parse_model

    with pytest.warns(md.SuspiciousValueWarning, match="look like they are in a smaller unit"):
        parse_model(model_text(a1=400.0, a2=300.0), "arm.toml")
    with pytest.warns(md.SuspiciousValueWarning, match="look like they are in a larger unit"):
        parse_model(model_text(units='[units]\nlength = "mm"\n', a1=0.4, a2=0.3), "arm.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("error")            # plausible lengths: no false alarm
        parse_model(model_text(units='[units]\nlength = "mm"\n', a1=400.0, a2=300.0), "arm.toml")


def test_negative_principal_moment_is_refused_like_a_negative_mass():
    from manipdyn.formats.modelfile import parse_model

    with pytest.raises(md.ModelError, match=r"links\[0\].*negative principal moment of inertia -0.01"):
        parse_model(model_text(inertia="{ ixx = -0.01, iyy = 0.02, izz = 0.02 }"), "arm.toml")
    with pytest.raises(md.ModelError, match="negative principal moment"):
        md.DHLink(mass=1.0, inertia=(0.1, -0.1, 0.1))


def test_check_strict_fails_on_notes_and_default_keeps_published_data(capsys):
    args = ["check", "puma560", "--samples", "5", "--timing-calls", "0"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "link 3: physically impossible inertia" in out
    assert main(args + ["--strict"]) == 1
    assert "--strict: puma560" in capsys.readouterr().out
    assert main(["check", "ur5", "--samples", "5", "--timing-calls", "0", "--strict"]) == 0


# -- 6. quiet, useful output -------------------------------------------------------------------
def test_warning_points_at_the_users_call_once():
    with pytest.warns(md.PhysicalConsistencyWarning) as record:
        arm = md.load("puma560")
    assert len(record) == 1
    assert record[0].filename == __file__          # not a line inside manipdyn
    assert len(arm.notes) == 2 and all(n in str(record[0].message) for n in arm.notes)


def test_urdf_notes_are_carried_and_warned_at_the_caller(tmp_path):
    """A URDF body with a broken triangle inequality: a note on the arm, one warning at this file."""
    arm = md.load("ur5")
    text = md.to_urdf(arm).replace('ixx="', 'ixx="5', 1)   # an impossible first body
    with pytest.warns(md.PhysicalConsistencyWarning) as record:
        urdf_arm = md.load(text)
    assert record[0].filename == __file__ and urdf_arm.notes


def test_crosscheck_report_prints_the_notes():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.ModelNoteWarning)
        arm = md.load("puma560")
    text = str(md.crosscheck(arm, samples=5))
    for note in arm.notes:
        assert f"note: {note}" in text


def test_track_shows_progress(capsys):
    assert main(["track", "ur5", "--duration", "0.2", "--progress"]) == 0
    err = capsys.readouterr().err
    assert "200/200 steps" in err


# -- 7. help that matches behaviour ------------------------------------------------------------
def test_help_texts(capsys):
    for cmd in ("track", "urdf", "check"):
        with pytest.raises(SystemExit):
            main([cmd, "--help"])
        out = capsys.readouterr().out
        assert ".urdf" in out and "--tip" in out, (cmd, out)
    with pytest.raises(SystemExit):
        main(["urdf", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "OUTDIR the folder to write the .urdf files into" in out


def test_unwritable_outdir_is_one_clear_line(capsys):
    assert main(["urdf", "ur5", "/proc"]) == 2
    line = one_error_line(capsys)
    assert line.startswith("manipdyn urdf: error: OUTDIR /proc: cannot write files in this folder")
    assert "[Errno" not in line


def test_simulate_blames_the_controller_not_the_trajectory():
    ur5 = md.load("ur5")
    from manipdyn.model.links import DHLink

    three = md.Manipulator(list(ur5.links[:3]) + [], convention="standard", name="three")
    assert isinstance(three.links[0], DHLink)
    path = Quintic(np.zeros(3), np.full(3, 0.2), 1.0)
    with pytest.raises(ValueError, match=r"^controller: built for an arm with 6 joints, the arm has 3"):
        md.simulate(three, ComputedTorque(ur5), path, duration=0.1)
    with pytest.raises(ValueError, match=r"^trajectory: has 6 joints, the arm 3"):
        md.simulate(three, ComputedTorque(three), Quintic(np.zeros(6), np.ones(6), 1.0), duration=0.1)


# -- 9. dir(manipdyn) and __all__ ----------------------------------------------------------------
def test_every_public_name_is_listed_and_importable():
    for name in ("load", "compare", "simulate", "crosscheck", "models", "load_with_notes",
                 "CompareReport", "ModelNoteWarning", "SuspiciousValueWarning"):
        assert name in md.__all__ and name in dir(md), name
    for name in md.__all__:
        assert getattr(md, name) is not None, name
    assert callable(md.compare) and callable(md.simulate)


# -- 10. negative gains, and where generated limits come from ----------------------------------
@pytest.mark.parametrize("kw, name", [({"kp": -1.0, "kd": 1.0}, "kp"), ({"kp": 1.0, "kd": [1, 1, 1, 1, 1, -1]}, "kd")])
def test_negative_gains_are_refused(kw, name):
    arm = md.load("ur5")
    with pytest.raises(ValueError, match=rf"^{name}: must be >= 0"):
        PD(arm, **kw)
    with pytest.raises(ValueError, match=rf"^{name}: must be >= 0"):
        ComputedTorque(arm, **kw)


def test_generated_urdf_says_where_limits_came_from():
    from manipdyn.model.links import DHLink

    arm = md.Manipulator([DHLink(a=0.5, mass=1.0, com=(0.25, 0, 0), inertia=(0.01, 0.02, 0.02),
                                 qlim=(-1.0, 1.0)),
                          DHLink(a=0.4, mass=1.0, com=(0.2, 0, 0), inertia=(0.01, 0.02, 0.02))],
                         convention="standard", name="two")
    text = md.to_urdf(arm)
    assert "joint1 limits: lower/upper: the model's qlim" in text
    assert "joint2 limits: lower/upper -3.14159/3.14159 rad: manipdyn's default (DEFAULT_QLIM)" in text
    assert "effort 1000, velocity 10: manipdyn's placeholders" in text
    back = md.load(text)                           # comments do not disturb the readers
    np.testing.assert_allclose(back.qlim, arm.qlim)


def test_suspicious_unit_is_a_note_by_default_and_fails_check_strict(tmp_path, capsys):
    path = tmp_path / "degrees.toml"
    path.write_text(model_text(alpha=90.0))
    args = ["check", str(path), "--samples", "5", "--timing-calls", "0"]
    assert main(args) == 0
    assert "key 'alpha' = 90.0 is more than 2 pi" in capsys.readouterr().out
    assert main(args + ["--strict"]) == 1
