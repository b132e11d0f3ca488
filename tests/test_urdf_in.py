"""URDF input: ``manipdyn.formats.urdf.reader.load_urdf`` on vendor files and on bad input.

What is checked, and against what:

* every serial arm of example-robot-data (and Panda, Talos and others cut to an
  arm with ``tip=``): the trace-form engine on manipdyn's own reading of the
  URDF against the Pinocchio engine (``md.crosscheck``: D, h, g, tau, forward
  dynamics, tip pose, energies on 200 seeded states);
* the same arms against Pinocchio reading the ORIGINAL vendor file directly
  (no continuous-joint rewrite: ``(cos, sin)`` coordinates; for a tree, a
  reduced model built here), so that neither the rewrite nor the engine
  wrapper can hide an error; for Panda, the lumped bodies one by one;
* seeded random URDF trees (fixed joints with rotations, unaligned and
  non-unit axes, prismatic and continuous joints, locked side branches) against
  Pinocchio with the side branches made ``fixed``: an independent lumping;
* ``md.to_urdf(arm)`` read back by Pinocchio and by ``load_urdf``;
* malformed or hostile input raises :class:`ModelError` naming file and element.

Tolerance: ``TOL = 1e-9`` relative to ``max(1, max|reference|)`` (the
cross-check's own).  Both sides are float64 computations of O(10..100)
operations on O(1..100) quantities and agree to ~1e-14 (observed <= 4e-15
for D, h, g, tau).  Forward dynamics solves with D, which loses up to
log10(cond D) digits: cond(D) <= 2.4e4 for the arms (observed qdd error
<= 2.3e-12), but 4.7e6 for Tiago cut at its arm (a 1000-kg-scale prismatic
torso beside a light wrist), where the observed error is 1.3e-10, still 7x
inside the tolerance.  A modelling error (a wrong frame, a sign, a lost body)
shows at 1e-3 or more.  Lumped mass properties are
sums of a handful of 4x4 products: ``LUMP_TOL = 1e-12``.
"""

from __future__ import annotations

import math
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn import ModelError
from manipdyn.model.arm import DEFAULT_QLIM
from manipdyn._support.errors import ToolFrameWarning
from manipdyn.formats.erd import robots_dir
from manipdyn.formats.urdf.reader import URDFArm, load_urdf

import pinocchio as pin  # noqa: E402

TOL = 1e-9        # see the module docstring
LUMP_TOL = 1e-12  # see the module docstring
SAMPLES = 200


# ---------------------------------------------------------------------------
# example-robot-data
# ---------------------------------------------------------------------------
ERD = robots_dir()  # a declared dependency: a broken install fails, it is not skipped


def needs_erd(f):
    return f

# (id, file under robots/, tip, expected joints).  tip=None: the file's movable
# joints are serial.  Panda's gripper fingers branch (two prismatic joints, one
# a mimic): it needs tip=.  Talos' left-arm file has <mimic> only on fixed
# joints, which have nothing to couple: serial as it is.
ROBOTS = [
    ("ur3", "ur_description/urdf/ur3_robot.urdf", None, 6),
    ("ur5", "ur_description/urdf/ur5_robot.urdf", None, 6),
    ("ur10", "ur_description/urdf/ur10_robot.urdf", None, 6),
    ("ur5-tool0", "ur_description/urdf/ur5_robot.urdf", "tool0", 6),
    ("so100", "so_arm_description/urdf/so100.urdf", None, 6),
    ("so101", "so_arm_description/urdf/so101.urdf", None, 6),
    ("xarm7", "xarm_description/urdf/xarm7.urdf", None, 7),
    ("z1", "z1_description/urdf/z1.urdf", None, 7),
    ("talos_left_arm", "talos_data/robots/talos_left_arm.urdf", None, 7),
    ("finger_edu", "finger_edu_description/robots/finger_edu.urdf", None, 3),
    ("double_pendulum", "double_pendulum_description/urdf/double_pendulum.urdf", None, 2),
    ("double_pendulum_continuous", "double_pendulum_description/urdf/double_pendulum_continuous.urdf", None, 2),
    ("double_pendulum_simple", "double_pendulum_description/urdf/double_pendulum_simple.urdf", None, 2),
    ("kinova", "kinova_description/robots/kinova.urdf", None, 6),
    ("twodofs", "asr_twodof_description/urdf/TwoDofs.urdf", None, 2),
    ("panda-link8", "panda_description/urdf/panda.urdf", "panda_link8", 7),
    ("panda-hand", "panda_description/urdf/panda.urdf", "panda_hand", 7),
    ("talos-full-left-arm", "talos_data/robots/talos_full_v2.urdf", "arm_left_7_link", 9),
    ("tiago-arm", "tiago_description/robots/tiago_no_hand.urdf", "arm_7_link", 8),
]
ROBOT_IDS = [r[0] for r in ROBOTS]

