"""Collision thresholds by default (issue 39 item 2): ``identify`` writes them into the model's trust record
from the band's own hold-outs, so ``observe`` on a new log needs no calibration logs."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import manipdyn as md
from manipdyn.cli import main
from manipdyn.control.collision import carried_thresholds
from manipdyn.control.collision.holdouts import held_out_thresholds


def _load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return md.load(str(path))


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """Two different UR5 trajectories (4 s at 1 kHz, synthesize's noise) and a push on the first."""
    d = tmp_path_factory.mktemp("default_thresholds")
    for seed in (0, 1):
        assert main(["excite", "ur5", "-o", str(d / f"traj{seed}.csv"), "--period", "4", "--rate", "1000",
                     "--iterations", "2", "--ramp", "0", "--seed", str(seed)]) == 0
        assert main(["synthesize", "ur5", str(d / f"traj{seed}.csv"), "-o", str(d / f"free{seed}.csv"),
                     "--derivatives", "--seed", str(seed + 1)]) == 0
    assert main(["synthesize", "ur5", str(d / "traj0.csv"), "-o", str(d / "push.csv"), "--derivatives",
                 "--seed", "5", "--contact", "2:2.3:0,0,-30"]) == 0
    return d


def test_identify_writes_thresholds_that_observe_uses_and_fit_data_reproduces(logs, capsys):
    d = logs
    capsys.readouterr()
    assert main(["identify", "ur5", str(d / "free0.csv"), "--friction", "-o", str(d / "fit.toml")]) == 0
    out = capsys.readouterr().out
    assert "collision thresholds (gain 100 1/s, 1 false event per hour)" in out
    arm = _load(d / "fit.toml")
    thr = carried_thresholds(arm)
    assert thr is not None and thr.n == 6 and np.all(thr.threshold > 0)
    assert thr.source.startswith("5 blocked hold-outs of the fit data free0.csv")
    # observe with no calibration option: the push is found, the free run is quiet
    assert main(["observe", str(d / "fit.toml"), str(d / "push.csv")]) == 1
    assert main(["observe", str(d / "fit.toml"), str(d / "free1.csv")]) == 0
    res = md.observe(arm, str(d / "push.csv"), direct=False, wrench=False)
    assert len(res.events) == 1 and 2.0 <= res.events[0].detected <= 2.02
    # the same hold-outs and refits as --fit-data's (identify replayed from the trust record)
    again = held_out_thresholds(arm, str(d / "free0.csv"))
    assert again.source == thr.source
    # the same refits on the same data: equal to the solver's reproducibility (measured identical, 0.0)
    np.testing.assert_allclose(again.threshold, thr.threshold, rtol=1e-9)


def test_two_trajectories_are_held_out_as_trajectories(logs, capsys):
    from manipdyn.control.collision.holdouts import identified_thresholds

    d = logs
    files = [str(d / "free0.csv"), str(d / "free1.csv")]
    assert main(["identify", "ur5", *files, "--friction", "-o", str(d / "two.toml")]) == 0
    assert "from 2 held-out trajectories of the fit data (free0.csv | free1.csv)" in capsys.readouterr().out
    arm = _load(d / "two.toml")
    carried = carried_thresholds(arm)
    # --fit-data with both logs, in either order: identify replayed, the same trajectories held out
    again = held_out_thresholds(arm, files[::-1])
    assert again.source == carried.source
    np.testing.assert_allclose(again.threshold, carried.threshold, rtol=1e-9)     # measured identical
    r = md.identify("ur5", files, friction=True)
    assert r.held_out.kind == "trajectories"
    # each trajectory's hold-out is one whole run of the stacked data
    n0 = r.data.segments[0]
    masks = [m for m, _ in r.held_out.pairs()]
    assert len(masks) == 2 and {int(m[:n0].sum()) for m in masks} == {0, n0}
    np.testing.assert_allclose(identified_thresholds(r, files).threshold, carried.threshold, rtol=1e-9)
    blocks = identified_thresholds(r, files, kind="blocks")
    assert blocks.source.startswith("5 blocked hold-outs")
    assert not np.allclose(carried.threshold, blocks.threshold, rtol=1e-6)
    with pytest.raises(md.ModelError, match="give them all"):
        held_out_thresholds(arm, files[0])


def test_no_thresholds_opt_out_and_no_silent_default(logs, capsys):
    d = logs
    assert main(["identify", "ur5", str(d / "free0.csv"), "--no-thresholds", "-o", str(d / "bare.toml")]) == 0
    assert "collision thresholds" not in capsys.readouterr().out
    assert carried_thresholds(_load(d / "bare.toml")) is None
    assert main(["observe", str(d / "bare.toml"), str(d / "push.csv")]) == 2
    assert "no collision thresholds" in capsys.readouterr().err
