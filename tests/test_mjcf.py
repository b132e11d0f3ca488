"""The MJCF writer (``md.to_mjcf``, ``md.write_mjcf``, ``manipdyn mjcf``) and the account of what
URDF and MJCF cannot hold, shared by both writers (issue 32, items 1 and 4).

MuJoCo is the real one (the ``mujoco`` wheel, in the ``test`` extra); the tests that compile a
file skip, saying so, where it is not installed.
"""

from __future__ import annotations

import hashlib
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from lxml import etree

import manipdyn as md
from manipdyn.formats.losses import format_losses, friction_difference, friction_held
from manipdyn.formats.mjcf import mjcf_losses, model_sha256
from manipdyn.formats.urdf.writer import urdf_losses

from mjcf_arms import drive_arm

ROOT = Path(__file__).resolve().parents[1]
PHYSICAL = [m for m in md.models() if m not in ("puma560", "puma560_akb", "stanford")]


def _mujoco():
    return pytest.importorskip("mujoco", reason="MuJoCo is not installed: MJCF files are not compiled")


def _load(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", md.PhysicalConsistencyWarning)
        return md.load(name)


def _xml(text):
    return etree.fromstring(text.encode("utf-8"))


def _comment(text) -> str:
    return _xml(text).xpath("//comment()")[0].text


def test_the_file_carries_the_arm_by_its_own_names_at_full_precision():
    arm = drive_arm(3, "joint", n=5)
    root = _xml(md.to_mjcf(arm))
    joints, tool = arm.chain()
    assert root.get("model") == arm.name
    assert [b.get("name") for b in root.iter("body")] == arm.link_names()
    assert [j.get("name") for j in root.iter("joint") if j.getparent().tag == "body"] == list(arm.joint_names)
    assert [m.get("joint") for m in root.iter("motor")] == list(arm.joint_names)
    assert [m.get("gear") for m in root.iter("motor")] == ["1"] * arm.n
    # masses, COMs and inertias round-trip exactly (repr floats, not 6 digits)
    for el, j in zip(root.iter("inertial"), joints):
        assert float(el.get("mass")) == j.body.mass
        full = [float(x) for x in el.get("fullinertia").split()]
        I = np.asarray(j.body.inertia)
        ref = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
        big = max(abs(x) for x in ref)
        assert all(a == b or abs(b) <= 1e-13 * big for a, b in zip(full, ref))
    # armature is the rotor inertia reflected through the gear; damping the viscous friction
    for el, a, fv in zip((j for j in root.iter("joint") if j.getparent().tag == "body"), arm.armature,
                         arm.friction_model.viscous):
        assert float(el.get("armature")) == a
        assert float(el.get("damping")) == fv
    assert [float(x) for x in root.find("option").get("gravity").split()] == list(arm.gravity)
    assert root.find(".//site").get("name") == "tool"


def test_the_opening_comment_names_the_model_its_hash_source_and_version():
    arm = md.load("panda")
    text = md.to_mjcf(arm)
    head = _comment(text)
    assert model_sha256(arm) in head
    assert model_sha256(arm) == hashlib.sha256(md.to_toml(arm).encode()).hexdigest()
    assert "Gaz" in head and "panda: written by manipdyn" in head
    from importlib import metadata
    assert metadata.version("manipdyn") in head
    for line in mjcf_losses(arm):
        assert line in head


def test_a_coupled_transmission_is_held_exactly_as_a_tendon():
    mujoco = _mujoco()
    arm = drive_arm(4, "coupled", n=4)
    text = md.to_mjcf(arm)
    root = _xml(text)
    fixed = root.findall("tendon/fixed")
    assert [f.get("name") for f in fixed] == ["motor4"]
    R = arm.transmission.R
    assert {(j.get("joint"), float(j.get("coef"))) for j in fixed[0]} == {("joint3", R[3, 2]), ("joint4", R[3, 3])}
    m = mujoco.MjModel.from_xml_string(text)
    d = mujoco.MjData(m)
    q = arm.random_state(np.random.default_rng(1))
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    M = np.zeros((arm.n, arm.n))
    mujoco.mj_fullM(m, d, M)
    # M - D_links is the rotor inertia R^T diag(Jm) R, off-diagonal coupling included
    rigid = arm.lagrange.mass_matrix(q) - arm.rotor_inertia
    np.testing.assert_allclose(M - rigid, arm.rotor_inertia, rtol=0, atol=1e-13 * np.abs(M).max())
    assert arm.rotor_inertia[3, 2] != 0


def test_coulomb_friction_becomes_frictionloss_and_says_it_is_a_constraint():
    base = drive_arm(5, "joint", n=3)
    law = md.Friction(viscous=[0.5, 0.4, 0.3], coulomb=[1.0, 2.0, 3.0], smoothing=0.0)
    arm = md.Manipulator(base.links, convention=base.convention, gravity=base.gravity, name="coulomb",
                         friction=law)
    root = _xml(md.to_mjcf(arm))
    joints = [j for j in root.iter("joint") if j.getparent().tag == "body"]
    assert [float(j.get("frictionloss")) for j in joints] == [1.0, 2.0, 3.0]
    assert "soft constraint" in _comment(md.to_mjcf(arm))


def test_each_friction_law_says_what_became_of_it_and_how_large_the_difference_is():
    arm = md.load("panda")                  # Gaz's sigmoid
    held, words = friction_held(arm, "mjcf")
    A = arm.friction_model.sigmoid_A
    np.testing.assert_array_equal(held.coulomb, A / 2)       # the mean of the two saturation levels
    diff = friction_difference(arm, held)
    # the figure, recomputed here: the sigmoid against A/2 tanh(v / smoothing) on each joint alone
    law = arm.friction_model
    for k in range(arm.n):
        v = np.linspace(-2.0, 2.0, 801)
        qd = np.zeros((v.size, arm.n))
        qd[:, k] = v
        gap = np.abs(law.torque(qd)[:, k] - A[k] / 2 * np.tanh(v / law.smoothing)).max()
        assert diff[k] == pytest.approx(gap, rel=1e-12)
    line = next(x for x in mjcf_losses(arm) if x.startswith("friction law"))
    assert "sigmoid" in line and f"joint4 {diff[3]:.3g}" in line
    # an offset and Stribeck's dip cannot be held: dropped, and said so
    base = drive_arm(6, "joint", n=2)
    odd = md.Manipulator(base.links, convention=base.convention, gravity=base.gravity, name="odd",
                         friction=md.Friction(viscous=[0.1, 0.1], coulomb=[1.0, 1.0], offset=[0.2, -0.3],
                                              stribeck_level=[0.5, 0.5], stribeck_velocity=[0.1, 0.1]))
    text = " ".join(mjcf_losses(odd))
    assert "offset dropped" in text and "stribeck dropped" in text
    # offset 0.3 on joint 2 plus a Stribeck dip up to 0.5: the figure is at least the offset
    assert friction_difference(odd, friction_held(odd, "mjcf")[0])[1] >= 0.3


def test_physical_bundled_arms_load_in_mujoco_without_a_warning():
    mujoco = _mujoco()
    for name in PHYSICAL:
        arm = md.load(name)
        with warnings.catch_warnings():
            warnings.simplefilter("error")          # nothing to warn about at export
            text = md.to_mjcf(arm)
        m = mujoco.MjModel.from_xml_string(text)
        d = mujoco.MjData(m)
        d.qpos[:] = np.mean(arm.qlim, axis=1)
        for _ in range(200):
            mujoco.mj_step(m, d)
        assert all(w.number == 0 for w in d.warning), name
        assert m.nu == arm.n and m.nsite == 1
        assert abs(float(np.sum(m.body_mass)) - sum(l.mass for l in arm.links)) < 1e-12


@pytest.mark.parametrize("name", ["puma560", "puma560_akb", "stanford"])
def test_bodies_mujoco_refuses_as_published_are_warned_at_export_and_refused_by_mujoco(name):
    # as published (issue 40: --as-published keeps the raw values); the default completes them
    # (tests/test_completion.py)
    mujoco = _mujoco()
    arm = _load(name)
    with pytest.warns(md.PhysicalConsistencyWarning, match="MuJoCo's compiler refuses"):
        text = md.to_mjcf(arm, as_published=True)
    assert "MuJoCo's compiler refuses it" in _comment(text)
    with pytest.raises(ValueError, match="inertia must"):   # the warning is true
        mujoco.MjModel.from_xml_string(text)
    # the URDF says it too: one account for both formats
    assert any("MuJoCo's compiler refuses it" in x for x in urdf_losses(arm))


def test_an_effort_limit_becomes_the_motors_ctrlrange(tmp_path):
    urdf = md.to_urdf(md.load("ur5")).replace('effort="1000.0"', 'effort="150.0"', 1)
    path = tmp_path / "ur5_effort.urdf"
    path.write_text(urdf)
    arm = md.load(str(path))
    motors = _xml(md.to_mjcf(arm)).findall("actuator/motor")
    assert motors[0].get("ctrlrange") == "-150.0 150.0"
    assert [m.get("ctrlrange") for m in motors[1:]] == ["-1000.0 1000.0"] * 5   # the URDF's (placeholders)


# -- item 4: the URDF says what it loses -------------------------------------------------------


def test_the_panda_urdf_says_what_it_loses():
    arm = md.load("panda")
    text = (ROOT / "urdf" / "panda.urdf").read_text()
    head = _comment(text)
    assert "9.80665" in head and "not expressible in URDF" in head
    assert "sigmoid on the joint side: dropped" in head
    assert "PLACEHOLDERS" in head
    for line in urdf_losses(arm):          # the file holds the same account the command prints
        assert line in head
    # the gravity figure is the relative change of every gravity torque
    q = arm.random_state(np.random.default_rng(0))
    g_model = arm.gravity_torque(q)
    g_urdf = g_model * 9.81 / 9.80665
    rel = float(re.search(r"torque by ([0-9.e-]+) relative", head).group(1))
    assert np.abs(g_urdf - g_model).max() / np.abs(g_model).max() == pytest.approx(rel, rel=1e-2)


def test_both_writers_share_one_account():
    arm = md.load("panda")
    u, m = format_losses(arm, "urdf"), format_losses(arm, "mjcf")
    assert u[0].startswith("gravity") and not any(x.startswith("gravity") for x in m)   # MJCF holds gravity
    assert set(m) <= set(mjcf_losses(arm)) and set(u) <= set(urdf_losses(arm))
    rotors = drive_arm(2, "motor", n=3)
    assert any("rotor inertia" in x for x in urdf_losses(rotors))
    assert not any("rotor inertia" in x for x in mjcf_losses(rotors))           # armature holds it


# -- the command -------------------------------------------------------------------------------


def _cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "manipdyn", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=300)