_cache: dict = {}


def robot(rid) -> URDFArm:
    if rid not in _cache:
        _, rel, tip, _ = next(r for r in ROBOTS if r[0] == rid)
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # vendor inertias of moving links are physical
            warnings.simplefilter("ignore", ToolFrameWarning)   # the UR files' tool0/ee_link: a note, tested elsewhere
            _cache[rid] = load_urdf(ERD / rel, tip=tip)
    return _cache[rid]


def states(arm, seed=0, samples=SAMPLES):
    rng = np.random.default_rng(seed)
    q = arm.random_state(rng, samples)
    qd = rng.uniform(-2.0, 2.0, (samples, arm.n))
    qdd = rng.uniform(-5.0, 5.0, (samples, arm.n))
    return q, qd, qdd


def assert_close(actual, ref, what, tol=TOL):
    actual = np.asarray(actual, dtype=float)
    ref = np.asarray(ref, dtype=float)
    assert actual.shape == ref.shape, f"{what}: shapes {actual.shape} vs {ref.shape}"
    N = ref.shape[0]
    err = np.abs(actual - ref).reshape(N, -1).max(axis=1)
    scale = np.maximum(1.0, np.abs(ref).reshape(N, -1).max(axis=1))
    rel = err / scale
    i = int(np.argmax(rel))
    assert rel[i] <= tol, f"{what}: relative error {rel[i]:.3e} > {tol:g} at sample {i}"


def pin_config(model, q):
    """Pinocchio configuration of joint angles q (nv), (cos, sin) for unbounded joints."""
    q = np.asarray(q, dtype=float)
    out = np.empty(q.shape[:-1] + (model.nq,))
    for jm in list(model.joints)[1:]:
        iq, iv = jm.idx_q, jm.idx_v
        if jm.nq == 2 and jm.nv == 1:
            out[..., iq] = np.cos(q[..., iv])
            out[..., iq + 1] = np.sin(q[..., iv])
        else:
            assert jm.nq == jm.nv == 1, jm.shortname()
            out[..., iq] = q[..., iv]
    return out


def pin_terms(model, q, qd, qdd):
    """D, g, tau (no friction) of a Pinocchio model for angle states q (N, nv)."""
    data = model.createData()
    qp = pin_config(model, q)
    D = np.array([pin.crba(model, data, x) for x in qp])
    g = np.array([pin.computeGeneralizedGravity(model, data, x) for x in qp])
    tau = np.array([pin.rnea(model, data, x, v, a) for x, v, a in zip(qp, qd, qdd)])
    return D, g, tau


# ---------------------------------------------------------------------------
# Vendor arms: the two engines agree
# ---------------------------------------------------------------------------
@needs_erd
@pytest.mark.parametrize("rid", ROBOT_IDS)
def test_engines_agree_on_vendor_arm(rid):
    arm = robot(rid)
    assert arm.n == next(r[3] for r in ROBOTS if r[0] == rid)
    report = md.crosscheck(arm, samples=SAMPLES, seed=1)
    assert report.ok, str(report)
    assert report["fk"].max_rel <= TOL
    assert arm.tool_frame == arm.tip


@needs_erd
@pytest.mark.parametrize("rid", ["ur5", "panda-hand", "kinova", "so101", "talos-full-left-arm"])
def test_engines_agree_direct(rid):
    """The same as the cross-check, written out (it does not depend on md.crosscheck)."""
    arm = robot(rid)
    q, qd, qdd = states(arm)
    L, P = arm.lagrange, arm.pinocchio
    D, h, g = L.dynamics_terms(q, qd)
    assert_close(D, P.mass_matrix(q), "D")
    assert_close(h, P.coriolis_torque(q, qd), "h")
    assert_close(g, P.gravity_torque(q), "g")
    tau = P.inverse_dynamics(q, qd, qdd)
    assert_close(L.inverse_dynamics(q, qd, qdd), tau, "tau")
    assert_close(L.forward_dynamics(q, qd, tau), qdd, "forward dynamics")
    assert_close(arm.fkine(q), P.frame_placement(q, arm.tip), "tip pose")


