"""Model files of URDF arms: the URDF's chain with the drive that URDF cannot state.

Layer 2 (formats), part of :mod:`manipdyn.formats.modelfile`.  A URDF holds the
chain, the inertials and joint-side viscous and Coulomb friction (``<dynamics>``), but no
gear, no rotor inertia, no motor-side or Stribeck friction.  An arm identified from a URDF
prior with those (``manipdyn identify ROBOT.urdf LOG --armature --friction-terms ...
-o OUT.toml``) is written as a model file that embeds the URDF text::

    format = "manipdyn-model/1"
    name = "arm_id"
    source = "identified by manipdyn ..."
    gravity = [0.0, 0.0, -9.81]
    tip = "tool0"                      # optional: the chain's last link in a tree URDF
    urdf = '''
    <robot name="...">...</robot>
    '''                                # the URDF text (kinematics, inertials), as written

    [transmission]                     # SI, as in DH model files, plus for a URDF's motors:
    gear_ratio = [...]                 # R's diagonal (a DH model's links hold it)
    motor_inertia = [...]              # rotor inertia Jm at each motor, kg m^2
    coupling = [[6, 5, 32.0]]          # motor_offset, torque_constant: as in DH model files

    [friction]                         # the friction law, as in DH model files (replaces <dynamics>)

    [trust]                            # what the fit carries (manipdyn.formats.trust), as in DH model files

``md.load`` reads it back as a :class:`manipdyn.URDFArm` that predicts what the fit predicted.
"""

from __future__ import annotations

import math

import numpy as np

from .._support.errors import ModelError
from .modelfile_drive import TRANSMISSION_KEYS, parse_drive
from .tomltext import toml_list, toml_num, toml_str
from .trust import trust_from_toml, trust_to_toml, without_trust_comment

__all__ = ["URDF_MODEL_KEYS", "parse_urdf_model", "urdf_model_to_toml"]

#: top-level keys of a URDF model file
URDF_MODEL_KEYS = {"format", "name", "gravity", "source", "sources", "description", "urdf", "tip", "transmission",
                   "friction", "trust"}
#: the [transmission] keys a URDF model adds to a DH model's
URDF_DRIVE_KEYS = ("gear_ratio", "motor_inertia")


def _text(value, where):
    if not isinstance(value, str):
        raise ModelError(f"{where}: expected a string, got {type(value).__name__}")
    return value


def _floats(value, n, where, positive=False):
    if not isinstance(value, list) or len(value) != n or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value):
        raise ModelError(f"{where}: expected a list of {n} finite numbers (one per joint), got {value!r:.80}")
    if positive and any(v < 0 for v in value):
        raise ModelError(f"{where}: expected numbers >= 0, got {value}")
    return np.array(value, dtype=np.float64)


def parse_urdf_model(data: dict, origin: str, strict: bool = False):
    """The :class:`manipdyn.URDFArm` of a URDF model file's TOML ``data`` (module docstring)."""
    from .urdf.reader import load_urdf

    unknown = set(data) - URDF_MODEL_KEYS
    if unknown:
        raise ModelError(f"{origin}: unknown key(s) {sorted(unknown)} in a model file with 'urdf'; expected some of "
                         f"{sorted(URDF_MODEL_KEYS)} (links and units belong to DH model files)")
    text = _text(data["urdf"], f"{origin}: key 'urdf'")
    if not text.lstrip("\ufeff \t\r\n").startswith("<"):
        # the URDF's text itself, never a path: a model file received from someone else must
        # not make manipdyn open a file of this machine (load_urdf would take a path)
        raise ModelError(f"{origin}: key 'urdf': expected the URDF text itself (starting with '<'), got "
                         f"{text!r:.60}; a model file carries its URDF, it never names a file (write one "
                         "with manipdyn.save(arm, 'FILE.toml') from manipdyn.load('ROBOT.urdf'))")
    tip = _text(data["tip"], f"{origin}: key 'tip'") if "tip" in data else None
    name = _text(data.get("name", ""), f"{origin}: key 'name'") or None
    gravity = _floats(data.get("gravity", [0.0, 0.0, -9.81]), 3, f"{origin}: key 'gravity'")
    sources = data.get("sources", {})
    if not isinstance(sources, dict) or not all(isinstance(v, str) for v in sources.values()):
        raise ModelError(f"{origin}: key 'sources' must be a table of strings")
    try:
        chain = load_urdf(text, tip=tip, name=name, gravity=gravity, strict=strict)
    except ModelError as exc:
        raise ModelError(f"{origin}: key 'urdf': {exc}") from None
    n = chain.n
    table = data.get("transmission", {})
    if not isinstance(table, dict):
        raise ModelError(f"{origin}: key 'transmission' must be a table ([transmission])")
    G = (_floats(table["gear_ratio"], n, f"{origin}: key 'transmission.gear_ratio'") if "gear_ratio" in table
         else np.ones(n))
    Jm = (_floats(table["motor_inertia"], n, f"{origin}: key 'transmission.motor_inertia'", positive=True)
          if "motor_inertia" in table else np.zeros(n))
    rest = dict(data)
    if "transmission" in data:
        rest["transmission"] = {k: v for k, v in table.items() if k not in URDF_DRIVE_KEYS}
    drive = parse_drive(rest, origin, list(G))
    transmission = drive["transmission"]
    if transmission is None and (np.any(G != 1.0) or np.any(Jm)):
        from ..model.drive import Transmission

        transmission = Transmission(np.diag(G))
    try:
        arm = load_urdf(text, tip=tip, name=name, gravity=gravity, strict=strict, transmission=transmission,
                        friction=drive["friction"], motor_inertia=Jm if np.any(Jm) else None)
    except ModelError as exc:
        raise ModelError(f"{origin}: {exc}") from None
    arm.source = _text(data.get("source", arm.source), f"{origin}: key 'source'")
    arm.sources = dict(sources)
    arm.description = _text(data.get("description", ""), f"{origin}: key 'description'")
    if "trust" in data:           # the table wins over a trust comment inside the URDF text
        arm.trust = trust_from_toml(data["trust"], origin)
    return arm


