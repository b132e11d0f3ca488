"""``compare(a, b)``: are two descriptions the same arm?

* acceptance: the bundled UR5 (Universal Robots' DH table) against
  example-robot-data's ``ur5_robot.urdf`` (read with ``md.load``) agree in
  kinematics to 1e-6 m after alignment, and the report names the transforms,
  joint offsets and dynamics differences;
* ``compare(a, a)`` is the identity with zero error, for every bundled model;
* a synthetic second description with known base, tool, joint signs and
  offsets (written as a URDF) is recovered;
* different joint counts or types are a one-line ModelError;
* the ``manipdyn compare`` command.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import arms
import manipdyn as md
from manipdyn import cli
from manipdyn.check.compare import KIN_TOLERANCE, CompareReport, compare
from manipdyn.check.compare.canonical import canonical_chain
from manipdyn.formats.erd import robots_dir
from manipdyn.model.kinematics import matrix_to_rpy, rot_x, rot_y, rot_z, trans

ROOT = Path(__file__).resolve().parents[1]


ERD = robots_dir()  # a declared dependency: a broken install fails, it is not skipped


def needs_erd(f):
    return f


def load(spec, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(spec, **kw)


# ---------------------------------------------------------------------------
# Acceptance: UR5 DH table vs the vendor's URDF
# ---------------------------------------------------------------------------
@needs_erd
def test_ur5_dh_table_matches_example_robot_data_urdf():
    dh = load("ur5")
    urdf = md.load(ERD / "ur_description" / "urdf" / "ur5_robot.urdf")
    r = compare(dh, urdf, samples=300, seed=1)
    assert isinstance(r, CompareReport)
    assert r.fk_error < 1e-6 and r.rot_error < 1e-6, str(r)
    assert r.same_kinematics
    # what it found: same joint directions and zeros; the ROS base is UR's base
    # turned half a turn about z; the URDF's tip (wrist_3_link) sits at the
    # wrist centre, 0.0823 m behind DH frame 6, turned 90 deg about x
    assert r.joint_signs == (1,) * 6
    assert np.all(np.abs(r.joint_offsets) < 1e-9)
    np.testing.assert_allclose(r.base, rot_z(math.pi), atol=1e-9)
    np.testing.assert_allclose(r.tool, trans(0, 0, -0.0823) @ rot_x(math.pi / 2), atol=1e-9)
    # the dynamics differ: cylinder estimates on both sides, and the URDF's
    # forearm is 2.275 kg where UR's page says 2.33 kg
    assert set(r.dynamics) == {"D", "h", "g"}
    for q in r.dynamics.values():
        assert np.isfinite(q.max_abs) and np.isfinite(q.max_rel)
    assert r.dynamics["g"].max_rel > 0.01
    masses = {m["link"]: m for m in r.masses}
    assert masses[3]["mass_a"] == pytest.approx(2.33) and masses[3]["mass_b"] == pytest.approx(2.275)
    text = str(r)
    for word in ("NOT THE SAME ARM", "base", "tool", "offset", "D ", "h ", "g ", "mass"):
        assert word in text, text


@needs_erd
@pytest.mark.parametrize("model, urdf, tip", [
    ("ur10", "ur_description/urdf/ur10_robot.urdf", None),
    ("panda", "panda_description/urdf/panda.urdf", "panda_link7"),
])
def test_other_bundled_models_match_their_example_robot_data_urdf(model, urdf, tip):
    b = md.load(ERD / urdf, tip=tip) if tip else md.load(ERD / urdf)
    r = compare(load(model), b, samples=200)
    assert r.same_kinematics, str(r)
    assert r.joint_signs == (1,) * r.n
    assert np.all(np.abs(r.joint_offsets) < 1e-9)


def test_two_puma_parameter_sets_differ_by_a_millimetre():
    """Corke's consensus (standard DH) and Armstrong-Khatib-Burdick (modified DH):
    the same robot with d4 = 0.4318 m vs 0.4331 m: aligned, the tools differ by ~1.3 mm."""
    r = compare(load("puma560"), load("puma560_akb"), samples=200)
    assert not r.same_kinematics
    assert 1e-4 < r.fk_error < 3e-3, str(r)


# ---------------------------------------------------------------------------
# compare(a, a)
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("name", md.models())
def test_compare_with_itself_is_the_identity(name):
    arm = load(name)
    r = compare(arm, arm, samples=50)
    assert r.fk_error < 1e-12 and r.rot_error < 1e-12
    assert r.joint_signs == (1,) * arm.n
    np.testing.assert_array_equal(r.joint_offsets, np.zeros(arm.n))
    np.testing.assert_allclose(r.base, np.eye(4), atol=1e-12)
    np.testing.assert_allclose(r.tool, np.eye(4), atol=1e-12)
    for q in r.dynamics.values():
        assert q.max_abs < 1e-12
    assert all(m["diff"] == 0 for m in r.masses)
    assert not r.notes


@pytest.mark.parametrize("name", md.models())
def test_bundled_model_against_its_own_urdf_file(name):
    arm = load(name)
    r = compare(arm, load(ROOT / "urdf" / f"{name}.urdf"), samples=50)
    assert r.fk_error < 1e-12 and r.rot_error < 1e-12
    np.testing.assert_allclose(r.base, np.eye(4), atol=1e-12)
    np.testing.assert_allclose(r.tool, np.eye(4), atol=1e-12)
    assert r.dynamics["D"].max_rel < 1e-12 and r.dynamics["h"].max_rel < 1e-12
    assert r.dynamics["g"].max_rel < 1e-12 or name == "panda"  # panda states g = 9.80665, the URDF reader 9.81


def test_chain_form_reproduces_forward_kinematics():
    for name in md.models():
        arm = load(name)
        ch = canonical_chain(arm)
        for q in arm.random_state(np.random.default_rng(2), 5):
            np.testing.assert_allclose(ch.fk(q), arm.fkine(q), atol=1e-13)


# ---------------------------------------------------------------------------
# Synthetic: a second description with a known base, tool, signs and offsets
# ---------------------------------------------------------------------------
def _axis_motion(u, joint, x):
    u = np.asarray(u, dtype=np.float64)
    if joint == "prismatic":
        return trans(*(x * u))
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    T = np.eye(4)
    T[:3, :3] = np.eye(3) + math.sin(x) * K + (1 - math.cos(x)) * K @ K
    return T


def _f(*xs) -> str:
    return " ".join(repr(float(x)) for x in xs)


def _origin_xml(T):
    return f'<origin xyz="{_f(*T[:3, 3])}" rpy="{_f(*matrix_to_rpy(T[:3, :3]))}"/>'


def redescribe(arm, base, tool, signs, offsets) -> str:
    """URDF of ``arm`` described so that T_b(q) = base @ T_a(sign * q + offset) @ tool."""
    joints, tool_a = arm.chain()
    parts = ['<robot name="redescribed">', '<link name="world"/>', '<link name="mount"/>',
             f'<joint name="mount_joint" type="fixed"><parent link="world"/><child link="mount"/>'
             f'{_origin_xml(base)}</joint>']
    parent = "mount"
    for k, j in enumerate(joints):
        b = j.body
        I = b.inertia
        parts.append(
            f'<link name="L{k}"><inertial><origin xyz="{_f(*b.com)}" rpy="0 0 0"/>'
            f'<mass value="{_f(b.mass)}"/><inertia ixx="{_f(I[0, 0])}" ixy="{_f(I[0, 1])}" ixz="{_f(I[0, 2])}" '
            f'iyy="{_f(I[1, 1])}" iyz="{_f(I[1, 2])}" izz="{_f(I[2, 2])}"/></inertial></link>')
        origin = j.origin @ _axis_motion(j.axis, j.joint, offsets[k])
        ax = signs[k] * np.asarray(j.axis)
        lim = "-3.0" if j.joint == "revolute" else "-0.4", "3.0" if j.joint == "revolute" else "0.4"
        parts.append(
            f'<joint name="J{k}" type="{j.joint}"><parent link="{parent}"/><child link="L{k}"/>'
            f'{_origin_xml(origin)}<axis xyz="{_f(*ax)}"/>'
            f'<limit lower="{lim[0]}" upper="{lim[1]}" effort="1" velocity="1"/></joint>')
        parent = f"L{k}"
    parts.append('<link name="tcp"/>')
    parts.append(f'<joint name="tcp_joint" type="fixed"><parent link="{parent}"/><child link="tcp"/>'
                 f'{_origin_xml(tool_a @ tool)}</joint>')
    parts.append("</robot>")
    return "\n".join(parts)


BASE = trans(0.3, -0.2, 0.5) @ rot_z(0.7) @ rot_y(-0.4) @ rot_x(1.1)
TOOL = trans(0.01, 0.02, 0.15) @ rot_x(-0.3) @ rot_z(2.0)


@pytest.mark.parametrize("seed, n, prismatic", [(1, 6, 0.0), (2, 7, 0.0), (3, 6, 0.3), (4, 5, 0.5)])
def test_synthetic_redescription_is_recovered(seed, n, prismatic):
    rng = np.random.default_rng(100 + seed)
    a = arms.random_arm(seed, n=n, prismatic_fraction=prismatic, rotors=False)
    signs = tuple(int(s) for s in rng.choice([-1, 1], n))
    offsets = np.where(np.array(a.joint_types) == "revolute", rng.uniform(-3.0, 3.0, n), rng.uniform(-0.2, 0.2, n))
    offsets[0] = offsets[-1] = 0.0   # the gauge joints: their offsets are part of base/tool
    b = load(redescribe(a, BASE, TOOL, signs, offsets))
    r = compare(a, b, samples=100, seed=seed)
    assert r.fk_error < 1e-9 and r.rot_error < 1e-9, str(r)
    assert r.joint_signs == signs, str(r)
    np.testing.assert_allclose(r.joint_offsets, offsets, atol=1e-9)
    np.testing.assert_allclose(r.base, BASE, atol=1e-9)
    np.testing.assert_allclose(r.tool, TOOL, atol=1e-9)
    # the same arm in the same world: equal dynamics (a's gravity is b's,
    # rotated into a's base by the base found)
    for name, q in r.dynamics.items():
        assert q.max_rel < 1e-9, (name, q)
    np.testing.assert_allclose(r.gravity_used_a, BASE[:3, :3].T @ np.array([0.0, 0.0, -9.81]), atol=1e-12)


def test_end_joint_offsets_are_folded_into_base_and_tool():
    """Joint 1's offset is a rotation of the base about joint 1's axis, the last
    joint's a rotation of the tool about the last axis: compare reports them there."""
    a = arms.random_arm(7, n=6, prismatic_fraction=0.0, rotors=False)
    signs = (1, -1, 1, 1, -1, 1)
    offsets = np.array([0.8, 0.3, -1.2, 2.0, 0.1, -0.6])
    b = md.load(redescribe(a, BASE, TOOL, signs, offsets))
    r = compare(a, b, samples=100)
    assert r.fk_error < 1e-9 and r.joint_signs == signs
    np.testing.assert_allclose(r.joint_offsets, [0.0, 0.3, -1.2, 2.0, 0.1, 0.0], atol=1e-9)
    joints, tool_a = a.chain()
    j0, jn = joints[0], joints[-1]
    R1 = j0.origin @ _axis_motion(j0.axis, j0.joint, offsets[0]) @ np.linalg.inv(j0.origin)
    np.testing.assert_allclose(r.base, BASE @ R1, atol=1e-9)
    Rn = np.linalg.inv(tool_a) @ _axis_motion(jn.axis, jn.joint, offsets[-1]) @ tool_a
    np.testing.assert_allclose(r.tool, Rn @ TOOL, atol=1e-9)


