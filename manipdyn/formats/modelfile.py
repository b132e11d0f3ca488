"""Model files: a human-editable TOML description of a DH arm, and ``md.load``.

Layer 2 (formats) loaders and writers (TOML model files).

Format (``format = "manipdyn-model/1"``)::

    format = "manipdyn-model/1"
    name = "puma560"
    convention = "standard"            # "standard" (distal, eq. 2.3) or "modified" (Craig)
    gravity = [0.0, 0.0, -9.81]        # m/s^2, in the world (the base frame without `base`; optional)
    source = "citation of the data"    # required for bundled models
    base = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.5], [0.0, 0.0, 0.0, 1.0]]
                                       # optional: the base in the world, 4x4 (translation in the length unit)
    tool = [[...], [...], [...], [...]]  # optional: the tool frame in DH frame n, 4x4

    [sources]                          # optional: citation per group of values
    kinematics = "..."
    inertia = "..."
    corrections = "..."                # every change made to the published numbers, and why

    [poses]                            # optional: named joint vectors, arm.poses (with sources.poses)
    ready = [0.0, 90.0, -90.0, 0.0, 0.0, 0.0]   # in the units of qlim

    [units]                            # optional; these are the defaults
    length = "m"                       # m | cm | mm | in
    angle = "rad"                      # rad | deg
    mass = "kg"                        # kg | g
                                       # inertias are in mass * length^2 of these units

    [[links]]                          # one table per link, base outwards
    name = "shoulder"                  # optional
    joint = "revolute"                 # revolute | prismatic
    a = 0.0                            # modified DH: a_{n-1}, alpha_{n-1} on row n
    alpha = 90.0
    d = 0.0
    theta = 0.0                        # fixed offsets: theta_n = q_n + theta (revolute),
                                       #                d_n = q_n + d (prismatic)
    qlim = [-160.0, 160.0]             # optional
    mass = 17.4
    com = [-0.3638, 0.006, 0.2275]     # centre of mass in frame n
    inertia = { ixx = 0.13, iyy = 0.524, izz = 0.539, ixy = 0.0, ixz = 0.0, iyz = 0.0 }
                                       # tensor about the COM, frame-n axes, tensor sign
                                       # (ixy = -integral(x y dm), as in URDF)
    motor_inertia = 200e-6             # optional, rotor inertia Jm (motor side)
    gear_ratio = 107.815               # optional; G^2 Jm is added to D's diagonal
    friction_viscous = 0.0             # optional, joint side, N m s/rad (N s/m)
    friction_coulomb = 0.0             # optional, joint side, N m (N)

    [transmission]                     # optional: motors to joints, q_m = R q + offset (manipdyn.model.drive)
    coupling = [[6, 5, 32.0]]          # extra entries of R: [motor row, joint column, value], 1-based;
                                       # R's diagonal is the links' gear_ratio
    motor_offset = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]   # rad (m) at the motor, optional
    torque_constant = [0.5, 0.5, 0.5, 0.5, 0.5, 0.5]  # N m per A at each motor, optional

    [trust]                            # optional: an identified model's fit record (manipdyn.formats.trust)

    [friction]                         # optional: the friction law (manipdyn.model.friction); then the
                                       # links' friction_viscous/coulomb must be 0 (one description)
    side = "joint"                     # or "motor": acts on qd_m = R qd, reaches the joints as R^T tau_m
    viscous = [...]                    # one number per joint each; coulomb = [...] (symmetric) or
    coulomb = [...]                    # coulomb_pos = [...] and coulomb_neg = [...] (v > 0, v < 0)
    offset = [...]                     # constant joint torque
    smoothing = 0.01                   # tanh(v / smoothing); 0 = sharp sign (default 0.01)
    deadband = 0.0                     # |v| <= deadband: no Coulomb torque
    stribeck_level = [...]             # Fs - Fc, with stribeck_velocity = [...], stribeck_exponent = 2.0
    sigmoid_A = [...]                  # Gaz et al. 2019, with sigmoid_alpha = [...], sigmoid_p3 = [...]

    The drive tables are in SI units whatever [units] says (ratios; rad at the
    motor; N m/A; N m s/rad and N m on the law's side).

Every key is checked: a missing, unknown or mistyped key, or a unit that is
not in the lists above, is a :class:`ModelError` naming the file and key.
"""

from __future__ import annotations

import math
import os
from importlib import resources

import numpy as np

