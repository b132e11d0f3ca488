"""Reading a URDF document safely: bytes to an lxml tree, and URDF's number grammar.

Layer: model loaders (URDF).  A document whose DOCTYPE declares entities or
points at an external DTD is refused before any expansion (XML external
entities, the "billion laughs" bomb).  Pinocchio (whose XML reader does not
guard against them) only ever sees text that passed this check.
"""

from __future__ import annotations

import math
import os
import re

import numpy as np

from .errors import ModelError
from .kinematics import rpy_to_matrix

__all__ = ["MOVABLE", "KNOWN_TYPES", "read_source", "decode", "parse_xml", "where_in", "read_number",
           "read_vector3", "read_origin", "one_child", "read_name"]

MOVABLE = ("revolute", "continuous", "prismatic")
KNOWN_TYPES = MOVABLE + ("fixed", "floating", "planar")

# An XML/URDF number: no nan, inf, hex or Python-only forms (underscores).
NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?\Z")


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
        try:
            with open(path, "rb") as fh:
                return fh.read(), label, path
        except OSError as exc:
            raise ModelError(f"{label}: cannot read {path!r}: {exc.strerror or exc}") from None
    raise ModelError(
        f"URDF source: expected a path or URDF text, got {type(source).__name__}"
    )


def decode(data, label: str) -> str:
    """The document as text (UTF-8 unless a BOM or the XML declaration says otherwise)."""
    if isinstance(data, str):
        text = data
    else:
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
    except (LookupError, UnicodeDecodeError) as exc:
        raise ModelError(f"{label}: cannot decode the text ({codec}): {exc}") from None


DOCTYPE_EXTERNAL = re.compile(r"<!DOCTYPE\s+[^\s\[>]+\s+(?:SYSTEM|PUBLIC)\b")


def refuse_entities(text: str, label: str) -> None:
    """Refuse a DOCTYPE that declares entities or names an external DTD, BEFORE parsing.

    libxml2 expands internal entities in attribute values even with
    ``resolve_entities=False``, so the check cannot wait for the parse.  It is
    conservative: any ``<!ENTITY`` in a document that has a DOCTYPE refuses it
    (URDF files have no use for either).
    """
    if "<!DOCTYPE" not in text:
        return
    if "<!ENTITY" in text:
        raise ModelError(
            f"{label}: refused: its DOCTYPE declares XML entities (a URDF has no use for "
            "them; they are how external-entity and entity-expansion attacks work). "
            "Nothing was expanded; remove the DOCTYPE"
        )
    if DOCTYPE_EXTERNAL.search(text):
        raise ModelError(
            f"{label}: refused: its DOCTYPE references an external DTD, which is not loaded "
            "and could declare entities; remove the DOCTYPE"
        )


XML_DECL = re.compile(r"\s*<\?xml\b[^>]*\?>")


def parse_xml(text: str, label: str):
    from lxml import etree

    refuse_entities(text, label)
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
    # Second line of defence, on what libxml2 actually saw.
    info = root.getroottree().docinfo
    dtd = info.internalDTD
    if (dtd is not None and any(True for _ in dtd.iterentities())) or info.system_url or info.public_id:
        raise ModelError(f"{label}: refused: its DOCTYPE declares XML entities or an external DTD")
    return root


# ---------------------------------------------------------------------------
# Strict element readers
# ---------------------------------------------------------------------------
def where_in(label: str, el, what: str) -> str:
    line = getattr(el, "sourceline", None)
    return f"{label}, line {line}, {what}" if line else f"{label}, {what}"


def read_number(el, attr: str, where: str, default=None) -> float:
    raw = el.get(attr)
    if raw is None:
        if default is None:
            raise ModelError(f"{where}: <{el.tag}> is missing the attribute '{attr}'")
        return default
    s = raw.strip()
    if not NUMBER.match(s):
        raise ModelError(f"{where}: <{el.tag} {attr}=\"{raw}\">: not a finite number")
    v = float(s)
    if not math.isfinite(v):
        raise ModelError(f"{where}: <{el.tag} {attr}=\"{raw}\">: not a finite number")
    return v


def read_vector3(el, attr: str, where: str, default) -> np.ndarray:
    raw = el.get(attr)
    if raw is None:
        return np.array(default, dtype=np.float64)
    parts = raw.split()
    if len(parts) != 3 or not all(NUMBER.match(p) for p in parts):
        raise ModelError(f"{where}: <{el.tag} {attr}=\"{raw}\">: expected 3 finite numbers")
    v = np.array([float(p) for p in parts])
    if not np.all(np.isfinite(v)):
        raise ModelError(f"{where}: <{el.tag} {attr}=\"{raw}\">: expected 3 finite numbers")
    return v


def read_origin(parent_el, where: str) -> np.ndarray:
    """The 4x4 transform of the ``<origin xyz rpy>`` child (identity if absent)."""
    els = parent_el.findall("origin")
    if len(els) > 1:
        raise ModelError(f"{where}: more than one <origin>")
    T = np.eye(4)
    if els:
        o = els[0]
        T[:3, 3] = read_vector3(o, "xyz", where, (0.0, 0.0, 0.0))
        T[:3, :3] = rpy_to_matrix(read_vector3(o, "rpy", where, (0.0, 0.0, 0.0)))
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
    return n
