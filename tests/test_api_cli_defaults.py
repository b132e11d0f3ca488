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
    import manipdyn as md
    from manipdyn import montecarlo as mc
    from manipdyn.control.track import track
    from manipdyn.identification import excitation, identify, point_to_point, synthesize, validate

    same = lambda *names: {n: n for n in names}  # noqa: E731
    return {
        # "subcommand/function": (library function, {argparse dest: parameter name})
        "track/track": (track, same("payload", "duration", "dt", "bandwidth", "gamma")),
        "montecarlo/study": (mc.study, same("seed", "duration", "dt", "bandwidth", "tau_max", "simulator")
                             | {"plants_from": "plants"}),
        "replay/replay": (md.replay, same("every", "simulator", "tip")),
        "montecarlo/run": (mc.run, same("scheduler", "workers", "chunk_size")),
        "excite/excitation": (excitation, {"period": "duration"} | same("harmonics", "rate", "seed", "vmax", "amax",
                                               "iterations", "friction", "ramp")),
        "excite/point_to_point": (point_to_point, same("rate", "seed", "vmax", "amax")),
        "synthesize/synthesize": (synthesize, same("noise", "seed")),
        "check/crosscheck": (md.crosscheck, same("samples", "seed", "scheduler", "workers")),
        "compare/compare": (md.compare, same("samples", "seed")),
        "identify/identify": (identify, same(*IDENTIFY_OPTIONS, *LOG_OPTIONS)),
        "validate/validate": (validate, same("tip", "predictions", "compare_column", *LOG_OPTIONS)),
        "observe/observe": (md.observe, same("false_alarms", "min_duration", "hysteresis")),
    }


#: the options ``manipdyn identify`` passes to ``manipdyn.identification.identify`` by name
IDENTIFY_OPTIONS = ("method", "tip", "friction", "friction_terms", "friction_side", "smoothing", "stribeck_velocity",
                    "sigmoid_alpha", "armature", "mass_bound", "com_bound", "total_mass_bound", "no_bounds",
                    "prior_weight", "bootstrap", "scheduler", "band_folds", "identify_torque_constants", "output",
                    "base_json", "scale_from_gravity")
#: how to read the logs, shared by identify and validate
LOG_OPTIONS = ("columns", "deg", "rate", "time_scale", "resample", "cutoff", "no_decimate", "t_range", "topic",
               "joint_names", "extra_joints")


def test_identify_and_validate_blas_threads_default_is_the_command_lines():
    """``--blas-threads`` is the top parser's; the pipelines limit BLAS themselves, by default alike."""
    from manipdyn.identification import identify, validate

    top = {a.dest: a.default for a in build_parser()._actions}
    for func in (identify, validate):
        assert inspect.signature(func).parameters["blas_threads"].default == top["blas_threads"] == 1


@pytest.mark.parametrize("key", sorted(_pipelines()))
def test_cli_defaults_are_the_library_defaults(key):
    command = key.split("/")[0]
    func, mapping = _pipelines()[key]
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


def test_montecarlo_cli_distributions_and_controllers_are_the_library_defaults():
    from manipdyn import montecarlo as mc

    cli = _defaults(_subparser("montecarlo"))
    # the absolute figures and their sized counterparts default to None on both sides (given, an
    # absolute figure turns its sized default off: issue 46), so compare what they resolve to
    fields = [f for f in vars(mc.Distributions()) if f in cli]
    assert len(fields) >= 10
    assert mc.Distributions(**{f: cli[f] for f in fields}) == mc.Distributions()
    for field, value in vars(mc.Distributions()).items():
        if field in cli and cli[field] is not None:
            assert cli[field] == value, field
    assert tuple(cli["controllers"].split(",")) == inspect.signature(mc.study).parameters["controllers"].default


def test_track_cli_controller_default_is_the_library_default():
    from manipdyn.control.track import track

    assert (_defaults(_subparser("track"))["controller"],) == inspect.signature(track).parameters["controllers"].default
