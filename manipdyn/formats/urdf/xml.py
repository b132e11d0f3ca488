"""Reading a URDF document safely: bytes to an lxml tree, and URDF's number grammar.

Layer 2 (formats: urdf) loaders (URDF).  A document whose DOCTYPE declares entities or
points at an external DTD is refused before any expansion (XML external
entities, the "billion laughs" bomb).  Pinocchio (whose XML reader does not
guard against them) only ever sees text that passed this check.
"""

from __future__ import annotations

import math
import os
import re

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError
from ...model.kinematics import rpy_to_matrix
from ...model.links import check_name

__all__ = ["MOVABLE", "KNOWN_TYPES", "check_numbers", "read_source", "decode", "parse_xml", "where_in", "read_number",
           "read_vector3", "read_origin", "one_child", "read_name"]

MOVABLE = ("revolute", "continuous", "prismatic")
KNOWN_TYPES = MOVABLE + ("fixed", "floating", "planar")

# An XML/URDF number: ASCII digits only (``\d`` would also take Arabic-Indic or
# fullwidth digits, which urdfdom refuses), no nan, inf, hex or Python-only
# forms (underscores).
NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\Z", re.ASCII)
#: the attributes URDF reads as numbers or vectors of numbers
NUMBER_ATTRIBUTES = ("xyz", "rpy", "value", "ixx", "ixy", "ixz", "iyy", "iyz", "izz", "lower", "upper",
                     "effort", "velocity", "damping", "friction", "multiplier", "offset")
# a number attribute whose raw text holds a tab, CR or LF, literally or as a
# character reference: lxml reads it as a space, urdfdom as part of a number
_RAW_NUMBER_ATTR = re.compile(
    r"(?<![\w.:-])(" + "|".join(NUMBER_ATTRIBUTES) + r")\s*=\s*(\"[^\"]*\"|'[^']*')")
_RAW_WS = re.compile(r"[\t\r\n]|&#(?:x0*[9aAdD]|0*(?:9|10|13));")
_COMMENT = re.compile(r"<!--.*?-->", re.S)


# ---------------------------------------------------------------------------
# Reading the source safely
# ---------------------------------------------------------------------------
def read_source(source):
    """Return ``(data: bytes or str, label for messages, path or None)``."""
    if isinstance(source, (bytes, bytearray)):
        return bytes(source), "URDF text", None
    if isinstance(source, str) and source.lstrip("\ufeff \t\r\n").startswith("<"):
        return source, "URDF text", None
    if isinstance(source, (str, os.PathLike)):
        path = os.fspath(source)
        label = f"URDF file {os.path.basename(path)}"
        return limits.read_regular(path, label, "MAX_FILE_BYTES", repr(path)), label, path
    raise ModelError(
        f"URDF source: expected a path or URDF text, got {type(source).__name__}"
    )


def decode(data, label: str) -> str:
    """The document as text (UTF-8 unless a BOM or the XML declaration says otherwise)."""
    if isinstance(data, str):
        text = data
        if len(text) > limits.MAX_FILE_BYTES:
            raise limits.over_limit(label, "the text length", f"{len(text)} characters", "MAX_FILE_BYTES")
    else:
        if len(data) > limits.MAX_FILE_BYTES:
            raise limits.over_limit(label, "the text length", f"{len(data)} bytes", "MAX_FILE_BYTES")
        text = decode_bytes(data, label)
    if "\x00" in text:  # XML forbids NUL; also what UTF-16 read as UTF-8 looks like
        raise ModelError(f"{label}: the text contains NUL characters (not XML, or UTF-16 without a BOM)")
    return text.lstrip("\ufeff")


def decode_bytes(data: bytes, label: str) -> str:
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        codec = "utf-16"
    else:
        codec = "utf-8-sig"
        m = re.match(rb"\s*<\?xml[^>]*encoding\s*=\s*[\"']([A-Za-z0-9._-]+)[\"']", data)
        if m:
            codec = m.group(1).decode("ascii")
            if codec.lower().replace("_", "-") in ("utf-8", "utf8"):
                codec = "utf-8-sig"
    try:
        return data.decode(codec)
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise ModelError(f"{label}: not valid {codec} text: byte offset {exc.start} (line {line}): "
                         f"{exc.reason} (byte {data[exc.start:exc.start + 1]!r})") from None
    except LookupError as exc:
        raise ModelError(f"{label}: cannot decode the text ({codec}): {exc}") from None