@needs_erd
@pytest.mark.parametrize("rid", [r[0] for r in ROBOTS])
def test_vendor_file_read_by_pinocchio_directly(rid):
    """Pinocchio on the untouched vendor text (continuous joints as (cos, sin);
    for a tree, buildReducedModel here with the locked joints at neutral)."""
    arm = robot(rid)
    _, rel, tip, _ = next(r for r in ROBOTS if r[0] == rid)
    with open(ERD / rel, encoding="utf-8") as fh:
        model = pin.buildModelFromXML(fh.read())
    if arm.locked_joints:
        ids = [model.getJointId(nm) for nm in arm.locked_joints]
        model = pin.buildReducedModel(model, ids, pin.neutral(model))
    assert tuple(model.names)[1:] == arm.joint_names
    assert model.nv == arm.n
    q, qd, qdd = states(arm, seed=2, samples=60)
    D, g, tau = pin_terms(model, q, qd, qdd)
    friction = arm.lagrange.friction_torque(qd)  # Pinocchio's rnea has none
    for eng in (arm.lagrange, arm.pinocchio):
        assert_close(eng.mass_matrix(q), D, f"{eng.name} D")
        assert_close(eng.gravity_torque(q), g, f"{eng.name} g")
        assert_close(eng.inverse_dynamics(q, qd, qdd) - friction, tau, f"{eng.name} tau")
    # tip pose against the vendor model's BODY frame of the tip link
    data = model.createData()
    fid = model.getFrameId(arm.tip, pin.BODY)
    poses = []
    for x in pin_config(model, q):
        pin.framesForwardKinematics(model, data, x)
        poses.append(data.oMf[fid].homogeneous.copy())
    assert_close(arm.fkine(q), np.array(poses), "tip pose")


@needs_erd
@pytest.mark.parametrize("tip", ["panda_link8", "panda_hand"])
def test_panda_lumped_bodies_match_reduced_model(tip):
    """Hand and fingers lumped into link 7: body by body against Pinocchio's
    buildReducedModel of the full file, and the total mass of the file."""
    arm = robot("panda-link8" if tip == "panda_link8" else "panda-hand")
    assert arm.locked_joints == ("panda_finger_joint1", "panda_finger_joint2")
    assert arm.tip == tip
    text = (ERD / "panda_description/urdf/panda.urdf").read_text(encoding="utf-8")
    full = pin.buildModelFromXML(text)
    red = pin.buildReducedModel(full, [full.getJointId(n) for n in arm.locked_joints], pin.neutral(full))
    joints, tool = arm.chain()
    for k, j in enumerate(joints):
        I = red.inertias[k + 1]
        scale = max(1.0, I.mass)
        assert abs(j.body.mass - I.mass) <= LUMP_TOL * scale, j.name
        np.testing.assert_allclose(j.body.com, I.lever, rtol=0, atol=LUMP_TOL * 10)
        np.testing.assert_allclose(j.body.inertia, I.inertia, rtol=0,
                                   atol=LUMP_TOL * max(1.0, np.abs(I.inertia).max()))
    # nothing lost: the moving mass is every link's mass after the base link
    moving_mass = sum(I.mass for I in list(full.inertias)[1:])
    assert math.isclose(sum(j.body.mass for j in joints), moving_mass, rel_tol=1e-13)
    assert "panda_leftfinger" in arm.lumped_links[-1]
    # the tool transform: link 7 -> tip, as Pinocchio places the tip frame
    data = red.createData()
    qn = pin.neutral(red)
    pin.framesForwardKinematics(red, data, qn)
    T7 = data.oMi[7].homogeneous
    Ttip = data.oMf[red.getFrameId(tip, pin.BODY)].homogeneous
    np.testing.assert_allclose(np.linalg.solve(T7, Ttip), tool, atol=1e-14)


@needs_erd
def test_panda_without_tip_names_the_branch():
    with pytest.raises(ModelError, match=r"panda\.urdf.*branch at link 'panda_hand'.*tip="):
        load_urdf(ERD / "panda_description/urdf/panda.urdf")


@needs_erd
def test_panda_finger_tip_is_a_mimic_chain():
    with pytest.raises(ModelError, match=r"panda\.urdf.*panda_finger_joint2.*mimic"):
        load_urdf(ERD / "panda_description/urdf/panda.urdf", tip="panda_leftfinger")


