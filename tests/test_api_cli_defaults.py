"""The command line and the library run the same thing with the same defaults.

Each subcommand that has a library pipeline is listed with that function and the
map from its argparse destinations to the function's parameters; the test reads
the parser's defaults and the function's signature and asserts they are equal,
so a default changed in one place and not the other fails here.
"""

from __future__ import annotations

import argparse
import inspect

import pytest

from manipdyn.cli import build_parser


def _subparser(name: str) -> argparse.ArgumentParser:
    sub = build_parser()._subparsers._group_actions[0]
    return sub.choices[name]


def _defaults(parser: argparse.ArgumentParser) -> dict:
    return {a.dest: a.default for a in parser._actions if a.dest != "help"}


def _pipelines():
    from manipdyn.control.track import track

    return {
        # subcommand: (library function, {argparse dest: parameter name})
        "track": (track, {"payload": "payload", "duration": "duration", "dt": "dt",
                          "bandwidth": "bandwidth", "gamma": "gamma"}),
    }


@pytest.mark.parametrize("command", sorted(_pipelines()))
def test_cli_defaults_are_the_library_defaults(command):
    func, mapping = _pipelines()[command]
    cli = _defaults(_subparser(command))
    params = inspect.signature(func).parameters
    for dest, name in mapping.items():
        assert dest in cli, f"{command}: no option with dest {dest!r}"
        assert name in params, f"{func.__qualname__} has no parameter {name!r}"
        assert cli[dest] == params[name].default, (
            f"{command} --{dest.replace('_', '-')} defaults to {cli[dest]!r}, "
            f"{func.__qualname__}({name}=...) to {params[name].default!r}")


def test_the_defaults_check_can_fail(monkeypatch):
    """A planted drift between the CLI and the library is seen (the test is not vacuous)."""
    from manipdyn.control import track as track_module

    def drifted(arm, controllers=("ct",), *, payload=0.0, duration=9.0, dt=1e-3, bandwidth=10.0, gamma=10.0,
                progress=None, on_run=None):
        raise AssertionError("not called")

    cli = _defaults(_subparser("track"))
    assert cli["duration"] != inspect.signature(drifted).parameters["duration"].default
    assert cli["duration"] == inspect.signature(track_module.track).parameters["duration"].default


def test_track_cli_controller_default_is_the_library_default():
    from manipdyn.control.track import track

    assert (_defaults(_subparser("track"))["controller"],) == inspect.signature(track).parameters["controllers"].default
