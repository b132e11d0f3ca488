"""DH -> URDF converter: structure, exact FK round trip through yourdfpy, atomic writes."""

from __future__ import annotations

import io
import math
import os
import re

import numpy as np
import pytest
import yourdfpy

import manipdyn as md
from manipdyn.formats.urdf.writer import DEFAULT_EFFORT, DEFAULT_VELOCITY


def _arm(convention):
    """A 4-joint arm with every DH field non-zero and full inertia tensors."""
    rot = np.array([[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])
    inertia = rot @ np.diag([0.02, 0.03, 0.04]) @ rot.T
    links = [
        md.DHLink(a=0.1, alpha=math.pi / 2, d=0.3, theta=0.2, mass=3.0, com=(0.01, 0.02, -0.1),
                  inertia=inertia, qlim=(-2.0, 2.5)),
        md.DHLink(joint="prismatic", a=0.05, alpha=-0.7, d=0.1, theta=-0.4, mass=2.0,
                  com=(0.0, 0.05, 0.02), inertia=inertia * 0.5, qlim=(0.0, 0.4)),
        md.DHLink(a=0.25, alpha=0.3, d=-0.05, theta=1.1, mass=1.5, com=(0.1, 0.0, 0.01),
                  inertia=inertia * 0.3),
        md.DHLink(a=0.0, alpha=-math.pi / 2, d=0.08, theta=0.0, mass=0.5, com=(0.0, 0.0, 0.03),
                  inertia=inertia * 0.1, name="wrist"),
    ]
    return md.Manipulator(links, convention=convention, name=f"test_{convention}")


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_structure_and_full_precision_floats(convention):
    arm = _arm(convention)
    text = md.to_urdf(arm)
    assert "np.float64" not in text
    robot = yourdfpy.URDF.load(io.BytesIO(text.encode()), build_scene_graph=False, load_meshes=False).robot
    assert [l.name for l in robot.links] == ["base_link", "link1", "link2", "link3", "wrist", "tool"]
    assert [j.type for j in robot.joints] == ["revolute", "prismatic", "revolute", "revolute", "fixed"]
    assert robot.joints[-1].child == "tool"
    # limits from qlim, defaults from DEFAULT_QLIM, effort/velocity defaults documented
    lim = robot.joints[0].limit
    assert (lim.lower, lim.upper) == (-2.0, 2.5)
    assert (lim.effort, lim.velocity) == (DEFAULT_EFFORT, DEFAULT_VELOCITY)
    assert robot.joints[2].limit.lower == -math.pi
    # every number is written so that it reads back to the same float
    for m in re.finditer(r'(?:xyz|rpy)="([^"]+)"', text):
        for tok in m.group(1).split():
            assert float(repr(float(tok))) == float(tok)


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_yourdfpy_fk_matches_link_poses(convention):
    """FK of every URDF link read back by yourdfpy matches arm.link_poses to 1e-12.

    URDF link i is joint i's frame after its motion; DH frame i is that frame
    times the fixed S_i of arm.urdf_link_offsets() (identity for modified DH).
    """
    arm = _arm(convention)
    urdf = yourdfpy.URDF.load(io.BytesIO(md.to_urdf(arm).encode()), build_scene_graph=True, load_meshes=False)
    S = arm.urdf_link_offsets()
    rng = np.random.default_rng(3)
    names = ["link1", "link2", "link3", "wrist"]
    for _ in range(20):
        q = arm.random_state(rng)
        urdf.update_cfg(q)
        T = arm.link_poses(q)
        for i, name in enumerate(names):
            np.testing.assert_allclose(urdf.get_transform(name, "base_link") @ S[i], T[i], rtol=0, atol=1e-12)
        np.testing.assert_allclose(urdf.get_transform("tool", "base_link"), arm.fkine(q), rtol=0, atol=1e-12)


def test_inertial_is_transformed_into_urdf_link_frame():
    """The body read back from the URDF, moved into DH frame i, is the link's own."""
    arm = _arm("standard")
    robot = yourdfpy.URDF.load(io.BytesIO(md.to_urdf(arm).encode()), build_scene_graph=False, load_meshes=False).robot
    S = arm.urdf_link_offsets()
    for i, l in enumerate(arm.links):
        inert = robot.links[i + 1].inertial
        body = md.LinkInertia(inert.mass, inert.origin[:3, 3], inert.origin[:3, :3] @ inert.inertia @ inert.origin[:3, :3].T)
        back = body.transformed(md.transform_inverse(S[i]))
        np.testing.assert_allclose(back.com, l.com, atol=1e-15)
        np.testing.assert_allclose(back.inertia, l.inertia, atol=1e-15)
        assert back.mass == l.mass


def test_write_urdf_is_atomic(tmp_path, monkeypatch):
    arm = _arm("standard")
    path = tmp_path / "arm.urdf"
    path.write_text("old content")
    import manipdyn._support.files as files

    real_replace = os.replace

    def boom(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(files.os, "replace", boom)
    with pytest.raises(OSError, match="disk full"):
        md.write_urdf(arm, path)
    assert path.read_text() == "old content"          # old file untouched
    assert sorted(os.listdir(tmp_path)) == ["arm.urdf"]  # no temp file left behind
    monkeypatch.setattr(files.os, "replace", real_replace)
    md.write_urdf(arm, path)
    assert path.read_text() == md.to_urdf(arm)


def test_write_urdf_conversion_failure_leaves_no_file(tmp_path, monkeypatch):
    arm = _arm("standard")
    import manipdyn.formats.save as uo

    def fail(_arm, **_kw):
        raise md.ModelError("conversion failed")

    monkeypatch.setattr(uo, "arm_to_urdf", fail)
    with pytest.raises(md.ModelError, match="conversion failed"):
        md.write_urdf(arm, tmp_path / "x.urdf")
    assert os.listdir(tmp_path) == []


def test_urdf_loads_in_pinocchio_with_joint_order():
    import pinocchio as pin

    arm = _arm("modified")
    model = pin.buildModelFromXML(md.to_urdf(arm))
    assert list(model.names)[1:] == ["joint1", "joint2", "joint3", "joint4"]
    assert model.nq == model.nv == 4


def test_point_in_base_is_eq_2_8():
    arm = _arm("standard")
    q = np.array([0.3, 0.1, -0.4, 0.9])
    p = np.array([0.1, -0.2, 0.3])
    T = arm.link_poses(q)
    for k in range(1, 5):
        np.testing.assert_allclose(arm.point_in_base(q, p, link=k), (T[k - 1] @ np.append(p, 1.0))[:3], atol=1e-15)
    # the origin of the last frame is the end position
    np.testing.assert_allclose(arm.point_in_base(q, np.zeros(3)), arm.fkine(q)[:3, 3], atol=1e-15)
    assert arm.point_in_base(np.tile(q, (5, 1)), p).shape == (5, 3)
    with pytest.raises(ValueError, match="link: expected a link number 1..4"):
        arm.point_in_base(q, p, link=5)