from .._support.files import atomic_write_text
from .._support import limits
from ..model.arm import Manipulator
from .._support.errors import ModelError, SuspiciousValueWarning, warn_notes
from ..model.links import DHLink
from .modelfile_drive import drive_to_toml, parse_drive, parse_poses, poses_to_toml
from .modelfile_urdf import parse_urdf_model, urdf_model_to_toml
from .tomltext import read_toml_text, toml_key, toml_list, toml_num, toml_str
from .trust import trust_from_toml, trust_to_toml

__all__ = ["models", "load_bundled", "load_model_file", "parse_model", "save_model", "model_to_toml", "FORMAT"]

FORMAT = "manipdyn-model/1"
_LENGTH = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254}
_ANGLE = {"rad": 1.0, "deg": math.pi / 180.0}
_MASS = {"kg": 1.0, "g": 0.001}

_TOP_KEYS = {"format", "name", "convention", "gravity", "source", "sources", "units", "links", "description",
             "transmission", "friction", "poses", "trust", "base", "tool"}
_LINK_REQUIRED = ("joint", "a", "alpha", "d", "theta", "mass")
_LINK_OPTIONAL = ("name", "qlim", "com", "inertia", "motor_inertia", "gear_ratio", "friction_viscous", "friction_coulomb")
_INERTIA_KEYS = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")


# ---------------------------------------------------------------------------
# Bundled models
# ---------------------------------------------------------------------------
def _bundled_dir():
    return resources.files("manipdyn.formats") / "models"


def models() -> list[str]:
    """Names of the bundled arm models, sorted (puma560, stanford and ur5 are not the Toolbox for Python's
    models of those names: ``arm.sources["toolbox"]`` and ``manipdyn models`` say what differs)."""
    return sorted(p.name[:-5] for p in _bundled_dir().iterdir() if p.name.endswith(".toml"))


def close_names(name, candidates) -> list:
    """Up to three of ``candidates`` closest to ``name``, case aside (``"UR5"``: ``["ur5", ...]``), best first."""
    import difflib

    folded: dict = {}
    for c in candidates:
        folded.setdefault(str(c).casefold(), c)
    return [folded[k] for k in difflib.get_close_matches(str(name).casefold(), list(folded), n=3, cutoff=0.6)]


def load_bundled(name: str, strict: bool = False) -> Manipulator:
    """A bundled model by name (see :func:`models`)."""
    if name not in models():
        close = close_names(name, models())
        hint = f"; did you mean {' or '.join(map(repr, close))}?" if close else ""
        raise ModelError(f"unknown model {name!r}: not a bundled model ({', '.join(models())}){hint}")
    path = _bundled_dir() / f"{name}.toml"
    return parse_model(path.read_text(encoding="utf-8"), f"bundled model {name}", strict=strict)


def load_model_file(path, strict: bool = False) -> Manipulator:
    """Read a TOML model file (format in this module's docstring)."""
    path = os.fspath(path)
    data = limits.read_regular(path, path, "MAX_MODEL_FILE_BYTES", "model file", "the model file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise ModelError(f"{path}: a model file is UTF-8 text; byte offset {exc.start} (line {line}) is "
                         f"not: {exc.reason} (byte {data[exc.start:exc.start + 1]!r})") from None
    return parse_model(text, path, strict=strict)