def test_bundled_arm_redescribed_with_flips_and_offsets():
    """On a real arm with right-angle axes several alignments are exact (the wrist
    flip): compare finds one of them, with zero error and equal dynamics."""
    a = load("ur5")
    signs = (-1, 1, -1, -1, 1, -1)
    offsets = np.array([0.0, 0.5, -2.0, 1.0, 3.0, 0.0])
    r = compare(a, md.load(redescribe(a, BASE, TOOL, signs, offsets)), samples=100)
    assert r.fk_error < 1e-9 and r.rot_error < 1e-9, str(r)
    for q in r.dynamics.values():
        assert q.max_rel < 1e-9


# ---------------------------------------------------------------------------
# Errors and the command line
# ---------------------------------------------------------------------------
def test_different_joint_count_is_a_verdict_not_an_error():
    r = compare(load("ur5"), load("panda"))
    assert not r.same_arm and r.kinematics == "different" and r.dynamics_verdict == "not compared"
    assert "6 joints" in r.structure and "7" in r.structure
    assert r.verdict().startswith("NOT THE SAME ARM")


def test_different_joint_type_is_a_verdict_not_an_error():
    r = compare(load("stanford"), load("ur5"))
    assert not r.same_arm
    assert "joint 3" in r.structure and "prismatic" in r.structure and "revolute" in r.structure


