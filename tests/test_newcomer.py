"""Issue 20, as a newcomer meets manipdyn: each item's test (the item number in the name).

Usage errors exit 2 with a one-line message, names are forgiving, files load back,
nothing is left behind.  Tests that need a long run stay small (a few iterations,
a few runs) and assert outcomes, never times.
"""

from __future__ import annotations

import sys

import pytest

from manipdyn.cli import main


def _err_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


# -- item 10: usage errors exit 2 with a message, never 3 ---------------------------------------
@pytest.mark.parametrize("size", ["0", "-1"])
def test_item10_montecarlo_chunk_size_is_usage_error(size, capsys):
    assert main(["montecarlo", "puma560", "--runs", "2", "--scheduler", "sync", "--chunk-size", size]) == 2
    assert "--chunk-size" in _err_line(capsys)


def test_item10_check_negative_timing_calls_is_usage_error(capsys):
    assert main(["check", "stanford", "--samples", "2", "--timing-calls", "-1"]) == 2
    assert "--timing-calls" in _err_line(capsys)


def test_item10_urdf_without_outdir_says_missing_outdir(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["urdf", "puma560"]) == 2
    assert "missing OUTDIR" in _err_line(capsys)
    assert not (tmp_path / "puma560").exists()


def test_item10_controllers_any_case(capsys):
    assert main(["montecarlo", "puma560", "--runs", "1", "--scheduler", "sync", "--controllers", "pd,CT",
                 "--duration", "0.05", "--json"]) == 0
    assert main(["montecarlo", "puma560", "--runs", "1", "--scheduler", "sync", "--controllers", "pd,XX"]) == 2
    line = _err_line(capsys)
    assert "pd,pdg,ct,adaptive" in line


def test_item10_missing_dask_hint_is_a_command_line(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)   # import distributed -> ImportError
    assert main(["montecarlo", "puma560", "--runs", "1", "--duration", "0.05"]) == 2
    line = _err_line(capsys)
    assert "--scheduler sync" in line and "scheduler='sync'" not in line


# -- item 6: excite checks -o before it optimises --------------------------------------------
def test_item6_excite_checks_output_before_optimising(tmp_path, monkeypatch, capsys):
    import manipdyn.identification as ident

    def never(*a, **k):                       # the optimiser must not start
        raise AssertionError("excitation ran before -o was checked")

    monkeypatch.setattr(ident, "excitation", never)
    assert main(["excite", "ur5", "-o", str(tmp_path / "missing" / "traj.csv")]) == 2
    assert "-o" in _err_line(capsys)
    assert main(["excite", "ur5", "-o", str(tmp_path)]) == 2      # a folder
    assert "folder" in _err_line(capsys)


# -- item 15: caps with messages that say how to raise them; a scheduler with no workers ------
@pytest.mark.parametrize("argv, limit", [
    (["excite", "ur5", "--harmonics", "1000"], "MAX_HARMONICS"),
    (["excite", "ur5", "--rate", "1e6", "--duration", "100"], "MAX_EXCITATION_SAMPLES"),
    (["montecarlo", "puma560", "--runs", "100000000"], "MAX_STUDY_STEPS"),
    (["montecarlo", "puma560", "--runs", "1", "--dt", "1e-9"], "MAX_RUN_STEPS"),
])
def test_item15_caps_say_how_to_raise_them(argv, limit, tmp_path, capsys):
    if argv[0] == "excite":
        argv = argv + ["-o", str(tmp_path / "t.csv")]
    assert main(argv) == 2
    line = _err_line(capsys)
    assert f"manipdyn.limits.{limit} = " in line and "from the shell" in line


def test_item15_caps_can_be_raised(monkeypatch):
    import manipdyn.limits as limits
    from manipdyn.montecarlo import check_study_size

    with pytest.raises(ValueError, match="MAX_STUDY_STEPS"):
        check_study_size(10**6, 4, 2.0, 1e-3, 10.0)
    monkeypatch.setattr(limits, "MAX_STUDY_STEPS", 1e10)
    check_study_size(10**6, 4, 2.0, 1e-3, 10.0)          # raised: accepted


def test_item15_scheduler_without_workers_times_out(monkeypatch, capsys):
    distributed = pytest.importorskip("distributed", reason="the scale extra is not installed")
    import manipdyn.scale as scale

    monkeypatch.setattr(scale, "WORKER_WAIT_S", 1.0)
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        assert main(["montecarlo", "puma560", "--runs", "1", "--duration", "0.05",
                     "--scheduler", cluster.scheduler_address]) == 2
    line = _err_line(capsys)
    assert "no worker" in line and "dask worker" in line


# -- item 19: exit 2, never 3, on bad excite and montecarlo options ---------------------------
@pytest.mark.parametrize("argv, culprit", [
    (["excite", "ur5", "--duration", "0.005"], "--rate x --duration"),
    (["excite", "ur5", "--rate", "1e-9"], "--rate x --duration"),
    (["excite", "ur5", "--seed", "-1"], "--seed"),
    (["excite", "ur5", "--duration", "nan"], "--duration"),
    (["montecarlo", "puma560", "--runs", "1", "--scheduler", "garbage"], "--scheduler"),
    (["montecarlo", "puma560", "--runs", "1", "--scheduler", "http://x:80"], "--scheduler"),
    (["montecarlo", "puma560", "--runs", "1", "--scheduler", ""], "--scheduler"),
    (["montecarlo", "puma560", "--runs", "1", "--scheduler", "sync", "--bandwidth", "1e300"], "--bandwidth"),
])
def test_item19_bad_options_exit_2(argv, culprit, tmp_path, capsys):
    if argv[0] == "excite":
        argv = argv + ["-o", str(tmp_path / "t.csv")]
    assert main(argv) == 2
    assert culprit in _err_line(capsys)
    assert not (tmp_path / "t.csv").exists()
