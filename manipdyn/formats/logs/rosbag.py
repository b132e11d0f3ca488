"""Joint samples from ROS bags: ``sensor_msgs/msg/JointState`` messages.

Layer 2 (formats: logs).

Reads a rosbag2 directory (sqlite3 or MCAP storage), a single ``.mcap`` file
or ROS 1 ``.bag`` files with the ``rosbags`` package (the ``ros`` extra:
``pip install 'manipdyn[ros]'``).  Each message's ``name`` list maps its
``position``, ``velocity`` and ``effort`` arrays onto the model's joints BY
NAME (``joint_names``, in the model's order), so a driver's own joint order,
extra joints (a gripper) or joints split across messages do not matter:

* ``position`` -> q (rad or m), ``velocity`` -> qd (used only when every
  message used has it for every joint), ``effort`` -> tau (N m or N);
* a message lacking one of the joints (or its effort) is skipped, and
  the note counts them;
* time is the header stamp when every message used has a non-zero one,
  otherwise the bag's receive time; the note says which.  Times are made
  relative to the first message (``t = 0`` there; the note gives the
  absolute start), so ``t_range`` reads in seconds into the recording.

The input is capped like a CSV (:data:`manipdyn.limits.MAX_DATA_BYTES` over
all the bag's files, regular files only: a FIFO is refused, never opened).
"""

from __future__ import annotations

import hashlib
import os
import stat
from pathlib import Path

import numpy as np

from ..._support import limits
from ..._support.errors import MissingExtraError, ModelError

__all__ = ["INSTALL_ROS", "JOINT_STATE", "is_bag", "read_joint_states"]

#: the command that installs what reading ROS bags needs
INSTALL_ROS = "pip install 'manipdyn[ros]'"
JOINT_STATE = "sensor_msgs/msg/JointState"
_SUFFIXES = (".mcap", ".bag", ".db3")


def is_bag(path) -> bool:
    """True when ``path`` is read as a ROS bag (a directory, ``.mcap``, ``.bag``, ``.db3``)."""
    p = Path(path)
    return p.is_dir() or p.suffix.lower() in _SUFFIXES


def _files(path: Path, where: str):
    """The bag's files, each a regular file, their total size under the cap."""
    try:
        st = os.stat(path)
    except OSError as exc:
        raise ModelError(f"{where}: cannot read the bag: {exc.strerror or exc}") from None
    if stat.S_ISDIR(st.st_mode):
        files = sorted(p for p in path.iterdir())
        if not any(p.name == "metadata.yaml" for p in files) and not any(p.suffix == ".mcap" for p in files):
            raise ModelError(f"{where}: a directory but not a rosbag2 recording (no metadata.yaml)")
    else:
        files = [path]
    total = 0
    for p in files:
        try:
            s = os.stat(p)
        except OSError as exc:
            raise ModelError(f"{where}: cannot read {p.name}: {exc.strerror or exc}") from None
        if not stat.S_ISREG(s.st_mode):
            raise ModelError(f"{where}: {p.name} is not a regular file (a directory, device, FIFO or socket)")
        total += s.st_size
    if total > limits.MAX_DATA_BYTES:
        raise limits.over_limit(where, "the bag's size", f"{total} bytes", "MAX_DATA_BYTES")
    return files


def _sha256(files) -> str:
    h = hashlib.sha256()
    for p in files:
        h.update(os.fsencode(p.name) + b"\0")
        with limits.open_regular(os.fspath(p), f"{p}: cannot read") as fh:
            hashlib.file_digest(fh, lambda: h)      # on into the same hash: every file, each after its name
    return h.hexdigest()


def _one_line(exc) -> str:
    """An exception's text on one line, at most 300 characters (a YAML error spans several)."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 300 else text[:297] + "..."


def _messages(reader, conns, where):
    """``reader.messages(connections=conns)``, a damaged bag (a corrupt MCAP chunk, a truncated
    sqlite page) raising a ModelError naming the file instead of the reader's own error."""
    it = reader.messages(connections=conns)
    while True:
        try:
            item = next(it)
        except StopIteration:
            return
        except Exception as exc:        # rosbags and its storage plugins raise their own classes
            raise ModelError(f"{where}: the bag is damaged (while reading its messages: "
                             f"{type(exc).__name__}: {_one_line(exc)})") from None
        yield item