# ---------------------------------------------------------------------------
# Parsing
# ---------------------------------------------------------------------------
def _num(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ModelError(f"{where}: expected a number, got {type(value).__name__} {value!r}")
    try:
        v = float(value)
    except OverflowError:
        raise ModelError(f"{where}: expected a finite number, got an integer of {len(str(abs(value)))} "
                         "digits (beyond the float64 range)") from None
    if not math.isfinite(v):
        raise ModelError(f"{where}: expected a finite number, got {value!r}")
    if abs(v) > limits.MAX_MAGNITUDE:
        raise ModelError(f"{where}: magnitude {abs(v):g} is over {limits.MAX_MAGNITUDE:g} "
                         "(manipdyn.limits.MAX_MAGNITUDE): products of such numbers overflow float64")
    return v


def _nums(value, k: int, where: str) -> list[float]:
    if not isinstance(value, list) or len(value) != k:
        raise ModelError(f"{where}: expected a list of {k} numbers, got {value!r}")
    return [_num(v, f"{where}[{i}]") for i, v in enumerate(value)]


def _str(value, where: str) -> str:
    if not isinstance(value, str):
        raise ModelError(f"{where}: expected a string, got {type(value).__name__} {value!r}")
    return value


def _unit(units: dict, key: str, table: dict, default: str, where: str) -> float:
    u = units.get(key, default)
    if not isinstance(u, str) or u not in table:
        raise ModelError(f"{where}: key 'units.{key}' has unit {u!r} that manipdyn cannot read; "
                         f"expected one of {', '.join(table)}")
    return table[u]


def _inertia(value, scale: float, where: str) -> np.ndarray:
    if isinstance(value, dict):
        unknown = set(value) - set(_INERTIA_KEYS)
        if unknown:
            raise ModelError(f"{where}: unknown key(s) {sorted(unknown)}; expected {', '.join(_INERTIA_KEYS)}")
        for k in ("ixx", "iyy", "izz"):
            if k not in value:
                raise ModelError(f"{where}: missing key '{k}'")
        v = {k: _num(value.get(k, 0.0), f"{where}.{k}") * scale for k in _INERTIA_KEYS}
        return np.array([[v["ixx"], v["ixy"], v["ixz"]],
                         [v["ixy"], v["iyy"], v["iyz"]],
                         [v["ixz"], v["iyz"], v["izz"]]])
    if isinstance(value, list) and len(value) == 3 and all(isinstance(r, list) for r in value):
        return np.array([_nums(r, 3, f"{where}[{i}]") for i, r in enumerate(value)]) * scale
    if isinstance(value, list) and len(value) == 3:   # [ixx, iyy, izz]: a diagonal tensor, as in Python
        return np.diag(_nums(value, 3, where)) * scale
    raise ModelError(f"{where}: expected a table {{ ixx = ..., iyy = ..., izz = ..., ixy = ..., ixz = ..., iyz = ... }}, "
                     f"3 diagonal values [ixx, iyy, izz] or a 3x3 list, got {value!r}")


def _transform(data: dict, key: str, origin: str, L: float):
    """The optional top-level ``base`` / ``tool``: a 4x4 homogeneous transform as four rows, its
    translation in the file's length unit (checked by :class:`Manipulator`); None when absent."""
    if key not in data:
        return None
    raw = data[key]
    if not isinstance(raw, list) or len(raw) != 4 or not all(isinstance(r, list) for r in raw):
        raise ModelError(f"{origin}: key {key!r}: expected a 4x4 homogeneous transform as four rows of four "
                         f"numbers, got {raw!r:.80}")
    T = np.array([_nums(r, 4, f"{origin}: key {key!r} row {i + 1}") for i, r in enumerate(raw)])
    T[:3, 3] *= L
    return T


def parse_model(text: str, origin: str = "<model>", strict: bool = False) -> Manipulator:
    """Parse model-file text; ``origin`` names the file in error messages.

    Named steps: the TOML document (:func:`_read_toml`), the top-level keys
    and units (:func:`_top_level`), one :class:`DHLink` per ``[[links]]``
    table (:func:`_parse_link`), then the unit checks and the arm.
    """
    data = _read_toml(text, origin)
    if "urdf" in data:       # a URDF's chain with its drive (modelfile_urdf)
        return parse_urdf_model(data, origin, strict)
    name, convention, source, sources, units, (L, A, M), gravity = _top_level(data, origin)
    raw_links = data["links"]
    if not isinstance(raw_links, list) or not raw_links or not all(isinstance(l, dict) for l in raw_links):
        raise ModelError(f"{origin}: key 'links' must be a non-empty array of tables ([[links]])")
    links = [_parse_link(raw, i, origin, L, A, M) for i, raw in enumerate(raw_links)]
    description = _str(data.get("description", ""), f"{origin}: key 'description'")
    unit_notes = _unit_notes(origin, raw_links, units, links)
    if strict and unit_notes:
        raise ModelError("; ".join(unit_notes) + " (strict)")
    drive = parse_drive(data, origin, [l.gear_ratio for l in links])
    try:
        arm = Manipulator(links, convention=convention, gravity=gravity, name=name, strict=strict,
                          source=source, sources=sources, description=description, **drive,
                          poses=parse_poses(data, origin, [l.joint for l in links], L, A),
                          base=_transform(data, "base", origin, L), tool=_transform(data, "tool", origin, L))
    except ModelError as exc:
        if origin in str(exc):
            raise
        raise ModelError(f"{origin}: {exc}") from None  # always name the file
    arm.notes = tuple(unit_notes) + arm.notes
    if "trust" in data:
        arm.trust = trust_from_toml(data["trust"], origin)
    warn_notes(name or origin, unit_notes, SuspiciousValueWarning)
    return arm


#: a DH length above this (m) looks like millimetres (or cm) read as metres
_LONGEST_PLAUSIBLE = 10.0
#: an arm whose every non-zero DH length is below this (m) looks like metres read as mm
_SHORTEST_PLAUSIBLE = 5e-3
#: a link's radius of gyration ``sqrt(I_max / m)`` (largest principal moment about its
#: COM) beyond this many times the arm's size looks like inertias in a smaller unit
#: (kg mm^2, g cm^2, g mm^2 read as kg m^2: 1e3 to 3e4 times too large a radius).  The
#: bundled arms' radii are 0.09 to 0.27 times their size
_GYRATION_LARGEST = 2.0
#: ... and below this many times the arm's size (but not zero: point masses are fine),
#: like inertias in a larger unit (kg m^2 in a file of g and mm: 3e4 times too small).
#: The bundled arms' smallest is 0.006
_GYRATION_SMALLEST = 1e-4


def _read_toml(text, origin: str) -> dict:
    """The TOML document of a model file, or a ModelError naming ``origin``."""
    if not isinstance(text, str):
        raise ModelError(f"{origin}: model text must be a str, got {type(text).__name__}")
    if len(text) > limits.MAX_MODEL_FILE_BYTES:
        raise limits.over_limit(origin, "the model text length", f"{len(text)} characters",
                                "MAX_MODEL_FILE_BYTES")
    return read_toml_text(text, origin, "model file")


def _top_level(data: dict, origin: str):
    """Checked top-level keys: ``(name, convention, source, sources, units, (L, A, M), gravity)``,
    with ``L, A, M`` the factors from the file's units to m, rad and kg."""
    unknown = set(data) - _TOP_KEYS
    if unknown:
        raise ModelError(f"{origin}: unknown key(s) {sorted(unknown)}; expected some of {sorted(_TOP_KEYS)}")
    if "format" not in data:
        raise ModelError(f"{origin}: missing key 'format'; the first line of a model file is "
                         f'format = "{FORMAT}"')
    fmt = data["format"]
    if fmt != FORMAT:
        raise ModelError(f"{origin}: key 'format' is {fmt!r}; this manipdyn reads {FORMAT!r}")
    for key in ("name", "convention", "links"):
        if key not in data:
            raise ModelError(f"{origin}: missing key '{key}'")
    name = _str(data["name"], f"{origin}: key 'name'")
    convention = _str(data["convention"], f"{origin}: key 'convention'")
    if convention not in ("standard", "modified"):
        raise ModelError(f"{origin}: key 'convention' must be 'standard' or 'modified', got {convention!r}")
    source = _str(data.get("source", ""), f"{origin}: key 'source'")
    sources = data.get("sources", {})
    if not isinstance(sources, dict) or not all(isinstance(v, str) for v in sources.values()):
        raise ModelError(f"{origin}: key 'sources' must be a table of strings")
    units = data.get("units", {})
    if not isinstance(units, dict):
        raise ModelError(f"{origin}: key 'units' must be a table")
    bad_units = set(units) - {"length", "angle", "mass"}
    if bad_units:
        raise ModelError(f"{origin}: unknown key(s) {sorted('units.' + u for u in bad_units)}; expected units.length, units.angle, units.mass")
    L = _unit(units, "length", _LENGTH, "m", origin)
    A = _unit(units, "angle", _ANGLE, "rad", origin)
    M = _unit(units, "mass", _MASS, "kg", origin)
    gravity = _nums(data.get("gravity", [0.0, 0.0, -9.81]), 3, f"{origin}: key 'gravity'")

    return name, convention, source, sources, units, (L, A, M), gravity


def _parse_link(raw: dict, i: int, origin: str, L: float, A: float, M: float) -> DHLink:
    """One ``[[links]]`` table as a :class:`DHLink` in SI units; errors name ``links[i]``."""
    w = f"{origin}: links[{i}]" + (f" ({raw['name']})" if isinstance(raw.get("name"), str) else "")
    unknown = set(raw) - set(_LINK_REQUIRED) - set(_LINK_OPTIONAL)
    if unknown:
        raise ModelError(f"{w}: unknown key(s) {sorted(unknown)}; expected some of "
                         f"{', '.join(_LINK_REQUIRED + _LINK_OPTIONAL)}")
    for key in _LINK_REQUIRED:
        if key not in raw:
            raise ModelError(f"{w}: missing key '{key}'")
    joint = _str(raw["joint"], f"{w}: key 'joint'")
    if joint not in ("revolute", "prismatic"):
        raise ModelError(f"{w}: key 'joint' must be 'revolute' or 'prismatic', got {joint!r}")
    mass = _num(raw["mass"], f"{w}: key 'mass'") * M
    if mass > 0:
        for key in ("com", "inertia"):
            if key not in raw:
                raise ModelError(f"{w}: missing key '{key}' (required when mass > 0)")
    com = np.array(_nums(raw.get("com", [0.0, 0.0, 0.0]), 3, f"{w}: key 'com'")) * L
    inertia = _inertia(raw.get("inertia", {"ixx": 0.0, "iyy": 0.0, "izz": 0.0}), M * L * L, f"{w}: key 'inertia'")
    qlim = None
    if "qlim" in raw:
        qs = L if joint == "prismatic" else A
        qlim = tuple(v * qs for v in _nums(raw["qlim"], 2, f"{w}: key 'qlim'"))
    kw = {}
    for key, scale in (("motor_inertia", M * L * L), ("gear_ratio", 1.0),
                       ("friction_viscous", 1.0), ("friction_coulomb", 1.0)):
        if key in raw:
            kw[key] = _num(raw[key], f"{w}: key '{key}'") * scale
    try:
        return DHLink(
            joint=joint,
            a=_num(raw["a"], f"{w}: key 'a'") * L,
            alpha=_num(raw["alpha"], f"{w}: key 'alpha'") * A,
            d=_num(raw["d"], f"{w}: key 'd'") * L,
            theta=_num(raw["theta"], f"{w}: key 'theta'") * A,
            mass=mass, com=com, inertia=inertia, qlim=qlim,
            name=_str(raw.get("name", ""), f"{w}: key 'name'"), **kw,
        )
    except ModelError as exc:
        raise ModelError(f"{w}: {exc}") from None


def _unit_notes(origin: str, raw_links: list, units: dict, links: list) -> list[str]:
    """One-line notes on values that look like they are in another unit than the file says."""
    notes = []
    angle_unit = units.get("angle", "rad")
    if angle_unit == "rad":
        for i, raw in enumerate(raw_links):
            for key in ("alpha", "theta"):
                v = raw.get(key)
                if isinstance(v, (int, float)) and abs(v) > 2 * math.pi + 1e-9:
                    notes.append(f"{origin}: links[{i}] key '{key}' = {v!r} is more than 2 pi in a file "
                                 "whose angles are in rad: degrees? (set units.angle = \"deg\")")
    length_unit = units.get("length", "m")
    lengths = np.array([abs(v) for l in links for v in (l.a, l.d)])
    if lengths.size and lengths.max() > _LONGEST_PLAUSIBLE:
        notes.append(f"{origin}: a DH length of {lengths.max():.6g} m (after units.length = "
                     f"\"{length_unit}\"): the lengths look like they are in a smaller unit")
    nonzero = lengths[lengths > 0]
    if nonzero.size and nonzero.max() < _SHORTEST_PLAUSIBLE:
        notes.append(f"{origin}: every DH length is under {_SHORTEST_PLAUSIBLE * 1000:g} mm (largest "
                     f"{nonzero.max():.6g} m after units.length = \"{length_unit}\"): the lengths look "
                     "like they are in a larger unit")
    return notes + _gyration_notes(origin, units, links)


def _gyration_notes(origin: str, units: dict, links: list) -> list[str]:
    """Notes on links whose radius of gyration is implausible for their mass and the arm's size
    (inertias pasted in another unit than ``units.mass * units.length^2``)."""
    size = max(sum(abs(l.a) + abs(l.d) for l in links)
               + max(float(np.linalg.norm(l.com)) for l in links), 1e-3)
    unit = f"{units.get('mass', 'kg')} {units.get('length', 'm')}^2"
    notes = []
    for i, l in enumerate(links):
        if not l.mass > 0:
            continue
        k = math.sqrt(max(float(np.linalg.eigvalsh(l.inertia).max()), 0.0) / l.mass)
        if k > _GYRATION_LARGEST * size:
            what = (f"more than {_GYRATION_LARGEST:g} times the arm's size ({size:.3g} m)", "smaller",
                    "kg mm^2, g cm^2 or g mm^2")
        elif 0 < k < _GYRATION_SMALLEST * size:
            what = (f"under {_GYRATION_SMALLEST:g} times the arm's size ({size:.3g} m)", "larger", "kg m^2")
        else:
            continue
        notes.append(f"{origin}: links[{i}] key 'inertia': the radius of gyration sqrt(I_max / mass) = "
                     f"{k:.3g} m for {l.mass:.6g} kg is {what[0]}: the inertias look like they are in a "
                     f"{what[1]} unit than the file's {unit} (e.g. {what[2]})")
    return notes


# ---------------------------------------------------------------------------
# Writing
# ---------------------------------------------------------------------------
def model_to_toml(arm: Manipulator) -> str:
    """Model-file text for a DH arm, in SI units (m, rad, kg), floats written exactly; for a URDF
    arm, its URDF text with the drive (:mod:`manipdyn.formats.modelfile_urdf`)."""
    if getattr(arm, "urdf_text", None) is not None:
        return urdf_model_to_toml(arm, FORMAT)
    if not isinstance(arm, Manipulator):
        raise ModelError(f"save: only DH arms (Manipulator) have a model file; "
                         f"{type(arm).__name__} {arm.name!r} can be written with write_urdf()")
    lines = [
        f"format = {toml_str(FORMAT)}",
        f"name = {toml_str(arm.name, 'name')}",
        f"convention = {toml_str(arm.convention)}",
        f"gravity = {toml_list(arm.gravity)}",
        f"source = {toml_str(arm.source, 'source')}",
    ]
    if arm.description:
        lines.append(f"description = {toml_str(arm.description, 'description')}")
    for key in ("base", "tool"):       # rows of a 4x4 homogeneous transform, metres; none: the identity
        T = getattr(arm, key, None)
        if T is not None and not np.array_equal(T, np.eye(4)):
            lines.append(f"{key} = [" + ", ".join(toml_list(r) for r in T) + "]")
    sources = arm.sources
    if sources:
        if not isinstance(sources, dict):
            raise ModelError(f"save: sources must be a dict of strings, got {type(sources).__name__}")
        lines += ["", "[sources]"] + [f"{toml_key(k, 'a key of sources')} = {toml_str(v, f'sources[{k!r}]')}"
                                      for k, v in sources.items()]
    lines += ["", "[units]", 'length = "m"', 'angle = "rad"', 'mass = "kg"']
    for l in arm.links:
        I = l.inertia
        lines += [
            "", "[[links]]",
            *( [f"name = {toml_str(l.name, 'a link name')}"] if l.name else [] ),
            f"joint = {toml_str(l.joint)}",
            f"a = {toml_num(l.a)}", f"alpha = {toml_num(l.alpha)}",
            f"d = {toml_num(l.d)}", f"theta = {toml_num(l.theta)}",
            *( [f"qlim = {toml_list(l.qlim)}"] if l.qlim is not None else [] ),
            f"mass = {toml_num(l.mass)}",
            f"com = {toml_list(l.com)}",
            "inertia = { " + ", ".join(
                f"{k} = {toml_num(v)}" for k, v in zip(
                    _INERTIA_KEYS, (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]))) + " }",
        ]
        if l.motor_inertia or l.gear_ratio != 1.0:
            lines += [f"motor_inertia = {toml_num(l.motor_inertia)}", f"gear_ratio = {toml_num(l.gear_ratio)}"]
        if l.friction_viscous or l.friction_coulomb:
            lines += [f"friction_viscous = {toml_num(l.friction_viscous)}",
                      f"friction_coulomb = {toml_num(l.friction_coulomb)}"]
    lines += drive_to_toml(arm) + poses_to_toml(arm)
    lines += trust_to_toml(getattr(arm, "trust", None))
    return "\n".join(lines) + "\n"


def save_model(arm: Manipulator, path) -> None:
    """Write ``arm`` as a model file, atomically.

    Whatever this writes, :func:`load_model_file` reads back: a model whose file
    would be over :data:`manipdyn.limits.MAX_MODEL_FILE_BYTES` (e.g. a description
    of megabytes) is refused here, before anything is written, with how to raise it.
    """
    text = model_to_toml(arm)
    size = len(text.encode("utf-8"))
    if size > limits.MAX_MODEL_FILE_BYTES:
        raise ModelError(
            f"save {os.fspath(path)}: the model file would be {size} bytes, over the {limits.MAX_MODEL_FILE_BYTES} "
            "bytes that load reads (manipdyn.limits.MAX_MODEL_FILE_BYTES); shorten the description or "
            "sources, or raise the limit (manipdyn.limits.MAX_MODEL_FILE_BYTES = ...) where it is saved and loaded")
    atomic_write_text(path, text)
