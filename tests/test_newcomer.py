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
