"""A URDF prior for identification: ``fit`` on a ``md.load``ed URDF arm returns a URDF arm, and
``manipdyn identify ARM.urdf DATA -o OUT.urdf`` writes the same URDF with only the chain links'
``<inertial>`` identified."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from lxml import etree

import manipdyn as md
from manipdyn.model.arm import URDFArm
from manipdyn.cli import main

pytest.importorskip("cvxpy", reason="identification needs the identify extra (cvxpy)")
from manipdyn.identification import excitation, fit, write_measurements_csv  # noqa: E402

UR5 = Path(__file__).resolve().parent.parent / "urdf" / "ur5.urdf"
#: each chain link's mass and inertia scaled by its factor (COM kept): a different, physical arm
FACTORS = {"shoulder": 1.1, "upper_arm": 0.9, "forearm": 1.2, "wrist_1": 0.8, "wrist_2": 1.15, "wrist_3": 1.05}


def _perturbed_text() -> str:
    """ur5.urdf with the masses and inertias scaled (by the test, not by the code under test)."""
    root = etree.fromstring(UR5.read_bytes())
    for link in root.iterchildren("link"):
        k = FACTORS.get(link.get("name"))
        inertial = link.find("inertial")
        if k is None or inertial is None:
            continue
        m = inertial.find("mass")
        m.set("value", repr(k * float(m.get("value"))))
        I = inertial.find("inertia")
        for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
            I.set(a, repr(k * float(I.get(a))))
    return etree.tostring(root, encoding="unicode")


def _without_inertials_and_comments(text: str) -> str:
    root = etree.fromstring(text.encode())
    for el in list(root.iter("inertial")) + list(root.iter(etree.Comment)):
        el.getparent().remove(el)
    for el in root.iter():
        el.text = el.tail = None
    return etree.tostring(root, encoding="unicode")


@pytest.fixture(scope="module")
def urdf_data(tmp_path_factory):
    prior = md.load(str(UR5))
    truth = md.load(_perturbed_text())
    ex = excitation(prior, duration=6.0, harmonics=3, rate=100.0, iterations=0)
    tau = truth.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    path = tmp_path_factory.mktemp("urdf") / "log.csv"
    write_measurements_csv(path, ex.t, ex.q, tau, qd=ex.qd, qdd=ex.qdd)
    return prior, truth, ex, tau, path


def test_fit_on_a_urdf_arm_returns_a_urdf_arm(urdf_data):
    prior, truth, ex, tau, _ = urdf_data
    r = fit(prior, ex.q, ex.qd, ex.qdd, tau, method="consistent")
    assert isinstance(r.arm, URDFArm) and r.arm_error is None
    assert r.arm.joint_names == prior.joint_names and r.arm.link_names == prior.link_names
    assert r.arm.tip == prior.tip
    # exact data: the identified arm predicts the truth's torques to 1e-7 of their RMS (the
    # consistent fit holds the base parameters to ~1e-10 of the largest; see test_fit_scaling)
    rms = np.sqrt(np.mean(tau**2, axis=0))
    pred = r.arm.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    assert np.all(np.sqrt(np.mean((pred - tau) ** 2, axis=0)) <= 1e-7 * rms)
    np.testing.assert_allclose(pred, r.predict(ex.q, ex.qd, ex.qdd), rtol=0, atol=1e-9 * rms.max())


def test_identify_writes_the_same_urdf_with_new_inertials(urdf_data, tmp_path, capsys):
    prior, truth, ex, tau, path = urdf_data
    out = tmp_path / "ur5_identified.urdf"
    assert main(["identify", str(UR5), str(path), "-o", str(out), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["output"] == str(out) and rep["consistent"]
    text = out.read_text()
    # kinematics, joints, names, limits: everything but the <inertial>s (and comments) is unchanged
    assert _without_inertials_and_comments(text) == _without_inertials_and_comments(UR5.read_text())
    assert "identified by manipdyn (consistent)" in text              # the provenance comment
    ident = md.load(str(out))
    assert ident.joint_names == prior.joint_names and ident.link_names == prior.link_names
    np.testing.assert_allclose(ident.fkine(ex.q[:20]), prior.fkine(ex.q[:20]), rtol=0, atol=1e-12)
    # it predicts like the fit, and like the truth (exact data), to 1e-7 of each joint's RMS torque
    rms = np.sqrt(np.mean(tau**2, axis=0))
    pred = ident.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    assert np.all(np.sqrt(np.mean((pred - tau) ** 2, axis=0)) <= 1e-7 * rms)
    fitted = fit(prior, ex.q, ex.qd, ex.qdd, tau, method="consistent")
    np.testing.assert_allclose(pred, fitted.predict(ex.q, ex.qd, ex.qdd), rtol=0, atol=1e-7 * rms.max())
    # the written file passes the engines' cross-check
    assert main(["check", str(out)]) == 0
    capsys.readouterr()


def test_identify_urdf_prior_refuses_what_urdf_cannot_hold(urdf_data, tmp_path, capsys):
    _, _, _, _, path = urdf_data
    for extra, msg in ((["-o", str(tmp_path / "x.toml")], "is written back as URDF"),
                       (["-o", str(tmp_path / "x.urdf"), "--armature"], "--armature: a URDF has no rotor inertia"),
                       (["-o", str(tmp_path / "x.urdf"), "--friction-terms", "viscous"],
                        "--friction-terms: a URDF's <dynamics> holds viscous and Coulomb friction only")):
        assert main(["identify", str(UR5), str(path), *extra]) == 2
        assert msg in capsys.readouterr().err


def test_a_change_the_chain_link_cannot_hold_moves_the_lumped_inertials():
    """wrist_3 lumps the fixed 'tool' link.  Given 0.5 kg on the tool, an identified wrist body
    0.3 kg lighter cannot be written as a change of wrist_3's own 0.19 kg: wrist_3 then carries
    the whole identified body and the tool's inertial is removed (a comment says where it went)."""
    from manipdyn.identification.estimation.model import arm_with_parameters
    from manipdyn.model.parameters import arm_parameters

    root = etree.fromstring(UR5.read_bytes())
    tool = next(el for el in root.iterchildren("link") if el.get("name") == "tool")
    tool.insert(0, etree.fromstring('<inertial><origin xyz="0 0 0.02" rpy="0 0 0"/><mass value="0.5"/>'
                                    '<inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial>'))
    prior = md.load(etree.tostring(root, encoding="unicode"))
    assert prior.lumped_links[5] == ("wrist_3", "tool")
    pi = arm_parameters(prior, False, False).copy()
    pi[50:60] *= (pi[50] - 0.3) / pi[50]           # the wrist body 0.3 kg lighter, same COM
    new = arm_with_parameters(prior, pi)
    np.testing.assert_allclose(arm_parameters(new, False, False), pi, rtol=0, atol=1e-12)
    assert "inertial identified as part of link 'wrist_3'" in new.urdf_text
    out = etree.fromstring(new.urdf_text.encode())
    assert next(el for el in out.iterchildren("link") if el.get("name") == "tool").find("inertial") is None