@needs_erd
def test_default_tips_and_attributes():
    ur5 = robot("ur5")  # wrist_3_link has two fixed children (ee_link, tool0): stop there
    assert ur5.tip == "wrist_3_link" and ur5.root == "world"
    np.testing.assert_array_equal(ur5.chain()[1], np.eye(4))
    assert robot("xarm7").tip == "link_eef"  # one fixed child: followed
    assert robot("so101").tip == "moving_jaw_so101_v1_link"
    assert ur5.source == "URDF file ur5_robot.urdf"
    assert ur5.name == "ur5"
    assert ur5.joint_names == ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                               "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
    assert ur5.link_names[-1] == "wrist_3_link"
    assert ur5.joint_types == ("revolute",) * 6
    assert ur5.locked_joints == ()
    np.testing.assert_array_equal(ur5.armature, np.zeros(6))
    assert ur5.friction is None  # <dynamics damping="0.0" friction="0.0"/>
    np.testing.assert_array_equal(robot("xarm7").friction, [[10, 10, 5, 5, 5, 2, 2], [1] * 7])
    assert ur5.gravity.shape == (3,)
    with pytest.raises(ValueError):
        ur5.gravity[2] = 0.0
    text = (ERD / "ur_description/urdf/ur5_robot.urdf").read_text(encoding="utf-8")
    assert ur5.urdf_text == text
    # continuous joints and "0 0" limits (a CAD exporter's "none"): the default range
    for rid in ("double_pendulum_continuous", "double_pendulum", "kinova"):
        arm = robot(rid)
        assert np.all(arm.qlim[:, 1] > arm.qlim[:, 0])
    np.testing.assert_array_equal(robot("double_pendulum_continuous").qlim,
                                  [DEFAULT_QLIM["revolute"]] * 2)
    assert robot("double_pendulum_continuous").pinocchio.model.nq == 2
    assert "URDFArm 'ur5'" in repr(ur5) and "wrist_3_link" in repr(ur5)
    assert "2 locked" in repr(robot("panda-hand"))


@needs_erd
def test_text_path_and_equality():
    path = ERD / "ur_description/urdf/ur3_robot.urdf"
    a = load_urdf(path)
    b = load_urdf(path.read_text(encoding="utf-8"))
    c = load_urdf(path.read_bytes())
    assert a == b == c
    assert b.source == "URDF text (robot 'ur3')"
    assert a != load_urdf(path, tip="tool0")
    assert a != load_urdf(path, gravity=(0, 0, 9.81))
    assert a != load_urdf(path, name="other")
    q = a.random_state(np.random.default_rng(3), 5)
    np.testing.assert_array_equal(a.lagrange.mass_matrix(q), b.lagrange.mass_matrix(q))
    # gravity reaches both engines
    up = load_urdf(path, gravity=(0.0, 0.0, 9.81))
    assert_close(up.lagrange.gravity_torque(q), -a.pinocchio.gravity_torque(q), "g reversed")
    assert_close(up.pinocchio.gravity_torque(q), -a.lagrange.gravity_torque(q), "g reversed")


@needs_erd
@pytest.mark.parametrize("rid", ["ur5", "panda-hand", "kinova", "finger_edu", "talos-full-left-arm"])
def test_to_urdf_round_trip(rid):
    """md.to_urdf(arm) (the generic writer on arm.chain()) read back by Pinocchio and by load_urdf."""
    arm = robot(rid)
    text = md.to_urdf(arm)
    model = pin.buildModelFromXML(text)
    model.gravity.linear = np.array(arm.gravity)
    assert model.nq == model.nv == arm.n
    q, qd, qdd = states(arm, seed=4, samples=60)
    D, g, tau = pin_terms(model, q, qd, qdd)
    P = arm.pinocchio
    assert_close(D, P.mass_matrix(q), "D")
    assert_close(g, P.gravity_torque(q), "g")
    h = tau - np.einsum("bij,bj->bi", D, qdd) - g
    assert_close(h, P.coriolis_torque(q, qd), "h")
    back = load_urdf(text)
    assert back.joint_names == arm.joint_names
    assert_close(back.lagrange.mass_matrix(q), arm.lagrange.mass_matrix(q), "D after round trip")
    assert_close(back.fkine(q), arm.fkine(q), "tool pose after round trip")


# ---------------------------------------------------------------------------
# Random URDF trees: lumping and general frames against Pinocchio
# ---------------------------------------------------------------------------
def _f(x):
    return " ".join(repr(float(v)) for v in np.atleast_1d(x))


def _inertial(rng):
    m = rng.uniform(0.2, 5.0)
    a, b = rng.uniform(0.01, 0.2, 2)
    c = rng.uniform(abs(a - b) + 1e-3, a + b)  # principal moments of a real body
    return (f'<inertial><origin xyz="{_f(rng.uniform(-0.2, 0.2, 3))}" rpy="{_f(rng.uniform(-3, 3, 3))}"/>'
            f'<mass value="{_f(m)}"/><inertia ixx="{_f(a)}" iyy="{_f(b)}" izz="{_f(c)}" ixy="0" ixz="0" iyz="0"/>'
            "</inertial>")