def test_bad_samples():
    with pytest.raises(ValueError):
        compare(load("ur5"), load("ur5"), samples=0)


def test_md_compare_is_callable():
    r = md.compare("ur5", "ur5", samples=10)
    assert isinstance(r, CompareReport) and r.same_kinematics


def test_cli_same_arm(capsys):
    code = cli.main(["compare", "ur5", str(ROOT / "urdf" / "ur5.urdf"), "--samples", "20"])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "SAME ARM" in out


def test_cli_json(capsys):
    code = cli.main(["compare", "puma560", "puma560_akb", "--samples", "20", "--json"])
    d = json.loads(capsys.readouterr().out)
    assert code == 1
    assert d["same_kinematics"] is False and d["fk_error_m"] > KIN_TOLERANCE
    assert len(d["joint_signs"]) == 6 and len(d["base"]) == 4
    assert set(d["dynamics"]) == {"D", "h", "g"}
    assert any("link 1" in n for n in d["load_notes"])  # the massless Puma link 1


def test_cli_joint_count_mismatch_exits_1_as_the_help_promises(capsys):
    code = cli.main(["compare", "stanford", "ur5"])
    out = capsys.readouterr().out
    assert code == 1
    assert "NOT THE SAME ARM" in out and "joint 3" in out


def test_rounded_angles_in_a_description():
    """A URDF that writes pi/2 as 1.5708 (as many do): its 'parallel' axes are
    tilted by 3.7e-6 rad.  The alignment still finds the joint map; the tool
    differs by tens of micrometres, above the same-arm tolerance."""
    a = load("ur5")
    text = redescribe(a, np.eye(4), np.eye(4), (1,) * 6, np.zeros(6))
    text = text.replace("1.5707963267948966", "1.5708").replace("1.5707963267948963", "1.5708")
    assert "1.5708" in text
    r = compare(a, load(text), samples=100)
    assert r.joint_signs == (1,) * 6, str(r)
    assert np.all(np.abs(r.joint_offsets) < 1e-4), str(r)
    assert 1e-6 < r.fk_error < 1e-4, str(r)
