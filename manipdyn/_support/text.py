"""Text shown to a person: control and invisible characters escaped, in one place.

Layer 0 (support).  A file name, a model name or a record's ``source`` may hold ESC (a terminal
escape sequence), C1 controls, NUL, a bidirectional override (U+202E) or another invisible format
character.  Every line manipdyn prints (the CLI's stdout and its one-line errors) and every HTML page
it writes pass their text through :func:`visible`, which shows such characters escaped (``\\x1b``,
``\\u202e``) and never raw.
"""

from __future__ import annotations

import sys
import unicodedata

__all__ = ["visible", "EscapingWriter"]

#: the Unicode categories shown escaped: controls, format characters (bidi overrides, zero-width
#: joiners), line and paragraph separators, lone surrogates
_CATEGORIES = ("Cc", "Cf", "Zl", "Zp", "Cs")
_NAMED = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}


def _escaped(ch: str) -> str:
    o = ord(ch)
    return _NAMED.get(ch) or (f"\\x{o:02x}" if o < 0x100 else f"\\u{o:04x}" if o <= 0xFFFF else f"\\U{o:08x}")


def visible(text, keep: str = "") -> str:
    """``text`` with every control or invisible character but those in ``keep`` (e.g. ``"\\n"`` for
    several lines) shown escaped."""
    s = str(text)
    if s.isprintable():           # the common case, fast: no control or format character at all
        return s
    return "".join(ch if ch in keep or unicodedata.category(ch) not in _CATEGORIES else _escaped(ch) for ch in s)


class EscapingWriter:
    """A text stream that writes :func:`visible` text (lines and tabs kept) to ``stream``: what the CLI
    puts in place of ``sys.stdout`` while a command runs."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text) -> int:
        stream = self._stream
        if getattr(stream, "closed", False):   # left in place over a stream since closed (a test's capture):
            stream = sys.__stdout__            # the process's own stdout, not a ValueError in the caller
        stream.write(visible(text, keep="\n\t"))
        return len(text)

    def __getattr__(self, name):          # flush, isatty, encoding, fileno, ...: the stream's own
        return getattr(self._stream, name)
