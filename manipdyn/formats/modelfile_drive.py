"""The drive tables of model files, ``[transmission]`` and ``[friction]``, and the named ``[poses]``.

Layer 2 (formats), part of :mod:`manipdyn.formats.modelfile` (the format is
documented there).  Values are SI whatever the file's ``[units]`` say: the
gear ratios and couplings are ratios, ``motor_offset`` is rad (m) at the motor,
``torque_constant`` N m/A, friction N m s/rad and N m (N s/m, N) on the law's side.
A pose is in the file's angle unit for a revolute joint and its length unit for a prismatic one,
as ``qlim``.
"""

from __future__ import annotations

import math

import numpy as np

from .._support import limits
from ..model.drive import Friction, Transmission
from .._support.errors import ModelError
from .tomltext import toml_list, toml_num

__all__ = ["parse_drive", "drive_to_toml", "parse_poses", "poses_to_toml", "TRANSMISSION_KEYS", "FRICTION_KEYS"]

TRANSMISSION_KEYS = ("coupling", "motor_offset", "torque_constant")
_FRICTION_ARRAYS = ("viscous", "coulomb", "coulomb_pos", "coulomb_neg", "offset", "stribeck_level",
                    "stribeck_velocity", "sigmoid_A", "sigmoid_alpha", "sigmoid_p3")
_FRICTION_SCALARS = ("smoothing", "deadband", "stribeck_exponent")
FRICTION_KEYS = ("side",) + _FRICTION_ARRAYS + _FRICTION_SCALARS


def _number(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ModelError(f"{where}: expected a number, got {type(value).__name__} {value!r:.60}")
    try:
        v = float(value)
    except OverflowError:
        raise ModelError(f"{where}: expected a finite number, got an integer beyond the float64 range") from None
    if not math.isfinite(v) or abs(v) > limits.MAX_MAGNITUDE:
        raise ModelError(f"{where}: expected a finite number of magnitude <= {limits.MAX_MAGNITUDE:g}, got {value!r}")
    return v


def _numbers(value, n: int, where: str) -> list[float]:
    if not isinstance(value, list) or len(value) != n:
        raise ModelError(f"{where}: expected a list of {n} numbers (one per joint), got {value!r:.80}")
    return [_number(v, f"{where}[{i}]") for i, v in enumerate(value)]


def _table(data: dict, key: str, origin: str, allowed) -> dict:
    table = data.get(key, {})
    if not isinstance(table, dict):
        raise ModelError(f"{origin}: key '{key}' must be a table ([{key}])")
    unknown = set(table) - set(allowed)
    if unknown:
        raise ModelError(f"{origin}: unknown key(s) {sorted(key + '.' + k for k in unknown)}; expected some of "
                         f"{', '.join(key + '.' + k for k in allowed)}")
    return table


def parse_drive(data: dict, origin: str, gear_ratios) -> dict:
    """``{"transmission": ..., "friction": ...}`` (each None when the file has no table)
    for :class:`manipdyn.Manipulator`; errors name the file and the key."""
    n = len(gear_ratios)
    out = {"transmission": None, "friction": None}
    if "transmission" in data:
        t = _table(data, "transmission", origin, TRANSMISSION_KEYS)
        coupling = t.get("coupling", [])
        w = f"{origin}: key 'transmission.coupling'"
        if not isinstance(coupling, list):
            raise ModelError(f"{w}: expected a list of [motor_row, joint_column, value], got {coupling!r:.80}")
        entries = []
        for c, e in enumerate(coupling):
            if not isinstance(e, list) or len(e) != 3 or not all(isinstance(k, int) and not isinstance(k, bool)
                                                                  for k in e[:2]):
                raise ModelError(f"{w}[{c}]: expected [motor_row, joint_column, value] with 1-based integer "
                                 f"row and column, got {e!r:.80}")
            entries.append([e[0], e[1], _number(e[2], f"{w}[{c}][2]")])
        kw = {k: _numbers(t[k], n, f"{origin}: key 'transmission.{k}'") for k in TRANSMISSION_KEYS[1:] if k in t}
        try:
            out["transmission"] = Transmission.from_gear_ratios(gear_ratios, entries, **kw)
        except ModelError as exc:
            raise ModelError(f"{origin}: [transmission]: {exc}") from None
    if "friction" in data:
        f = _table(data, "friction", origin, FRICTION_KEYS)
        kw = {k: _numbers(f[k], n, f"{origin}: key 'friction.{k}'") for k in _FRICTION_ARRAYS if k in f}
        kw.update({k: _number(f[k], f"{origin}: key 'friction.{k}'") for k in _FRICTION_SCALARS if k in f})
        if "side" in f:
            if not isinstance(f["side"], str):
                raise ModelError(f"{origin}: key 'friction.side' must be \"joint\" or \"motor\", got {f['side']!r}")
            kw["side"] = f["side"]
        try:
            out["friction"] = Friction(**kw, n=n)
        except ModelError as exc:
            raise ModelError(f"{origin}: [friction]: {exc}") from None
    return out


def drive_to_toml(arm) -> list[str]:
    """The ``[transmission]`` and ``[friction]`` lines of ``arm`` (none when the links say it all); floats
    and lists written exactly (:mod:`manipdyn.formats.tomltext`)."""
    lines = []
    t = arm.transmission
    if not t.is_diagonal or np.any(t.motor_offset) or t.torque_constant is not None:
        lines += ["", "[transmission]"]
        if not t.is_diagonal:
            lines.append("coupling = [" + ", ".join(f"[{r}, {c}, {toml_num(v)}]" for r, c, v in t.coupling) + "]")
        if np.any(t.motor_offset):
            lines.append(f"motor_offset = {toml_list(t.motor_offset)}")
        if t.torque_constant is not None:
            lines.append(f"torque_constant = {toml_list(t.torque_constant)}")
    f = arm.friction_model
    links_say_it = any(l.friction_viscous or l.friction_coulomb for l in arm.links)
    if f is not None and not links_say_it:
        lines += ["", "[friction]", f'side = "{f.side}"', f"smoothing = {toml_num(f.smoothing)}",
                  f"deadband = {toml_num(f.deadband)}"]
        for k in _FRICTION_ARRAYS:
            v = getattr(f, k)
            if k in ("coulomb_pos", "coulomb_neg") and not f.asymmetric or v is None:
                continue
            lines.append(f"{k} = {toml_list(v)}")
        if f.stribeck_level is not None:
            lines.append(f"stribeck_exponent = {toml_num(f.stribeck_exponent)}")
    return lines


def parse_poses(data: dict, origin: str, joint_types, L: float, A: float):
    """``[poses]`` (``name = [q1, ..., qn]``) in SI units, or None when the file has none;
    :func:`manipdyn.model.arm_calls.as_poses` checks the names and values."""
    if "poses" not in data:
        return None
    table = data["poses"]
    if not isinstance(table, dict):
        raise ModelError(f"{origin}: key 'poses' must be a table of name = [one value per joint]")
    scale = [A if t == "revolute" else L for t in joint_types]
    return {k: [x * f for x, f in zip(_numbers(v, len(scale), f"{origin}: key 'poses.{k}'"), scale)]
            for k, v in table.items()}


def poses_to_toml(arm) -> list[str]:
    """The ``[poses]`` lines of ``arm`` (SI units), none when it has no pose."""
    poses = getattr(arm, "poses", {})
    return ["", "[poses]"] + [f"{k} = {toml_list(v)}" for k, v in poses.items()] if poses else []