def refuse_doctype(text: str, label: str) -> None:
    """Refuse any DOCTYPE, BEFORE parsing.

    A URDF has no use for one, and the two readers treat it differently:
    libxml2 (manipdyn's reader) applies ``<!ATTLIST>`` defaults and would
    expand internal entities even with ``resolve_entities=False``, while
    urdfdom (Pinocchio's reader) ignores them: the same file would describe
    two arms.  Entities are also how external-entity and entity-expansion
    ("billion laughs") attacks work.  Nothing is expanded or loaded.
    """
    k = text.find("<!DOCTYPE")
    if k >= 0:
        line = text.count("\n", 0, k) + 1
        raise ModelError(
            f"{label}: refused: a DOCTYPE at line {line} (entities, ATTLIST defaults, external DTDs) "
            "is read differently by libxml2 and by urdfdom, Pinocchio's reader; a URDF needs none: "
            "remove it"
        )


def refuse_raw_whitespace(text: str, label: str) -> None:
    """Refuse a tab, CR or LF inside a number attribute (``xyz="0\t0 1"``).

    XML turns them into spaces for libxml2 but urdfdom keeps them and then
    fails to read the number (or, for ``<inertial>``, silently drops the
    whole element): the two readers would read different arms.  Only the
    ASCII space separates the numbers of a vector.
    """
    body = _COMMENT.sub(lambda m: "\n" * m.group(0).count("\n"), text)
    for m in _RAW_NUMBER_ATTR.finditer(body):
        if _RAW_WS.search(m.group(2)):
            line = body.count("\n", 0, m.start()) + 1
            raise ModelError(
                f"{label}, line {line}: {m.group(1)}={m.group(2)[1:-1]!r}: a tab or line break inside a "
                "number attribute; separate the numbers with spaces (urdfdom, Pinocchio's reader, "
                "reads the attribute differently)"
            )


XML_DECL = re.compile(r"\s*<\?xml\b[^>]*\?>")


def parse_xml(text: str, label: str):
    from lxml import etree

    refuse_doctype(text, label)
    refuse_raw_whitespace(text, label)
    # lxml parses a str only without an encoding declaration; the text is already
    # decoded, so drop the declaration (keeping its newlines: line numbers stay right).
    m = XML_DECL.match(text)
    body = text if m is None else "\n" * m.group(0).count("\n") + text[m.end():]
    parser = etree.XMLParser(
        resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False,
        dtd_validation=False, remove_comments=False,
    )
    try:
        root = etree.fromstring(body, parser)
    except etree.XMLSyntaxError as exc:
        raise ModelError(f"{label}: not well-formed XML: {exc}") from None
    # processing instructions: urdfdom's XML parser (TinyXML2) refuses them inside the document
    pis = [n for n in root.iter(etree.PI)] + [n for n in root.itersiblings(etree.PI, preceding=True)] \
        + [n for n in root.itersiblings(etree.PI)]
    if pis:
        raise ModelError(f"{label}, line {pis[0].sourceline}: refused: a processing instruction "
                         f"<?{pis[0].target} ...?>; urdfdom (Pinocchio's reader) refuses them: remove it")
    # Second line of defence, on what libxml2 actually saw.
    info = root.getroottree().docinfo
    dtd = info.internalDTD
    if dtd is not None or info.doctype or info.system_url or info.public_id:
        raise ModelError(f"{label}: refused: a DOCTYPE; a URDF needs none: remove it")
    return root


# ---------------------------------------------------------------------------
# Strict element readers
# ---------------------------------------------------------------------------
def where_in(label: str, el, what: str) -> str:
    line = getattr(el, "sourceline", None)
    return f"{label}, line {line}, {what}" if line else f"{label}, {what}"


def parse_number(s: str):
    """A URDF number as urdfdom reads it, or None: ASCII, finite, within
    :data:`manipdyn.limits.MAX_MAGNITUDE`, and not a non-zero literal that
    underflows to 0 (urdfdom refuses those)."""
    if not NUMBER.match(s):
        return None
    v = float(s)
    if not (abs(v) <= limits.MAX_MAGNITUDE):
        return None
    if v == 0.0 and s.lstrip("+-").split("e")[0].split("E")[0].strip("0.") != "":
        return None  # underflow: "1e-400"
    return v


def why_not_a_number(s: str) -> str:
    """Why ``s`` (one number, no spaces expected) is refused, in words."""
    if s != s.strip():
        return "a leading or trailing space or line break (urdfdom refuses it)"
    if any(not c.isascii() for c in s):
        return "non-ASCII characters (urdfdom reads ASCII digits only)"
    if not NUMBER.match(s):
        return "not a decimal number (no nan, inf, hex or 1_000)"
    v = float(s)
    if not math.isfinite(v) or abs(v) > limits.MAX_MAGNITUDE:
        return (f"magnitude over {limits.MAX_MAGNITUDE:g} (manipdyn.limits.MAX_MAGNITUDE: products of "
                "such numbers overflow)")
    return "a non-zero number that underflows to 0 (urdfdom refuses it)"


