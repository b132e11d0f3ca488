"""Issue 38 (round five), items 1, 4, 5, 6, 12, 13, 14, 16: silent choices and numbers that
contradicted each other.  Each test failed on the code before the fix."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main


# -- item 1: a vendor URDF's tool frame is no longer chosen silently -----------------------------
def test_item1_default_tool_frame_names_the_frames_passed_over(capsys):
    arm, notes = md.load_with_notes("erd:ur10_robot")
    assert arm.tip == "wrist_3_link"                       # the rule is unchanged: the last moving link
    note = next(n for n in notes if "tool frame" in n)
    assert "'tool0'" in note and "'ee_link'" in note and "tip=" in note
    tool0 = md.load("erd:ur10_robot", tip="tool0")
    assert not any("tool frame" in n for n in tool0.notes)   # a tip the user chose is no guess
    q = np.zeros(6)
    gap = np.linalg.norm(tool0.fkine(q)[:3, 3] - arm.fkine(q)[:3, 3])
    assert f"'tool0' ({gap:.4g} m, 90 deg away)" in note    # the note's distance is the frames' own
    with pytest.warns(md.ModelNoteWarning, match="tool0"):    # where fkine/jacobian/IK users see it
        md.load("erd:ur10_robot")
    assert main(["check", "erd:ur10_robot", "--samples", "2", "--timing-calls", "0"]) == 0
    assert "note: " in capsys.readouterr().out.split("passed over")[0]


def test_item1_a_single_leaf_or_an_explicit_tip_adds_no_note():
    with warnings.catch_warnings():
        warnings.simplefilter("error", md.ModelNoteWarning)
        arm = md.load("erd:panda", tip="panda_hand")
    assert arm.notes == () or not any("tool frame" in n for n in arm.notes)
