"""Model files: round trip, units, and the errors that name the file and key."""

from __future__ import annotations

import math

import numpy as np
import pytest

import manipdyn as md
from manipdyn.formats.modelfile import model_to_toml, parse_model

GOOD = """
format = "manipdyn-model/1"
name = "two"
convention = "modified"
gravity = [0.0, -9.81, 0.0]
source = "made up for the test"

[units]
length = "mm"
angle = "deg"
mass = "g"

[[links]]
joint = "revolute"
a = 0.0
alpha = 0.0
d = 100.0
theta = 90.0
qlim = [-90.0, 90.0]
mass = 2000.0
com = [10.0, 0.0, 0.0]
inertia = { ixx = 1000.0, iyy = 2000.0, izz = 2500.0, ixy = 10.0 }

[[links]]
joint = "prismatic"
a = 300.0
alpha = -90.0
d = 0.0
theta = 0.0
qlim = [0.0, 200.0]
mass = 500.0
com = [0.0, 0.0, 50.0]
inertia = [[100.0, 0.0, 0.0], [0.0, 100.0, 0.0], [0.0, 0.0, 50.0]]
motor_inertia = 1.0
gear_ratio = 10.0
friction_viscous = 0.5
friction_coulomb = 0.1
"""


def test_units_are_converted_to_si():
    arm = parse_model(GOOD, "good.toml")
    l1, l2 = arm.links
    assert l1.d == pytest.approx(0.1) and l1.theta == pytest.approx(math.pi / 2)
    assert l1.qlim == pytest.approx((-math.pi / 2, math.pi / 2))
    assert l1.mass == pytest.approx(2.0)
    assert l1.com == pytest.approx([0.01, 0, 0])
    # inertia in g mm^2 -> kg m^2; ixy given, ixz/iyz default 0; tensor symmetric
    assert l1.inertia[0, 1] == l1.inertia[1, 0] == pytest.approx(10e-9)
    assert l1.inertia[2, 2] == pytest.approx(2500e-9)
    assert l2.qlim == pytest.approx((0.0, 0.2))   # prismatic limits are lengths
    assert l2.alpha == pytest.approx(-math.pi / 2) and l2.a == pytest.approx(0.3)
    assert l2.motor_inertia == pytest.approx(1e-9)
    assert arm.gravity.tolist() == [0.0, -9.81, 0.0]


def test_save_load_round_trip_is_exact(tmp_path):
    arm = parse_model(GOOD, "good.toml")
    path = tmp_path / "two.toml"
    md.save(arm, path)
    back = md.load(str(path))
    assert back == arm
    for a, b in zip(arm.links, back.links):
        assert np.array_equal(a.inertia, b.inertia) and a.friction_viscous == b.friction_viscous


@pytest.mark.filterwarnings("ignore::manipdyn.PhysicalConsistencyWarning")
@pytest.mark.parametrize("name", ["puma560", "stanford"])
def test_bundled_round_trip(tmp_path, name):
    arm = md.load(name)
    md.save(arm, tmp_path / "m.toml")
    assert md.load(str(tmp_path / "m.toml")) == arm
    assert model_to_toml(md.load(str(tmp_path / "m.toml"))) == model_to_toml(arm)


def _bad(text, match):
    with pytest.raises(md.ModelError, match=match):
        parse_model(text, "arm.toml")


def test_missing_key():
    _bad(GOOD.replace('convention = "modified"\n', ""), r"arm\.toml: missing key 'convention'")
    _bad(GOOD.replace("d = 100.0\n", "", 1), r"arm\.toml: links\[0\]: missing key 'd'")


def test_unknown_key():
    _bad(GOOD.replace('name = "two"', 'name = "two"\ncolour = "red"'), r"arm\.toml: unknown key\(s\) \['colour'\]")
    _bad(GOOD.replace("theta = 90.0", "theta = 90.0\nlenght = 1.0"), r"links\[0\]: unknown key\(s\) \['lenght'\]")
    _bad(GOOD.replace("ixy = 10.0", "ixy = 10.0, iyx = 1.0"), r"links\[0\]: key 'inertia': unknown key")