def test_manipdyn_mjcf_writes_one_file_per_model_and_prints_what_is_not_held(tmp_path):
    out = tmp_path / "out"
    r = _cli("mjcf", "panda", "ur5", str(out), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in out.iterdir()) == ["panda.xml", "ur5.xml"]
    assert (out / "panda.xml").read_text() == md.to_mjcf(md.load("panda"))
    assert "not held: friction law (sigmoid" in r.stdout
    bad = _cli("mjcf", "panda", cwd=tmp_path)
    assert bad.returncode == 2 and "missing OUTDIR" in bad.stderr and len(bad.stderr.splitlines()) == 1
    model = tmp_path / "m.toml"
    md.save(md.load("ur5"), model)
    onto = _cli("mjcf", str(model), str(tmp_path), cwd=tmp_path)
    assert onto.returncode == 0                         # m.xml beside m.toml: no input overwritten
    assert model.read_text() == md.to_toml(md.load("ur5"))


def test_write_mjcf_is_atomic_and_round_trips(tmp_path):
    arm = md.load("ur5e")
    path = tmp_path / "ur5e.xml"
    md.write_mjcf(arm, path)
    assert path.read_text() == md.to_mjcf(arm)
    assert not [p for p in tmp_path.iterdir() if p != path]        # no temporary left behind