def random_tree(seed):
    """A random URDF tree, its tip, and the same tree with the off-chain joints fixed."""
    rng = np.random.default_rng(seed)
    links, joints = [], []
    counter = iter(range(1000))

    def link(inertial=True):
        name = f"L{next(counter)}"
        links.append(f'<link name="{name}">{_inertial(rng) if inertial else ""}</link>')
        return name

    def joint(parent, child, jtype, locked=False):
        name = f"J{len(joints)}_{jtype}"
        axis = [[1, 0, 0], [0, 1, 0], [0, 0, 1], list(rng.uniform(-2, 2, 3))][rng.integers(4)]
        lim = ""
        if jtype == "revolute":
            lim = f'<limit lower="{_f(-rng.uniform(0.5, 3))}" upper="{_f(rng.uniform(0.5, 3))}" effort="10" velocity="2"/>'
        elif jtype == "prismatic":
            lim = '<limit lower="-0.4" upper="0.6" effort="10" velocity="2"/>'
        joints.append((name, locked,
                       f'<joint name="{name}" type="{jtype}"><parent link="{parent}"/><child link="{child}"/>'
                       f'<origin xyz="{_f(rng.uniform(-0.3, 0.3, 3))}" rpy="{_f(rng.uniform(-3, 3, 3))}"/>'
                       f'<axis xyz="{_f(axis)}"/>{lim}</joint>'))
        return name

    movable = ["revolute", "continuous", "prismatic"]
    root = link(inertial=bool(rng.integers(2)))  # the base's inertia is ignored by both
    parent = root
    for _ in range(rng.integers(0, 2)):  # fixed joints before the first movable one
        child = link(bool(rng.integers(2)))
        joint(parent, child, "fixed")
        parent = child
    n = int(rng.integers(1, 6))
    for k in range(n):
        # massless frames are allowed, but not at the end: that joint would move nothing
        child = link(inertial=rng.random() < 0.8 or k == n - 1)
        joint(parent, child, movable[rng.integers(3)] if rng.random() < 0.7 else "revolute")
        parent = child
        for _ in range(rng.integers(0, 3)):  # fixed links lumped into this body
            child = link(inertial=rng.random() < 0.7)
            joint(parent, child, "fixed")
            parent = child
        if rng.random() < 0.5:  # a side branch, locked at 0 (or fixed), with a body after it
            side = link()
            joint(parent, side, movable[rng.integers(3)] if rng.random() < 0.7 else "fixed", locked=True)
            if rng.random() < 0.5:
                joint(side, link(), "revolute", locked=True)
    tip = parent
    for _ in range(rng.integers(0, 3)):  # beyond the tip: lumped too
        child = link()
        joint(parent, child, movable[rng.integers(3)] if rng.random() < 0.5 else "fixed", locked=True)
        parent = child
    head = f'<?xml version="1.0"?>\n<robot name="random{seed}">\n'
    text = head + "\n".join(links + [j[2] for j in joints]) + "\n</robot>\n"
    fixed = head + "\n".join(links + [_as_fixed(j[2]) if j[1] else j[2] for j in joints]) + "\n</robot>\n"
    return text, tip, fixed


def _as_fixed(joint_xml):
    import re

    out = re.sub(r'type="\w+"', 'type="fixed"', joint_xml, count=1)
    return re.sub(r"<axis[^>]*/>|<limit[^>]*/>", "", out)


@pytest.mark.parametrize("seed", range(24))
def test_random_tree_against_pinocchio(seed):
    text, tip, fixed = random_tree(seed)
    arm = load_urdf(text, tip=tip)
    report = md.crosscheck(arm, samples=60, seed=seed)
    assert report.ok, str(report) + "\n" + text
    # independent of buildReducedModel: Pinocchio merging the locked joints as fixed ones
    model = pin.buildModelFromXML(fixed)
    assert tuple(model.names)[1:] == arm.joint_names
    q, qd, qdd = states(arm, seed=seed, samples=40)
    D, g, tau = pin_terms(model, q, qd, qdd)
    L = arm.lagrange
    assert_close(L.mass_matrix(q), D, "D")
    assert_close(L.gravity_torque(q), g, "g")
    assert_close(L.inverse_dynamics(q, qd, qdd), tau, "tau")


# ---------------------------------------------------------------------------
# Small hand-checked chains
# ---------------------------------------------------------------------------
def urdf(body: str, name: str = "t") -> str:
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n{body}\n</robot>\n'


def LINK(name, mass=None, xyz="0 0 0", rpy="0 0 0", ixx=0.01, iyy=0.01, izz=0.01):
    if mass is None:
        return f'<link name="{name}"/>'
    return (f'<link name="{name}"><inertial><origin xyz="{xyz}" rpy="{rpy}"/><mass value="{mass}"/>'
            f'<inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="0" ixz="0" iyz="0"/></inertial></link>')


def JOINT(name, parent, child, jtype="revolute", xyz="0 0 0", rpy="0 0 0", axis="0 0 1", extra=None):
    lim = '<limit lower="-1" upper="1" effort="1" velocity="1"/>' if jtype in ("revolute", "prismatic") else ""
    return (f'<joint name="{name}" type="{jtype}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>{lim if extra is None else extra}</joint>')


ONE = urdf("\n".join([LINK("base"), LINK("l1", 1.0, xyz="0.5 0 0"),
                      JOINT("j1", "base", "l1")]))


