"""ROS bags through read_log: a real rosbag2 (sqlite3 and MCAP storage) written with
rosbags, then read back with its joints mapped by name."""

from __future__ import annotations

import sys

import numpy as np
import pytest

import manipdyn as md
from manipdyn._support.errors import MissingExtraError
from manipdyn.identification import read_log

pytest.importorskip("scipy")
rosbags = pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")
from rosbags.rosbag2 import StoragePlugin, Writer  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

TS = get_typestore(Stores.ROS2_HUMBLE)
JS = TS.types["sensor_msgs/msg/JointState"]
HEADER, TIME = TS.types["std_msgs/msg/Header"], TS.types["builtin_interfaces/msg/Time"]
JOINTS = ["shoulder", "elbow"]
W, A = 2 * np.pi * np.array([0.3, 0.5]), np.array([0.8, 0.4])
START = 1_700_000_000 * 10**9          # header stamps in ns since the epoch


def motion(t):
    s, c = np.sin(np.outer(t, W)), np.cos(np.outer(t, W))
    return A * s, A * W * c, -A * W**2 * s


def write_bag(path, storage, *, stamps=True, velocity=True, topics=("/joint_states",), rate=250.0, duration=16.0):
    t = np.arange(0, duration, 1 / rate)
    q, qd, _ = motion(t)
    tau = 2.0 * q + 0.1
    with Writer(path, version=9, storage_plugin=storage) as w:
        conns = [w.add_connection(tp, JS.__msgtype__, typestore=TS) for tp in topics]
        for k, tk in enumerate(t):
            ns = START + int(round(tk * 1e9))
            st = TIME(sec=ns // 10**9, nanosec=ns % 10**9) if stamps else TIME(sec=0, nanosec=0)
            # the driver's own order, plus a gripper joint the model does not have
            msg = JS(header=HEADER(stamp=st, frame_id=""), name=["gripper", "elbow", "shoulder"],
                     position=np.array([0.01, q[k, 1], q[k, 0]]),
                     velocity=np.array([0.0, qd[k, 1], qd[k, 0]]) if velocity else np.array([], dtype=np.float64),
                     effort=np.array([0.0, tau[k, 1], tau[k, 0]]))
            raw = TS.serialize_cdr(msg, JS.__msgtype__)
            log_ns = ns + 3_000_000 + (k % 7) * 100_000            # received later, jittered
            for c in conns:
                w.write(c, log_ns, raw)
    return t, q, qd, tau


@pytest.mark.parametrize("storage", [StoragePlugin.SQLITE3, StoragePlugin.MCAP], ids=["sqlite3", "mcap"])
def test_joint_states_round_trip(tmp_path, storage):
    bag = tmp_path / "run"
    t, q, qd, tau = write_bag(bag, storage)
    m = read_log(bag, 2, joint_names=JOINTS)
    text = "\n".join(m.notes)
    assert "joints mapped by name" in text and "time from the header stamps" in text
    assert m.measured_qd and len(m.source_sha256) == 64
    q_ref, qd_ref, qdd_ref = motion(m.t)
    # stamps are exact (uniform 250 Hz): q passes a >= 2 Hz filter with ~1e-5 of its
    # peak; qdd from the (exact) measured qd, edge transient ~2e-4: 2e-3 relative
    assert np.abs(m.q - q_ref).max() < 1e-4
    assert np.all(np.abs(m.qdd - qdd_ref).max(axis=0) < 2e-3 * np.abs(qdd_ref).max(axis=0))
    np.testing.assert_allclose(m.tau, 2.0 * np.interp(m.t, t, q[:, 0])[:, None] * [1, 0]
                               + 2.0 * np.interp(m.t, t, q[:, 1])[:, None] * [0, 1] + 0.1, atol=1e-9)
    # a single .mcap file reads too
    if storage == StoragePlugin.MCAP:
        single = read_log(bag / "run.mcap", 2, joint_names=JOINTS)
        np.testing.assert_array_equal(single.q, m.q)


def test_receive_time_when_stamps_are_zero_and_no_velocity(tmp_path):
    bag = tmp_path / "nostamp"
    write_bag(bag, StoragePlugin.SQLITE3, stamps=False, velocity=False)
    m = read_log(bag, 2, joint_names=JOINTS)
    text = "\n".join(m.notes)
    assert "bag receive times (header stamps are zero)" in text and not m.measured_qd
    assert "resampled onto a uniform grid" in text        # the receive times jitter
    _, _, qdd_ref = motion(m.t - 0.0)
    # receive times are the stamps + 3 ms + a jitter of up to 0.6 ms; t starts at the first
    # message, so the offset cancels and the jitter (0.6 ms x 2.5 rad/s = 1.5e-3 rad of q,
    # 7-periodic, far above the cut-off) is filtered out: qdd within 1 % of its peak
    assert np.all(np.abs(m.qdd - qdd_ref).max(axis=0) < 1e-2 * np.abs(qdd_ref).max(axis=0))


def test_bag_errors(tmp_path, monkeypatch):
    bag = tmp_path / "two"
    write_bag(bag, StoragePlugin.SQLITE3, topics=("/a/joint_states", "/b/joint_states"), duration=13.0)
    with pytest.raises(md.ModelError, match=r"two: 2 sensor_msgs/msg/JointState topics .* choose one with topic="):
        read_log(bag, 2, joint_names=JOINTS)
    assert len(read_log(bag, 2, joint_names=JOINTS, topic="/b/joint_states")) > 0
    with pytest.raises(md.ModelError, match=r"no sensor_msgs/msg/JointState topic '/c'"):
        read_log(bag, 2, joint_names=JOINTS, topic="/c")
    with pytest.raises(md.ModelError, match=r"never seen: \['wrist'\]; the bag's joints: \['elbow', 'gripper', 'shoulder'\]"):
        read_log(bag, 2, joint_names=["shoulder", "wrist"], topic="/a/joint_states")
    with pytest.raises(md.ModelError, match="maps joints by name: give joint_names"):
        read_log(bag, 2, topic="/a/joint_states")
    with pytest.raises(md.ModelError, match="joint_names: expected 2 names, got 1"):
        read_log(bag, 2, joint_names=["elbow"])
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)     # as if rosbags were not installed
    with pytest.raises(MissingExtraError, match=r"pip install 'manipdyn\[ros\]'"):
        read_log(bag, 2, joint_names=JOINTS)


def test_bag_size_is_capped(tmp_path, monkeypatch):
    from manipdyn._support import limits

    bag = tmp_path / "capped"
    write_bag(bag, StoragePlugin.MCAP, duration=13.0)
    monkeypatch.setattr(limits, "MAX_DATA_BYTES", 10_000)
    with pytest.raises(md.ModelError, match=r"capped: the bag's size is .* bytes, over the limit.*MAX_DATA_BYTES"):
        read_log(bag, 2, joint_names=JOINTS)
