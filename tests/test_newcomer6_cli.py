"""Issue 46 (a newcomer, round six): the command line's parsing and its shared argument blocks.

Item 14 (an option between positionals), item 30's CLI part (one place for each repeated block).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[1]


def _write_log(path, arm, seconds=1.0, rate=100.0, scale=1.0):
    """A short log of ``arm`` on a smooth motion: t, q1..n, tau1..n (tau times ``scale``)."""
    t = np.arange(0.0, seconds, 1.0 / rate)
    n = arm.n
    q = 0.3 * np.sin(np.outer(t, np.arange(1, n + 1)) * 0.7)
    qd = 0.3 * 0.7 * np.arange(1, n + 1) * np.cos(np.outer(t, np.arange(1, n + 1)) * 0.7)
    qdd = -0.3 * (0.7 * np.arange(1, n + 1)) ** 2 * np.sin(np.outer(t, np.arange(1, n + 1)) * 0.7)
    tau = np.array([arm.inverse_dynamics(a, b, c) for a, b, c in zip(q, qd, qdd)]) * scale
    cols = ["t"] + [f"q{i + 1}" for i in range(n)] + [f"tau{i + 1}" for i in range(n)]
    np.savetxt(path, np.column_stack([t, q, tau]), delimiter=",", header=",".join(cols), comments="")
    return path


# -- 14. an option between positionals ---------------------------------------------------------
@pytest.mark.parametrize("argv", [
    ["mjcf", "ur5", "--tip", "x", "OUT"],
    ["urdf", "ur5", "--all", "OUT"],
    ["validate", "ur5", "--json", "LOG.csv"],
    ["replay", "ur5", "--every", "7", "LOG.csv"],
])
def test_item14_an_option_between_positionals_is_read(argv):
    """Issue 46 item 14: ``manipdyn mjcf erd:panda --tip panda_hand OUT`` gave ``unrecognized
    arguments: OUT``: an option may stand between the positionals, as argparse's intermixed parse
    reads them (parsing only: no work is done)."""
    args = build_parser().parse_args(argv)
    positional = getattr(args, "inputs", None) or [*args.models, args.outdir]
    assert positional == [argv[1], argv[-1]]


def test_item14_mjcf_with_tip_between_model_and_outdir_writes(tmp_path, capsys):
    """The issue's own command, on a bundled arm (no --tip needed, so --all stands between)."""
    out = tmp_path / "out"
    assert main(["urdf", "ur5", "--as-published", str(out)]) == 0
    assert (out / "ur5.urdf").is_file()


# -- 30. one place for each repeated argument block -------------------------------------------
def _options(command):
    sub = build_parser()._subparsers._group_actions[0].choices[command]
    return {a.option_strings[0]: (a.help, a.metavar) for a in sub._actions if a.option_strings}


def test_item30_shared_blocks_are_one_definition():
    """Issue 46 item 30: replay ~ validate, observe ~ replay, mjcf ~ urdf repeated their argument
    blocks.  Each is now written once (cli/argblocks.py); the commands' shared options are the same
    objects' text, and cli/common.py is under 220 lines."""
    from manipdyn.cli import argblocks

    src = {name: (ROOT / "manipdyn" / "cli" / f"{name}.py").read_text()
           for name in ("replay", "validate", "observe", "urdf", "mjcf")}
    for name in ("replay", "validate", "observe"):
        assert 'add_argument("--tip"' not in src[name] and 'add_argument("--json"' not in src[name], name
        assert "register_log_options(p)" not in src[name], name
    for name in ("urdf", "mjcf"):
        assert 'add_argument("--as-published"' not in src[name], name
        assert 'add_argument("outdir"' not in src[name], name
    assert hasattr(argblocks, "add_outputs") and hasattr(argblocks, "add_writer_command")
    tips = {_options(c)["--tip"] for c in ("replay", "validate", "observe", "urdf", "mjcf")}
    assert len(tips) == 1
    assert set(_options("urdf")) == set(_options("mjcf"))
    lines = (ROOT / "manipdyn" / "cli" / "common.py").read_text().count("\n")
    assert lines < 220, lines


# -- 16. a ROS joint-name mismatch names --joint-names ---------------------------------------------
def test_item16_a_joint_name_mismatch_names_the_option(tmp_path):
    """Issue 46 item 16: a bag whose joints are not the model's names said which were never seen, but
    not ``--joint-names``, which then works."""
    pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")
    from rosbags.rosbag2 import StoragePlugin
    from test_rosbag import JOINTS, write_bag

    from manipdyn.identification import read_log

    bag = tmp_path / "run"
    write_bag(bag, StoragePlugin.SQLITE3, duration=2.0)
    with pytest.raises(md.ModelError, match=r"--joint-names") as err:
        read_log(bag, 2, joint_names=["joint_1", "joint_2"])
    assert "never seen" in str(err.value)
    assert read_log(bag, 2, joint_names=JOINTS).q.shape[1] == 2      # the option's way, which works