def test_fixed_child_is_lumped_by_hand():
    """Joint about z; link l1 (1 kg at x=0.5) and, through a fixed joint at x=1
    turned 90 deg about z, link l2 (2 kg at its own x=0.5, i.e. (1, 0.5) in l1).
    D = sum (Izz + m r^2) = 0.01 + 0.25 + 0.01 + 2 * (1 + 0.25)."""
    text = urdf("\n".join([
        LINK("base", 7.0), LINK("l1", 1.0, xyz="0.5 0 0"), LINK("l2", 2.0, xyz="0.5 0 0"),
        JOINT("j1", "base", "l1"),
        JOINT("f", "l1", "l2", "fixed", xyz="1 0 0", rpy="0 0 1.5707963267948966"),
    ]))
    arm = load_urdf(text)
    (j,), tool = arm.chain()
    assert arm.tip == "l2" and arm.lumped_links == (("l1", "l2"),)
    assert math.isclose(j.body.mass, 3.0)
    np.testing.assert_allclose(j.body.com, [(0.5 + 2 * 1.0) / 3, 1.0 / 3, 0.0], atol=1e-15)
    D = arm.lagrange.mass_matrix([0.3])
    assert math.isclose(D[0, 0], 0.01 + 0.25 + 0.01 + 2 * 1.25, rel_tol=1e-14)
    np.testing.assert_allclose(tool[:3, 3], [1, 0, 0], atol=1e-15)
    assert_close(arm.pinocchio.mass_matrix([[0.3]]), D[None], "pinocchio D")


def test_base_bodies_are_ignored_and_massless_frame_is_fine():
    text = urdf("\n".join([
        LINK("world"), LINK("base", 5.0), LINK("l1"), LINK("l2", 1.0, xyz="0 0 1"),
        JOINT("fix", "world", "base", "fixed", xyz="0 0 2"),
        JOINT("j1", "base", "l1", axis="1 0 0"),
        JOINT("j2", "l1", "l2", "prismatic", axis="0 0 2"),
    ]))
    arm = load_urdf(text)
    assert arm.joint_types == ("revolute", "prismatic")
    joints, _ = arm.chain()
    assert joints[0].body.mass == 0.0  # massless frame l1
    np.testing.assert_allclose(joints[1].axis, [0, 0, 1])
    np.testing.assert_allclose(joints[0].origin[:3, 3], [0, 0, 2])
    report = md.crosscheck(arm, samples=50, seed=0)
    assert report.ok, str(report)


def test_joint_moving_no_mass_warns():
    text = urdf("\n".join([LINK("base"), LINK("a", 1.0, xyz="0.5 0 0"), LINK("b"),
                           JOINT("j1", "base", "a"), JOINT("j2", "a", "b")]))
    with pytest.warns(md.PhysicalConsistencyWarning, match=r"joint 'j2': moves no mass"):
        arm = load_urdf(text)
    assert arm.lagrange.mass_matrix([0.1, 0.2])[1, 1] == 0.0


def test_friction_from_dynamics():
    dyn = '<limit lower="-1" upper="1" effort="1" velocity="1"/><dynamics damping="0.5" friction="0.2"/>'
    text = urdf("\n".join([LINK("base"), LINK("l1", 1.0, xyz="0.5 0 0"),
                           JOINT("j1", "base", "l1", extra=dyn)]))
    arm = load_urdf(text)
    np.testing.assert_array_equal(arm.friction, [[0.5], [0.2]])
    tau_l = arm.lagrange.inverse_dynamics([0.1], [1.0], [0.0])
    tau_p = arm.pinocchio.inverse_dynamics([0.1], [1.0], [0.0])
    np.testing.assert_allclose(tau_l, tau_p, rtol=0, atol=1e-14)
    assert load_urdf(ONE).friction is None


def test_one_joint_arm_batch_shapes():
    """A one-joint URDF arm: batch results keep their (N, 1) shape in both engines
    (Pinocchio's parallel RNEA/ABA hand back a flat vector when n == 1)."""
    arm = load_urdf(ONE)
    q = np.linspace(-1, 1, 5)[:, None]
    for eng in (arm.lagrange, arm.pinocchio):
        assert eng.inverse_dynamics(q, q, q).shape == (5, 1), eng.name
        assert eng.forward_dynamics(q, q, q).shape == (5, 1), eng.name
        assert eng.gravity_torque(q).shape == (5, 1), eng.name
        assert eng.mass_matrix(q).shape == (5, 1, 1), eng.name


