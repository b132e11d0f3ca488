"""compare's two verdicts (kinematics, dynamics), labels, rounding and exit codes (issue 13, finding 1)."""

from __future__ import annotations

import dataclasses
import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import manipdyn as md
from manipdyn import cli
from manipdyn.check.compare import DYN_TOLERANCE, KIN_REMAPPED, KIN_SAME, compare
from manipdyn.formats.erd import urdf_path
from test_compare import BASE, TOOL, redescribe

ROOT = Path(__file__).resolve().parents[1]


def load(spec, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(spec, **kw)


def test_ur5_against_example_robot_data_is_not_the_same_arm(capsys):
    """Same kinematics (other base and tool frames), far-apart dynamics: exit 1, and say why."""
    erd = str(urdf_path("ur5_robot"))
    code = cli.main(["compare", "ur5", erd, "--samples", "50"])
    out = capsys.readouterr().out
    assert code == 1, out
    first = out.splitlines()[1]
    assert first.startswith("NOT THE SAME ARM: kinematics the same") and "dynamics DIFFERENT" in first
    assert "most responsible" in first
    # both sides named, and differently: the file name when the robot names clash
    assert "a = 'ur5' with b = 'ur5_robot.urdf'" in out
    # no rounding noise printed as an offset
    assert not re.search(r"e-\d+ deg", out), out


def test_ur5_report_fields():
    r = compare(load("ur5"), md.load(urdf_path("ur5_robot")), samples=50)
    assert r.kinematics == KIN_SAME and r.same_kinematics
    assert r.dynamics_verdict == "different" and not r.same_arm
    assert r.worst_quantity.max_rel > DYN_TOLERANCE
    resp = r.responsible
    assert resp is not None and 1 <= resp["link"] <= 6 and 0 < resp["share"] <= 1
    for key in ("mass_a", "mass_b", "com_a", "com_b", "inertia_a", "inertia_b"):
        assert key in resp
    np.testing.assert_array_equal(r.joint_offsets, np.zeros(6))   # below tolerance -> exactly 0


def test_one_link_changed_is_the_link_blamed():
    """Make link 3 heavier: dynamics differ, and link 3 is the one reported, with both masses."""
    a = load("ur5")
    links = list(a.links)
    links[2] = dataclasses.replace(links[2], mass=links[2].mass * 1.5)
    b = md.Manipulator(links, convention=a.convention, gravity=a.gravity, name="ur5 heavier forearm")
    r = compare(a, b, samples=50)
    assert r.kinematics == KIN_SAME and r.dynamics_verdict == "different"
    assert r.responsible["link"] == 3, r.responsible
    assert r.responsible["mass_b"] == pytest.approx(1.5 * r.responsible["mass_a"])


def test_same_arm_exit_0_and_json(capsys):
    code = cli.main(["compare", "ur5", str(ROOT / "urdf" / "ur5.urdf"), "--samples", "20", "--json"])
    d = json.loads(capsys.readouterr().out)
    assert code == 0
    assert d["same_arm"] is True and d["kinematics"] == "same" and d["dynamics_verdict"] == "same"
    assert d["verdict"].startswith("SAME ARM")


def test_flipped_and_offset_joints_are_the_same_arm_only_up_to_the_joint_map():
    a = load("ur5")
    signs = (1, -1, 1, 1, 1, 1)
    offsets = np.array([0.0, 0.5, 0.0, 0.0, 0.0, 0.0])
    r = compare(a, md.load(redescribe(a, BASE, TOOL, signs, offsets)), samples=50)
    assert r.kinematics == KIN_REMAPPED and r.remapped_joints == [2]
    assert r.same_dynamics              # the same bodies, matched states
    assert not r.same_arm                # the same q does not give the same arm
    assert "same up to the signs/offsets of joints [2]" in r.verdict()


def test_rotor_inertia_counts_in_the_dynamics_verdict():
    """puma560 (Corke) and puma560_akb state different rotor inertias: named in the verdict."""
    r = compare(load("puma560"), load("puma560_akb"), samples=20)
    assert r.rotor is not None and not r.rotor.same
    assert "rotor inertia" in r.verdict()


def test_same_name_arms_get_distinct_labels():
    arm = load("ur5")
    r = compare(arm, arm, samples=5)
    assert r.a != r.b and r.same_arm