def test_identify_takes_a_tree_urdf_with_tip(tmp_path, capsys):
    """A URDF with a gripper branches; ``identify --tip LINK`` (like check, track, montecarlo) takes
    the chain to that link, and the written URDF, read back with the same tip, predicts what the
    fit predicted (the hand and fingers lumped into the last body are written back once)."""
    prior = md.load("erd:panda", tip="panda_hand_tcp")
    ex = excitation(prior, duration=6.0, harmonics=3, rate=100.0, iterations=0)
    tau = prior.inverse_dynamics(ex.q, ex.qd, ex.qdd)
    tau = tau + 0.01 * np.abs(tau).max(axis=0) * np.random.default_rng(0).standard_normal(tau.shape)
    log = tmp_path / "log.csv"
    write_measurements_csv(log, ex.t, ex.q, tau, qd=ex.qd, qdd=ex.qdd)
    out = tmp_path / "panda_id.urdf"
    assert main(["identify", "erd:panda", str(log), "-o", str(out)]) == 2      # a tree: the tip is needed
    assert "--tip" in capsys.readouterr().err
    assert main(["identify", "erd:panda", str(log), "--tip", "panda_hand_tcp", "-o", str(out)]) == 0
    # identify now chooses the prior weight on the hold-outs by default (--prior-weight auto): the fit the
    # file must reproduce is the consistent fit at the weight it chose and said
    weight = re.search(r"note: prior weight (\S+) chosen", capsys.readouterr().out)
    assert weight, "identify did not say which prior weight it chose"
    ident = md.load(str(out), tip="panda_hand_tcp")
    fitted = fit(prior, ex.q, ex.qd, ex.qdd, tau, method="consistent", prior_weight=float(weight.group(1)))
    scale = np.abs(tau).max()
    np.testing.assert_allclose(ident.inverse_dynamics(ex.q, ex.qd, ex.qdd), fitted.predict(ex.q, ex.qd, ex.qdd),
                               rtol=0, atol=1e-9 * scale)
    # excite takes the tip too
    traj = tmp_path / "traj.csv"
    assert main(["excite", "erd:panda", "-o", str(traj), "--tip", "panda_hand_tcp", "--duration", "4",
                 "--iterations", "0", "--no-progress"]) == 0
    capsys.readouterr()
    assert traj.read_text().splitlines()[0].split(",")[:8] == ["t"] + [f"q{i}" for i in range(1, 8)]
    # a URDF prior with a friction law or rotor inertias: refused for a URDF output, which cannot hold
    # them, taken when only the base model is written
    base = tmp_path / "panda_id.json"
    assert main(["identify", "erd:panda", str(log), "--tip", "panda_hand_tcp", "-o", str(tmp_path / "x.urdf"),
                 "--friction-terms", "viscous,offset"]) == 2
    assert "or write only the base model" in capsys.readouterr().err
    assert main(["identify", "erd:panda", str(log), "--tip", "panda_hand_tcp", "-o", str(base), "--method", "wls",
                 "--friction-terms", "viscous,offset", "--armature"]) == 0
    capsys.readouterr()
    assert main(["validate", str(base), str(log), "--json"]) == 0
    assert len(json.loads(capsys.readouterr().out)["rms"]) == 7