def test_trace_form_path_never_imports_pinocchio(tmp_path):
    """The trace-form engine on a URDF works with Pinocchio made unimportable."""
    p = tmp_path / "one.urdf"
    p.write_text(ONE, encoding="utf-8")
    code = (
        "import sys; sys.modules['pinocchio'] = None\n"
        "import numpy as np\n"
        "from manipdyn.formats.urdf.reader import load_urdf\n"
        f"arm = load_urdf({str(p)!r})\n"
        "print(arm.lagrange.mass_matrix(np.zeros(1))[0, 0])\n"
        "try:\n    arm.pinocchio\nexcept ImportError:\n    print('blocked')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.split()
    assert math.isclose(float(lines[0]), 0.01 + 0.25) and lines[1] == "blocked"


# ---------------------------------------------------------------------------
# Bad input
# ---------------------------------------------------------------------------
XXE = ('<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n'
       '<robot name="&x;"><link name="base"/></robot>')
BOMB = ('<?xml version="1.0"?>\n<!DOCTYPE lolz [\n <!ENTITY lol "lol">\n'
        + "".join(f' <!ENTITY lol{i} "{("&lol" + (str(i - 1) if i > 1 else "") + ";") * 10}">\n'
                  for i in range(1, 10))
        + ']>\n<robot name="&lol9;"><link name="base"/></robot>')


def test_xxe_in_a_file_is_refused(tmp_path):
    p = tmp_path / "evil.urdf"
    p.write_text(XXE, encoding="utf-8")
    with pytest.raises(ModelError, match=r"URDF file evil\.urdf: refused: .*entities"):
        load_urdf(p)


def test_xxe_text_and_external_dtd_are_refused():
    with pytest.raises(ModelError, match=r"refused: .*entities"):
        load_urdf(XXE)
    with pytest.raises(ModelError, match=r"refused: .*external DTD"):
        load_urdf('<!DOCTYPE robot SYSTEM "http://example.com/urdf.dtd">\n<robot name="r"/>')
    # UTF-16 (with a BOM) is decoded before the check; without a BOM it is refused as NUL
    with pytest.raises(ModelError, match=r"refused: .*entities"):
        load_urdf(XXE.replace('<?xml version="1.0"?>', "").encode("utf-16"))
    with pytest.raises(ModelError, match=r"NUL"):
        load_urdf(XXE.replace('<?xml version="1.0"?>', "").encode("utf-16-le"))


def test_billion_laughs_is_refused_not_expanded():
    t0 = time.perf_counter()
    with pytest.raises(ModelError, match=r"URDF text: refused: .*entities"):
        load_urdf(BOMB)
    assert time.perf_counter() - t0 < 1.0


def test_any_doctype_is_refused():
    # even a plain one: libxml2 and urdfdom read DOCTYPEs differently (issue 11)
    with pytest.raises(ModelError, match=r"refused: a DOCTYPE at line 1"):
        load_urdf("<!DOCTYPE robot>\n" + ONE.split("\n", 1)[1])


BAD = {
    "branch without tip": (
        urdf("\n".join([LINK("base"), LINK("hand", 1.0), LINK("f1", 0.1), LINK("f2", 0.1),
                        JOINT("j1", "base", "hand"), JOINT("jf1", "hand", "f1", "prismatic"),
                        JOINT("jf2", "hand", "f2", "prismatic")])),
        {}, r"branch at link 'hand'.*tip=",
    ),
    "loop": (
        urdf("\n".join([LINK("base"), LINK("a", 1.0), LINK("b", 1.0),
                        JOINT("j1", "base", "a"), JOINT("j2", "a", "b"), JOINT("j3", "base", "b")])),
        {}, r"line \d+, joint 'j3': link 'b' already has the parent joint 'j2'.*loop",
    ),
    "cycle without root": (
        urdf("\n".join([LINK("a", 1.0), LINK("b", 1.0),
                        JOINT("j1", "a", "b"), JOINT("j2", "b", "a")])),
        {}, r"no root link.*loop",
    ),
    "floating joint": (
        urdf("\n".join([LINK("world"), LINK("base", 1.0), LINK("l1", 1.0),
                        JOINT("free", "world", "base", "floating"), JOINT("j1", "base", "l1")])),
        {}, r"joint 'free': floating joints are not supported",
    ),
    "planar joint": (
        urdf("\n".join([LINK("world"), LINK("base", 1.0),
                        JOINT("p", "world", "base", "planar")])),
        {}, r"joint 'p': planar joints are not supported",
    ),
    "no inertial anywhere": (
        urdf("\n".join([LINK("base", 3.0), LINK("a"), LINK("b"),
                        JOINT("j1", "base", "a"), JOINT("j2", "a", "b")])),
        {}, r"no <inertial> on any moving link \('a', 'b'\)",
    ),
    "unknown tip": (ONE, {"tip": "hand"},
                    r"unknown tip link 'hand'; choose the chain with tip='<link name>'; the leaf links are 'l1'; "
                    r"all 2 links: 'base', 'l1'"),
    "tip before any joint": (ONE, {"tip": "base"}, r"no movable joint between the root link 'base' and the tip 'base'"),
    "malformed number": (ONE.replace('value="1.0"', 'value="1.0.0"'), {},
                         r'line \d+, link \'l1\' <inertial>: <mass value="1.0.0">: not a finite number'),
    "NaN mass": (ONE.replace('value="1.0"', 'value="nan"'), {}, r"<mass value=\"nan\">: not a finite number"),
    "inf inertia": (ONE.replace('izz="0.01"', 'izz="1e999"'), {}, r"izz=\"1e999\">: not a finite number"),
    "short vector": (ONE.replace('xyz="0.5 0 0"', 'xyz="0.5 0"'), {}, r"expected 3 finite numbers"),
    "missing inertia attribute": (ONE.replace(' ixy="0"', ""), {}, r"<inertia> is missing the attribute 'ixy'"),
    "missing mass": (ONE.replace('<mass value="1.0"/>', ""), {}, r"link 'l1' <inertial>: missing the <mass> element"),
    "negative mass": (ONE.replace('value="1.0"', 'value="-1"'), {}, r"'mass' must be >= 0"),
    "missing child": (ONE.replace('<child link="l1"/>', ""), {}, r"joint 'j1': missing the <child> element"),
    "undefined link": (ONE.replace('<child link="l1"/>', '<child link="l9"/>'), {}, r"child link 'l9' is not defined"),
    "revolute without limit": (ONE.replace('<limit lower="-1" upper="1" effort="1" velocity="1"/>', ""),
                               {}, r"joint 'j1': missing the <limit> element"),
    "limit without effort": (ONE.replace(' effort="1"', ""), {}, r"<limit> is missing the attribute 'effort'"),
    "inverted limits": (ONE.replace('lower="-1" upper="1"', 'lower="1" upper="-1"'), {}, r"lower < upper"),
    "zero axis": (ONE.replace('axis xyz="0 0 1"', 'axis xyz="0 0 0"'), {}, r'<axis xyz="0 0 0">: must be a direction'),
    "unknown joint type": (ONE.replace('type="revolute"', 'type="hinge"'), {}, r"unknown joint type 'hinge'"),
    "duplicate link": (ONE.replace('<link name="base"/>', '<link name="base"/><link name="base"/>'), {},
                       r"link 'base': duplicate link name"),
    "not xml": ("<robot name='r'><link name='a'></robot>", {}, r"not well-formed XML"),
    "not a robot": ("<model/>", {}, r"root element is <model>, expected <robot>"),
    "no links": ('<robot name="r"/>', {}, r"no <link>"),
    "mimic in chain": (
        urdf("\n".join([LINK("base"), LINK("a", 1.0), LINK("b", 1.0), JOINT("j1", "base", "a"),
                        JOINT("j2", "a", "b", extra='<limit lower="-1" upper="1" effort="1" velocity="1"/>'
                              '<mimic joint="j1" multiplier="2"/>')])),
        {}, r"joint 'j2': mimic joints are not supported",
    ),
    "locked mimic with offset": (
        urdf("\n".join([LINK("base"), LINK("a", 1.0), LINK("b", 1.0), LINK("c", 1.0),
                        JOINT("j1", "base", "a"), JOINT("j2", "base", "b"),
                        JOINT("j3", "base", "c", extra='<limit lower="-1" upper="1" effort="1" velocity="1"/>'
                              '<mimic joint="j2" offset="0.5"/>')])),
        {"tip": "a"}, r"joint 'j3': mimic joints are not supported.*offset 0.5",
    ),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_input_raises_model_error(case):
    text, kw, pattern = BAD[case]
    with pytest.raises(ModelError, match=pattern) as info:
        load_urdf(text, **kw)
    assert str(info.value).startswith("URDF text")


def test_bad_file_is_named(tmp_path):
    p = tmp_path / "arm.urdf"
    p.write_text(BAD["floating joint"][0], encoding="utf-8")
    with pytest.raises(ModelError, match=r"^URDF file arm\.urdf, line \d+, joint 'free'"):
        load_urdf(p)
    with pytest.raises(ModelError, match=r"URDF file missing\.urdf: cannot read"):
        load_urdf(tmp_path / "missing.urdf")


def test_strict_refuses_impossible_inertia():
    bad = ONE.replace('izz="0.01"', 'izz="0.5"')  # Ixx + Iyy < Izz
    with pytest.warns(md.PhysicalConsistencyWarning, match="link 'l1'"):
        load_urdf(bad)
    with pytest.raises(ModelError, match=r"link 'l1' <inertial>: physically impossible"):
        load_urdf(bad, strict=True)
