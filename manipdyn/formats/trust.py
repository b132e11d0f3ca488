"""The trust record a model carries from its identification, on every route to and from disk.

Layer 2 (formats).

A model identified from logs is only as good as what it was fitted on, so the model keeps,
as ``arm.trust`` (a plain JSON-ready ``dict``, or None), what ``validate`` needs to say how
far to trust it on new data: the data file's name and sha256, the method and options of the
fit, the states it saw (``fitted_range``), the prediction band from blocked hold-outs of its
data (``prediction_band``), the reference for the extrapolation measure (``leverage``: how
far a new state is from what the fit data excited, joint by joint), and what the fit found
doubtful (``doubts``).  The identification layer (``manipdyn.identification.trust``) builds
and reads the fields; this module only moves the record across the disk, and it is the
**one** place that does, for every kind of file:

* a TOML model file, DH or with an embedded URDF (the bundled models are such files): a
  ``[trust]`` table (:func:`trust_to_toml`, :func:`trust_from_toml`), numbers written exactly;
* a URDF (what ``md.to_urdf``, ``manipdyn urdf`` and ``identify -o OUT.urdf`` write): one
  XML comment ``<!-- manipdyn-trust/1 {JSON} -->`` after ``<robot>``
  (:func:`trust_comment`, :func:`trust_from_urdf`), which URDF readers ignore and
  :func:`manipdyn.load` reads back;
* a base model JSON: the key ``"trust"`` (:func:`trust_to_json`, :func:`trust_from_json`).

The record's keys (all optional but ``format``; JSON types; SI units)::

    format            "manipdyn-trust/1"
    data, data_sha256 the fit data's file name(s) and sha256(s), ", "-separated
    method, prior, date, options (object), rms_residual (n numbers, N m or N)
    fitted_range      {"q", "qd", "tau"}: n [min, max] pairs each
    prediction_band   {"method", "level", "folds", "samples", "half_width", "held_out_rms", ...}
    leverage          the extrapolation measure's reference (identification.trust)
    doubts            [strings]: degenerate inertias, contradicted payloads, runs far off
    collision         collision thresholds (manipdyn.control.collision): {"threshold", "gain", ...}
    decided           what the data decided and what the prior kept: {"weight", "links" (n of "data",
                      "prior", "floor"), "prior" (the base parameters the logs do not excite)}
    torque_constants  one line: the k_t found from currents, their standard deviations and where the scale came
                      from (a payload, the model's k_t, the prior's gravity)
    rest              the joints at rest (manipdyn.model.friction_rest): {"threshold" rad/s, "static_level" N m,
                      "measured", "rest_fraction", "slow" rad/s}, n each

A record that does not read is a :class:`ModelError` naming the file and the key.
"""

from __future__ import annotations

import json
import math
import re

from .._support import limits
from .._support.errors import ModelError
from .tomltext import toml_key, toml_str

__all__ = ["TRUST_FORMAT", "check_trust", "trust_to_toml", "trust_from_toml", "trust_comment", "trust_from_urdf",
           "strip_trust_comments", "without_trust_comment", "trust_to_json", "trust_from_json"]

TRUST_FORMAT = "manipdyn-trust/1"
_COMMENT_HEAD = " " + TRUST_FORMAT + " "


#: the record's numbers that are widths, scales or weights: a negative one is no record manipdyn wrote
_NONNEGATIVE = {"prediction_band": ("half_width", "held_out_rms", "leverage_gain", "slow_speed", "slow_half_width"),
                "leverage": ("weights", "scale", "mean", "largest", "smoothing"),
                "rest": ("threshold", "static_level", "rest_fraction", "slow")}


def _plain(value, where: str, depth: int = 0):
    """``value`` checked to be JSON-ready and TOML-writable: str, bool, int, finite float of at most
    :data:`manipdyn.limits.MAX_MAGNITUDE`, lists, string-keyed dicts, nested at most
    :data:`manipdyn.limits.MAX_JSON_DEPTH` deep (TOML has no null: None values are dropped from dicts, and
    written ``"none"`` in lists, e.g. an open ``t_range``)."""
    if depth > limits.MAX_JSON_DEPTH:
        raise ModelError(f"{where}: nested deeper than the limit of {limits.MAX_JSON_DEPTH} "
                         "(manipdyn.limits.MAX_JSON_DEPTH)")
    if isinstance(value, bool) or isinstance(value, str):
        return value
    if isinstance(value, (int, float)) or hasattr(value, "dtype"):
        try:
            v = float(value)
        except (TypeError, ValueError, OverflowError):
            raise ModelError(f"{where}: expected a number float64 holds, got {value!r:.60}") from None
        if not math.isfinite(v):
            raise ModelError(f"{where}: expected a finite number, got {v}")
        if abs(v) > limits.MAX_MAGNITUDE:
            raise ModelError(f"{where}: {v:g} is beyond the largest number a trust record may hold, "
                             f"{limits.MAX_MAGNITUDE:g} (manipdyn.limits.MAX_MAGNITUDE)")
        return int(value) if isinstance(value, int) else v
    if isinstance(value, (list, tuple)) or (hasattr(value, "tolist") and not isinstance(value, dict)):
        items = value.tolist() if hasattr(value, "tolist") else value
        return [("none" if x is None else _plain(x, f"{where}[{k}]", depth + 1)) for k, x in enumerate(items)]
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise ModelError(f"{where}: keys must be strings, got {k!r}")
            if v is not None:
                out[k] = _plain(v, f"{where}.{k}", depth + 1)
        return out
    raise ModelError(f"{where}: expected numbers, strings, lists or tables, got {type(value).__name__}")