def _bad_number(where, el, attr, raw, expected) -> ModelError:
    if expected.startswith("expected "):
        parts = [p for p in raw.split(" ") if p]
        bad = [p for p in parts if parse_number(p) is None]
        why = f"{len(parts)} found" if not bad else f"{bad[0]!r}: {why_not_a_number(bad[0])}"
    else:
        why = why_not_a_number(raw)
    return ModelError(f"{where}: <{el.tag} {attr}=\"{raw}\">: {expected}: {why}")


def read_number(el, attr: str, where: str, default=None) -> float:
    """A scalar number attribute: no spaces at all (urdfdom refuses a trailing
    space everywhere and a leading one in ``<limit>``)."""
    raw = el.get(attr)
    if raw is None:
        if default is None:
            raise ModelError(f"{where}: <{el.tag}> is missing the attribute '{attr}'")
        return default
    v = parse_number(raw)
    if v is None:
        raise _bad_number(where, el, attr, raw, "not a finite number")
    return v


def read_vector3(el, attr: str, where: str, default) -> np.ndarray:
    """Three numbers separated by ASCII spaces (any number of them, as urdfdom)."""
    raw = el.get(attr)
    if raw is None:
        return np.array(default, dtype=np.float64)
    parts = [p for p in raw.split(" ") if p]
    vals = [parse_number(p) for p in parts]
    if len(vals) != 3 or any(v is None for v in vals):
        raise _bad_number(where, el, attr, raw, "expected 3 finite numbers separated by spaces")
    return np.array(vals, dtype=np.float64)


#: every number attribute urdfdom parses (in <joint> and <link> and their
#: children), with the count of numbers it holds
URDFDOM_NUMBERS = {"xyz": 3, "rpy": 3, "size": 3, "scale": 3, "rgba": 4, "radius": 1, "length": 1,
                   "value": 1, "ixx": 1, "ixy": 1, "ixz": 1, "iyy": 1, "iyz": 1, "izz": 1, "lower": 1,
                   "upper": 1, "effort": 1, "velocity": 1, "damping": 1, "friction": 1, "multiplier": 1,
                   "offset": 1, "rising": 1, "falling": 1, "soft_lower_limit": 1, "soft_upper_limit": 1,
                   "k_position": 1, "k_velocity": 1}


def check_numbers(el, where: str) -> None:
    """Check the grammar of every number urdfdom reads under ``el`` (a <link> or <joint>).

    manipdyn uses only some of them (not a visual's size, nor a fixed joint's
    <limit>), but urdfdom parses them all and refuses the whole file, or drops
    the element, on one it cannot read: refused here first, with the place.
    """
    for sub in el.iter():
        if not isinstance(sub.tag, str):
            continue
        for attr, raw in sub.attrib.items():
            k = URDFDOM_NUMBERS.get(attr)
            if k is None or (attr == "value" and sub.tag != "mass") or (attr == "length" and sub.tag != "cylinder"):
                continue
            parent = sub.getparent()
            w = where if sub is el or parent is el else f"{where} <{parent.tag}>"
            if k == 1:
                if parse_number(raw) is None:
                    raise _bad_number(w, sub, attr, raw, "not a finite number")
            else:
                parts = [p for p in raw.split(" ") if p]
                if len(parts) != k or any(parse_number(p) is None for p in parts):
                    raise _bad_number(w, sub, attr, raw, f"expected {k} finite numbers separated by spaces")


def read_origin(parent_el, where: str) -> np.ndarray:
    """The 4x4 transform of the ``<origin xyz rpy>`` child (identity if absent)."""
    els = parent_el.findall("origin")
    if len(els) > 1:
        raise ModelError(f"{where}: more than one <origin>")
    T = np.eye(4)
    if els:
        o = els[0]
        xyz = read_vector3(o, "xyz", where, (0.0, 0.0, 0.0))
        rpy = read_vector3(o, "rpy", where, (0.0, 0.0, 0.0))
        limits.check_range(xyz, f"{where} <origin>", "xyz", "length")
        limits.check_range(rpy, f"{where} <origin>", "rpy", "angle")
        T[:3, 3] = xyz
        T[:3, :3] = rpy_to_matrix(rpy)
    return T


def one_child(el, tag: str, where: str, required: bool):
    els = el.findall(tag)
    if len(els) > 1:
        raise ModelError(f"{where}: more than one <{tag}>")
    if not els:
        if required:
            raise ModelError(f"{where}: missing the <{tag}> element")
        return None
    return els[0]


def read_name(el, where: str) -> str:
    n = el.get("name")
    if n is None or not n.strip():
        raise ModelError(f"{where}: <{el.tag}> has no name")
    return check_name(n, where, "name")
