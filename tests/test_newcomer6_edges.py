"""Issue 46 (a newcomer, round six): numbers at the edges, and what a command says it did.

Items 5 (a contact that never happens), 23 (exit 3 on edge numbers), 26 (a velocity cut-off that
is no frequency), 29 (the API's edges).  Each case: exit 2 with one line, or a ModelError, never
exit 3 or a traceback.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main


@pytest.fixture(scope="module")
def traj(tmp_path_factory):
    """A 4 s UR5 excitation trajectory at 250 Hz (what synthesize reads)."""
    d = tmp_path_factory.mktemp("traj")
    path = d / "traj.csv"
    assert main(["excite", "ur5", "-o", str(path), "--period", "4", "--rate", "250", "--iterations", "1",
                 "--ramp", "0"]) == 0
    return d, path


def _one_line_error(capsys, code, *words):
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err and "internal error" not in err, err
    for w in words:
        assert w in err, err
    return err


# -- 5. a contact that never happens ----------------------------------------------------------------
def test_item5_a_contact_after_the_trajectory_is_refused(traj, capsys):
    """Issue 46 item 5: ``synthesize --contact 5:6:...`` on a 4 s trajectory reported "1 contact(s)"
    that never happens; now refused, naming the trajectory's span, nothing written."""
    d, path = traj
    out = d / "push.csv"
    code = main(["synthesize", "ur5", str(path), "-o", str(out), "--contact", "5:6:0,0,-30"])
    _one_line_error(capsys, code, "--contact 5:6", "acts at no sample")
    assert not out.exists() and not (d / "push.contacts.json").exists()
    assert main(["synthesize", "ur5", str(path), "-o", str(out), "--contact", "1:2:0,0,-30"]) == 0
    assert "1 contact(s)" in capsys.readouterr().out


# -- 23. a superscript digit as the contact's link ----------------------------------------------------
def test_item23_a_superscript_digit_link_is_a_usage_error(traj, capsys):
    d, path = traj
    code = main(["synthesize", "ur5", str(path), "-o", str(d / "x.csv"), "--contact", "1:2:0,0,-30@\u00b2"])
    _one_line_error(capsys, code, "LINK")


# -- 29. synthesize writes torques its own readers refuse ------------------------------------------
def test_item29_synthesize_refuses_torques_its_readers_refuse():
    """1e307 N m torques were written; the log readers refuse anything over limits.MAX_SIGNAL."""
    from manipdyn._support import limits
    from manipdyn.identification.experiments.synthesize import synthesize

    arm = md.load("ur5")
    q = np.zeros((3, 6))
    qdd = np.full((3, 6), 1e150)                # torques ~1e150 N m: finite, beyond any reader
    with pytest.raises(md.ModelError, match="MAX_SIGNAL"):
        synthesize(arm, q, q, qdd)
    ok = synthesize(arm, q, q, np.ones((3, 6)))
    assert np.all(np.abs(ok) <= limits.MAX_SIGNAL)