def _nonnegative(record: dict, where: str) -> None:
    """A ModelError naming the key when one of :data:`_NONNEGATIVE`'s numbers is negative."""
    for table, keys in _NONNEGATIVE.items():
        sub = record.get(table)
        if not isinstance(sub, dict):
            continue
        for key in keys:
            stack = [(sub.get(key), f"{where}.{table}.{key}")]
            while stack:
                x, name = stack.pop()
                if isinstance(x, list):
                    stack.extend((y, f"{name}[{k}]") for k, y in enumerate(x))
                elif isinstance(x, (int, float)) and not isinstance(x, bool) and x < 0:
                    raise ModelError(f"{name}: expected a number >= 0, got {x!r}")


def check_trust(value, where: str = "trust") -> dict:
    """``value`` as a plain trust record (module docstring), or a :class:`ModelError` naming ``where``."""
    if not isinstance(value, dict):
        raise ModelError(f"{where}: expected a table/object with format = {TRUST_FORMAT!r}, "
                         f"got {type(value).__name__}")
    fmt = value.get("format")
    if fmt != TRUST_FORMAT:
        raise ModelError(f"{where}: key 'format' is {fmt!r}; this manipdyn reads {TRUST_FORMAT!r}")
    record = _plain(value, where)
    _nonnegative(record, where)
    return record


# -- TOML -------------------------------------------------------------------------------------------------------
def _toml_key(k: str) -> str:
    return toml_key(k, "a key of the trust record")


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        return toml_str(v, "a string of the trust record")
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"


def trust_to_toml(record) -> list[str]:
    """The lines of a model file's ``[trust]`` table (and its ``[trust.KEY]`` sub-tables), empty for None."""
    if record is None:
        return []
    record = check_trust(record, "save: the arm's trust record")
    lines = ["", "[trust]"]
    tables = []
    for k, v in record.items():
        if isinstance(v, dict):
            tables.append((k, v))
        else:
            lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
    for k, table in tables:
        lines += ["", f"[trust.{_toml_key(k)}]"] + [f"{_toml_key(a)} = {_toml_value(b)}" for a, b in table.items()]
    return lines


def trust_from_toml(value, origin: str) -> dict:
    """A model file's ``[trust]`` table as a record; errors name ``origin``."""
    return check_trust(value, f"{origin}: key 'trust'")


# -- URDF -------------------------------------------------------------------------------------------------------
def trust_comment(record) -> str | None:
    """The body of the URDF comment holding ``record`` (None for None): JSON, ``--`` escaped inside strings
    (the only place JSON can hold it), so the comment is well-formed XML."""
    if record is None:
        return None
    text = json.dumps(check_trust(record, "the arm's trust record"), ensure_ascii=True, separators=(",", ":"))
    return _COMMENT_HEAD + text.replace("--", "-\\u002d") + " "


def strip_trust_comments(root) -> None:
    """Remove the trust comments directly under the lxml ``<robot>`` element ``root`` (before writing a new one)."""
    from lxml import etree

    for node in list(root):
        if isinstance(node, etree._Comment) and (node.text or "").startswith(_COMMENT_HEAD):
            root.remove(node)


def without_trust_comment(text: str) -> str:
    """URDF ``text`` with its trust comments removed (a model file holds the record once, in ``[trust]``)."""
    return re.sub(r"[ \t]*<!--" + re.escape(_COMMENT_HEAD) + r".*?-->\n?", "", text, flags=re.S)


def trust_from_urdf(root, label: str):
    """The record in ``<robot>``'s trust comment (lxml element ``root``), or None; errors name ``label``."""
    from lxml import etree

    for node in root:
        if isinstance(node, etree._Comment) and (node.text or "").startswith(_COMMENT_HEAD):
            try:
                value = json.loads(node.text[len(_COMMENT_HEAD):])
            except ValueError as exc:
                raise ModelError(f"{label}, line {node.sourceline}: the {TRUST_FORMAT} comment is not JSON "
                                 f"({exc})") from None
            except RecursionError:
                raise ModelError(f"{label}, line {node.sourceline}: the {TRUST_FORMAT} comment is nested deeper "
                                 f"than the limit of {limits.MAX_JSON_DEPTH} (manipdyn.limits.MAX_JSON_DEPTH)") from None
            return check_trust(value, f"{label}: the {TRUST_FORMAT} comment")
    return None


# -- base model JSON --------------------------------------------------------------------------------------------
def trust_to_json(record):
    """The value of a base model's ``"trust"`` key (None stays None)."""
    return None if record is None else check_trust(record, "the base model's trust record")


def trust_from_json(value, where: str):
    """A base model's ``"trust"`` value as a record (None when absent)."""
    return None if value is None else check_trust(value, f"{where}: key 'trust'")
