"""TOML values as text: the one string escaper every TOML file manipdyn writes goes through.

Layer 2 (formats).  Model files (:mod:`.modelfile`, :mod:`.modelfile_urdf`) and their ``[trust]``
table (:mod:`.trust`) write their strings, keys and numbers with these, so a value that cannot be
written is refused the same way, naming it, whichever part of the file holds it.
"""

from __future__ import annotations

import re

from .._support.errors import ModelError

__all__ = ["toml_str", "toml_key", "toml_num", "toml_list", "read_toml_text"]

def read_toml_text(text: str, where: str, what: str = "file") -> dict:
    """The TOML document ``text`` (a leading byte-order mark, which some editors write, skipped), or a
    ModelError naming ``where``: not TOML, arrays or tables nested too deeply, or an integer of more
    digits than Python converts (4300), which tomllib raises as a bare ValueError."""
    import tomllib

    if text.startswith("\ufeff"):
        text = text[1:]
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(f"{where}: not valid TOML: {exc}") from None
    except RecursionError:
        raise ModelError(f"{where}: not a {what}: arrays or tables nested too deeply") from None
    except ValueError as exc:       # "Exceeds the limit (4300 digits) for integer string conversion"
        digits = re.search(r"has (\d+) digits", str(exc))
        raise ModelError(f"{where}: not a {what}: an integer of {digits.group(1) if digits else 'too many'} digits "
                         "(no quantity needs more than a few; Python reads at most 4300)") from None


_TOML_ESCAPES = {"\\": "\\\\", '"': '\\"', "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def toml_str(s: str, where: str = "text") -> str:
    """A TOML basic string holding ``s`` exactly: every control character (U+0000 to U+001F,
    U+007F) escaped, so that the file reads back; a ModelError naming ``where`` for a value
    that is not a string or holds a lone surrogate (not Unicode text: no file can hold it)."""
    if not isinstance(s, str):
        raise ModelError(f"save: {where} must be a string, got {type(s).__name__} {s!r:.60}")
    out = []
    for k, ch in enumerate(s):
        o = ord(ch)
        if ch in _TOML_ESCAPES:
            out.append(_TOML_ESCAPES[ch])
        elif o < 0x20 or o == 0x7F:
            out.append(f"\\u{o:04X}")
        elif 0xD800 <= o <= 0xDFFF:
            raise ModelError(f"save: {where} holds the lone surrogate U+{o:04X} at index {k} "
                             f"({s[max(0, k - 20):k + 20]!r}), which is not Unicode text: no file can hold it")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def toml_key(k: str, where: str = "a key") -> str:
    """A TOML key: bare when it can be, quoted otherwise (:func:`toml_str`, errors naming ``where``)."""
    return k if isinstance(k, str) and re.fullmatch(r"[A-Za-z0-9_-]+", k) else toml_str(k, where)


def toml_num(x: float) -> str:
    """A float written exactly (``repr`` round-trips)."""
    return repr(float(x))


def toml_list(xs) -> str:
    """A TOML array of floats written exactly."""
    return "[" + ", ".join(toml_num(x) for x in xs) + "]"