def test_wrong_type():
    _bad(GOOD.replace("mass = 2000.0", 'mass = "2 kg"'), r"links\[0\]: key 'mass': expected a number, got str")
    _bad(GOOD.replace("mass = 2000.0", "mass = true"), r"key 'mass': expected a number, got bool")
    _bad(GOOD.replace("com = [10.0, 0.0, 0.0]", "com = [10.0, 0.0]"), r"key 'com': expected a list of 3 numbers")
    _bad(GOOD.replace('joint = "prismatic"', 'joint = "helical"'), r"links\[1\]: key 'joint' must be 'revolute' or 'prismatic'")


def test_unknown_unit():
    _bad(GOOD.replace('length = "mm"', 'length = "furlong"'), r"arm\.toml: key 'units\.length' has unit 'furlong'.*m, cm, mm, in")
    _bad(GOOD.replace('angle = "deg"', 'angle = "grad"'), r"key 'units\.angle' has unit 'grad'")


def test_six_vector_inertia_is_refused():
    _bad(GOOD.replace("inertia = [[100.0, 0.0, 0.0], [0.0, 100.0, 0.0], [0.0, 0.0, 50.0]]",
                      "inertia = [1.0, 2.0, 3.0, 0.0, 0.0, 0.0]"), r"links\[1\]: key 'inertia': expected a table")


def test_not_toml():
    _bad("name = ", r"arm\.toml: not valid TOML")


def test_physical_problem_names_file_link_and_condition():
    text = GOOD.replace("ixx = 1000.0, iyy = 2000.0, izz = 2500.0, ixy = 10.0", "ixx = 100.0, iyy = 2000.0, izz = 1000.0")
    with pytest.warns(md.PhysicalConsistencyWarning, match=r"two: link 1: .*triangle inequality Ixx \+ Izz >= Iyy broken"):
        parse_model(text, "arm.toml")
    with pytest.raises(md.ModelError, match="triangle inequality"):
        parse_model(text, "arm.toml", strict=True)


def test_unknown_name_lists_bundled_models():
    with pytest.raises(md.ModelError, match=r"unknown model 'nope'.*puma560.*stanford"):
        md.load("nope")


def test_missing_file_names_it(tmp_path):
    with pytest.raises(md.ModelError, match=r"missing\.toml: cannot read model file"):
        md.load(str(tmp_path / "missing.toml"))


def test_save_refuses_nothing_half_written(tmp_path):
    arm = parse_model(GOOD, "good.toml")
    target = tmp_path / "out.toml"
    target.write_text("previous")
    import manipdyn.formats.modelfile as mf

    def boom(_arm):
        raise md.ModelError("cannot serialise")

    real = mf.model_to_toml
    mf.model_to_toml = boom
    try:
        with pytest.raises(md.ModelError):
            md.save(arm, target)
    finally:
        mf.model_to_toml = real
    assert target.read_text() == "previous"


def test_round_trip_keeps_description_and_quotes_odd_source_keys(tmp_path):
    arm = parse_model(GOOD.replace('source = "made up for the test"',
                                   'source = "made up for the test"\ndescription = "two links"'), "g.toml")
    assert arm.description == "two links"
    odd = md.Manipulator(arm.links, convention=arm.convention, name="odd", source="s",
                         sources={"data sheet": "p. 3", "x.y": "z"}, description="d")
    md.save(odd, tmp_path / "odd.toml")
    back = md.load(str(tmp_path / "odd.toml"))
    assert back == odd and back.sources == {"data sheet": "p. 3", "x.y": "z"}


def test_massless_first_moment_is_refused():
    with pytest.raises(md.ModelError, match=r"first moments .* but mass 0"):
        md.LinkInertia.from_chapter_terms(0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