def read_joint_states(path, joint_names, topic: str | None = None):
    """Joint samples of the bag ``path`` (module docstring).

    ``joint_names``: the model's n joint names in order.  ``topic``: the
    JointState topic (needed when the bag has more than one).

    Returns ``(t, q, qd, tau, notes, sha256)``: t (N,) s from the first message,
    q, tau (N, n), qd (N, n) or None, notes (list of str), and the SHA-256 of
    the bag's files (name and bytes, in name order).
    """
    where = os.fspath(path)
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError as exc:
        raise MissingExtraError(f"reading ROS bags needs the Python package 'rosbags', which is not installed "
                                f"({exc}); install the ROS extra: {INSTALL_ROS}") from None
    if joint_names is None:
        raise ModelError(f"{where}: a ROS bag maps joints by name: give joint_names (the model's joints in "
                         "order; --joint-names on the command line)")
    names = [str(x) for x in joint_names]
    twice = sorted({nm for nm in names if names.count(nm) > 1})
    if twice:
        raise ModelError(f"{where}: joint_names (--joint-names): {', '.join(twice)} given twice; each of the "
                         "model's joints needs its own name")
    root = Path(path)
    files = _files(root, where)
    digest = _sha256(files)
    try:
        reader = AnyReader([root], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as exc:            # rosbags raises its own classes per format
        raise ModelError(f"{where}: not a readable ROS bag: {_one_line(exc)}") from None
    try:
        states = [c for c in reader.connections if c.msgtype == JOINT_STATE]
        if not states:
            found = sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections})
            raise ModelError(f"{where}: no {JOINT_STATE} topic; the bag has {', '.join(found) or 'no topics'}")
        topics = sorted({c.topic for c in states})
        if topic is None:
            if len(topics) > 1:
                raise ModelError(f"{where}: {len(topics)} {JOINT_STATE} topics ({', '.join(topics)}); choose one "
                                 "with topic= (--topic)")
            topic = topics[0]
        elif topic not in topics:
            raise ModelError(f"{where}: no {JOINT_STATE} topic {topic!r}; the bag has {', '.join(topics)}")
        conns = [c for c in states if c.topic == topic]
        stamps, logged, qs, vs, es = [], [], [], [], []
        skipped, seen = 0, set()
        for conn, t_log, raw in _messages(reader, conns, where):
            try:
                msg = reader.deserialize(raw, conn.msgtype)
            except Exception as exc:
                raise ModelError(f"{where}: topic {topic}: message at log time {t_log} ns cannot be decoded: "
                                 f"{_one_line(exc)}") from None
            seen.update(msg.name)
            pos = {nm: k for k, nm in enumerate(msg.name)}
            idx = [pos.get(nm) for nm in names]
            if any(k is None for k in idx) or len(msg.position) != len(msg.name) \
                    or len(msg.effort) != len(msg.name):
                skipped += 1
                continue
            qs.append(np.asarray(msg.position, dtype=np.float64)[idx])
            es.append(np.asarray(msg.effort, dtype=np.float64)[idx])
            vs.append(np.asarray(msg.velocity, dtype=np.float64)[idx] if len(msg.velocity) == len(msg.name)
                      else None)
            stamps.append(int(msg.header.stamp.sec) * 10**9 + int(msg.header.stamp.nanosec))
            logged.append(int(t_log))
    finally:
        reader.close()
    if not qs:
        missing = [nm for nm in names if nm not in seen]
        raise ModelError(f"{where}: topic {topic}: no message has position and effort for all of the joints "
                         f"{names}" + (f"; never seen: {missing}; the bag's joints: {sorted(seen)}: give the model's "
                                       "joints by the bag's names, in the model's order, with joint_names= "
                                       "(--joint-names A,B,...)" if missing else
                                       "; the effort (or position) arrays are empty"))
    notes = [f"ros: {len(qs)} {JOINT_STATE} messages on {topic}, joints mapped by name"]
    if skipped:
        notes.append(f"ros: skipped {skipped} messages lacking one of the joints, its position or its effort")
    use_stamp = all(s > 0 for s in stamps)
    ns = np.array(stamps if use_stamp else logged, dtype=np.int64)
    order = np.argsort(ns, kind="stable")
    start = int(ns[order[0]])
    notes.append(f"ros: time from the {'header stamps' if use_stamp else 'bag receive times (header stamps are zero)'}"
                 f", t = 0 at {start / 1e9:.9f} s")
    if np.any(order != np.arange(len(ns))):
        notes.append("ros: messages reordered by time")
    t = (ns[order] - start).astype(np.float64) / 1e9
    q, tau = np.array(qs)[order], np.array(es)[order]
    qd = None if any(v is None for v in vs) else np.array(vs)[order]
    if qd is None and any(v is not None for v in vs):
        notes.append("ros: velocity missing in some messages; qd derived from q")
    if not all(np.all(np.isfinite(a)) for a in (q, tau) + (() if qd is None else (qd,))):
        raise ModelError(f"{where}: topic {topic}: a position, velocity or effort is not finite")
    return t, q, qd, tau, notes, digest