def _multiline(text: str) -> str:
    """``text`` as a TOML multi-line literal string when it can be one, else a basic string (:func:`toml_str`)."""
    ok = "'''" not in text and not text.endswith("'") and all(
        ch in "\n\t" or (ord(ch) >= 0x20 and ord(ch) != 0x7F) for ch in text)
    return "'''\n" + text + "'''" if ok else toml_str(text, "urdf")


def urdf_model_to_toml(arm, fmt: str) -> str:
    """Model-file text of a URDF arm with its drive (module docstring); strings, floats and lists
    written exactly (:mod:`manipdyn.formats.tomltext`)."""
    lines = [f"format = {toml_str(fmt)}", f"name = {toml_str(arm.name, 'name')}", f"gravity = {toml_list(arm.gravity)}",
             f"source = {toml_str(getattr(arm, 'source', '') or '', 'source')}"]
    if getattr(arm, "description", ""):
        lines.append(f"description = {toml_str(arm.description, 'description')}")
    if arm.tip is not None:
        lines.append(f"tip = {toml_str(arm.tip, 'tip')}")
    text = arm.urdf_text if getattr(arm, "trust", None) is None else without_trust_comment(arm.urdf_text)
    lines.append(f"urdf = {_multiline(text)}")
    sources = getattr(arm, "sources", None) or {}
    if sources:
        lines += ["", "[sources]"] + [f"{toml_str(k, 'a key of sources')} = {toml_str(v, 'a source')}"
                                      for k, v in sources.items()]
    t = arm.transmission
    G = np.diag(t.R)
    if np.any(G != 1.0) or np.any(arm.motor_inertia) or not t.is_diagonal or np.any(t.motor_offset) \
            or t.torque_constant is not None:
        lines += ["", "[transmission]", f"gear_ratio = {toml_list(G)}", f"motor_inertia = {toml_list(arm.motor_inertia)}"]
        if not t.is_diagonal:
            lines.append("coupling = [" + ", ".join(f"[{r}, {c}, {toml_num(v)}]" for r, c, v in t.coupling) + "]")
        for key in TRANSMISSION_KEYS[1:]:
            v = getattr(t, key)
            if v is not None and np.any(v):
                lines.append(f"{key} = {toml_list(v)}")
    f = arm.friction_model
    if f is not None:
        lines += ["", "[friction]", f'side = "{f.side}"', f"smoothing = {toml_num(f.smoothing)}",
                  f"deadband = {toml_num(f.deadband)}"]
        for k in ("viscous", "coulomb", "coulomb_pos", "coulomb_neg", "offset", "stribeck_level",
                  "stribeck_velocity", "sigmoid_A", "sigmoid_alpha", "sigmoid_p3"):
            v = getattr(f, k)
            if v is None or (k in ("coulomb_pos", "coulomb_neg") and not f.asymmetric):
                continue
            lines.append(f"{k} = {toml_list(v)}")
        if f.stribeck_level is not None:
            lines.append(f"stribeck_exponent = {toml_num(f.stribeck_exponent)}")
    lines += trust_to_toml(getattr(arm, "trust", None))
    return "\n".join(lines) + "\n"
