"""A measurement CSV read as a table of numbers, streamed and capped.

Layer 2 (formats: logs).

:func:`read_table` reads a delimited text file (comma, semicolon or tab, from
the header line) into a float64 array without ever holding more than one
chunk of text (:data:`CHUNK_BYTES`) as Python objects, so a 100 MB log costs
about its parsed array (8 bytes a number) plus a few MB.  Every limit comes
from :mod:`manipdyn._support.limits`: the file is opened with
:func:`~manipdyn._support.limits.open_regular` (a FIFO or a device such as
``/dev/zero`` is refused at once, never read), at most
:data:`~manipdyn.limits.MAX_DATA_BYTES` are read and no field may exceed
:data:`~manipdyn.limits.MAX_DATA_FIELD_BYTES`.

What is understood: a UTF-8 byte-order mark (Excel's "CSV UTF-8"), CRLF line
ends, blank lines and lines starting with ``#`` (skipped; row numbers stay
those of the file), numbers in double quotes.  Errors are
:class:`~manipdyn.ModelError` naming the file, its row (1-based line number
of the file, the header included) and the column (number and header name):
a ragged row, a field that is not a number, one that overflows float64
(``1e999``) or is not finite (``nan``, ``inf``), text that is not UTF-8.
"""

from __future__ import annotations

import csv
import hashlib
import os

import numpy as np

from ..._support import limits
from ..._support.errors import ModelError

__all__ = ["CHUNK_BYTES", "Table", "read_table"]

#: bytes read (and parsed) at a time
CHUNK_BYTES = 1 << 20


class Table:
    """The numbers of a CSV file: ``header`` (m names), ``data`` (N, m) float64,
    ``rows`` (N,) the file row (1-based line number) of each data row,
    ``sha256`` of the file's bytes, ``where`` the file name for messages."""

    def __init__(self, where: str, header, data, rows, sha256: str):
        self.where, self.header, self.data, self.rows, self.sha256 = where, list(header), data, rows, sha256

    def column(self, name: str) -> int:
        return self.header.index(name)


def _field_error(where, row, col, header, text, problem):
    name = f" ({header[col]!r})" if header and col < len(header) else ""
    return ModelError(f"{where}: row {row}, column {col + 1}{name}: {problem}")


class _Parser:
    """Parses complete lines chunk by chunk (see :func:`read_table`)."""

    def __init__(self, where: str):
        self.where = where
        self.header: list[str] | None = None
        self.delim = ","
        self.line = 0                     # file lines consumed so far
        self.blocks, self.rowblocks = [], []

    def feed(self, raw: bytes, first: bool) -> None:
        if first and raw.startswith((b"\xff\xfe", b"\xfe\xff", b"\x00\x00\xfe\xff")):
            # UTF-32 LE's byte-order mark begins with UTF-16 LE's: test the longer one first
            wide = "UTF-32" if raw.startswith((b"\xff\xfe\x00\x00", b"\x00\x00\xfe\xff")) else "UTF-16"
            raise ModelError(f"{self.where}: row 1: the file is {wide} text; save it as CSV UTF-8 "
                             "(or plain CSV) instead")
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            row = self.line + raw.count(b"\n", 0, exc.start) + 1
            col = raw.rfind(b"\n", 0, exc.start)
            raise ModelError(f"{self.where}: row {row}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at "
                             f"character {exc.start - col} of the row); save the file as CSV UTF-8 "
                             "or plain ASCII") from None
        if first and text.startswith("\ufeff"):
            text = text[1:]
        lines = text.split("\n")
        if text.endswith("\n"):
            lines.pop()
        keep, nums = [], []
        cap = limits.MAX_DATA_FIELD_BYTES
        for k, ln in enumerate(lines):
            number = self.line + k + 1
            s = ln.strip()
            if not s or s.startswith("#"):
                continue
            if len(ln) > cap:
                self._check_fields(ln, number)
            if self.header is None:
                self._set_header(s, number)
                continue
            keep.append(ln.rstrip("\r"))
            nums.append(number)
        self.line += len(lines)
        if keep:
            self.blocks.append(self._parse(keep, nums))
            self.rowblocks.append(np.asarray(nums, dtype=np.int64))

    def _check_fields(self, ln: str, number: int) -> None:
        cap = limits.MAX_DATA_FIELD_BYTES
        delim = self.delim if self.header is not None else ","
        for c, f in enumerate(ln.split(delim)):
            if len(f.encode("utf-8")) > cap:
                raise limits.over_limit(f"{self.where}: row {number}, column {c + 1}", "the field size",
                                        f"over {cap} bytes", "MAX_DATA_FIELD_BYTES")

    def _set_header(self, s: str, number: int) -> None:
        self.delim = "," if "," in s else ";" if ";" in s else "\t" if "\t" in s else ","
        try:
            names = [h.strip() for h in next(csv.reader([s], delimiter=self.delim))]
        except csv.Error as exc:
            raise ModelError(f"{self.where}: row {number} (the header): {exc}") from None
        seen = set()
        for c, h in enumerate(names):
            if not h:
                raise ModelError(f"{self.where}: row {number} (the header), column {c + 1}: empty column name")
            if h in seen:
                raise ModelError(f"{self.where}: row {number} (the header), column {c + 1}: duplicate "
                                 f"column name {h!r}")
            seen.add(h)
        self.header = names

    def _parse(self, lines, nums) -> np.ndarray:
        m = len(self.header)
        under = next((r for r, ln in enumerate(lines) if "_" in ln), None)
        if under is not None:     # float() reads '0_5' as 5.0 (Python's digit grouping); no CSV does
            c = next(c for c, f in enumerate(lines[under].split(self.delim)) if "_" in f)
            f = lines[under].split(self.delim)[c].strip()
            raise _field_error(self.where, nums[under], c, self.header, f,
                               f"{f!r:.40} is not a number (an underscore is no decimal point or digit group)")
        try:
            arr = np.loadtxt(lines, delimiter=self.delim, dtype=np.float64, ndmin=2, comments=None)
            if arr.shape != (len(lines), m):
                raise ValueError("shape")
        except ValueError:
            arr = self._parse_slowly(lines, nums)
        bad = ~np.isfinite(arr)
        if bad.any():
            r, c = (int(x) for x in np.argwhere(bad)[0])
            text = lines[r].split(self.delim)[c].strip().strip('"')
            try:
                overflow = float(text) != float(text) or abs(float(text)) == float("inf")
                word = text.lower().lstrip("+-")
                overflow = overflow and word not in ("inf", "infinity", "nan")
            except ValueError:
                overflow = False
            problem = (f"{text!r:.40} overflows float64 (largest 1.8e308); check the units"
                       if overflow else f"{text!r:.40} is not a finite number")
            raise _field_error(self.where, nums[r], c, self.header, text, problem)
        return arr

    def _parse_slowly(self, lines, nums) -> np.ndarray:
        """The same numbers as ``np.loadtxt``, or an error naming the row and column."""
        m = len(self.header)
        out = np.empty((len(lines), m))
        for r, (ln, number) in enumerate(zip(lines, nums)):
            fields = ln.split(self.delim)
            if len(fields) != m:
                raise ModelError(f"{self.where}: row {number} has {len(fields)} field(s), the header has {m} "
                                 f"({', '.join(self.header)})")
            for c, f in enumerate(fields):
                s = f.strip()
                if len(s) >= 2 and s[0] == s[-1] == '"':
                    s = s[1:-1].strip()
                try:
                    out[r, c] = float(s)
                except ValueError:
                    raise _field_error(self.where, number, c, self.header, s,
                                       f"{s!r:.40} is not a number") from None
        return out


def read_table(path, label: str | None = None) -> Table:
    """Read the CSV file ``path`` (module docstring) into a :class:`Table`.

    ``label`` names the file in messages (default: the path).  Raises
    :class:`~manipdyn.ModelError` for an unreadable, oversized or malformed
    file, naming the row and column.
    """
    where = label or os.fspath(path)
    cap, fcap = limits.MAX_DATA_BYTES, limits.MAX_DATA_FIELD_BYTES
    digest = hashlib.sha256()
    parser = _Parser(where)
    total, pending, first, cr_only = 0, b"", True, False
    try:
        with limits.open_regular(os.fspath(path), f"{where}: cannot read data file") as fh:
            while True:
                chunk = fh.read(CHUNK_BYTES)
                if not chunk:
                    break
                total += len(chunk)
                if total > cap:
                    raise limits.over_limit(where, "the data file size", f"over {cap} bytes", "MAX_DATA_BYTES")
                digest.update(chunk)
                if first and b"\r" in chunk and b"\n" not in chunk:
                    cr_only = True      # classic Mac line endings: read them as lines
                if cr_only:
                    chunk = chunk.replace(b"\r", b"\n")
                buf = pending + chunk
                if first and buf.lstrip(b"\xef\xbb\xbf \t\r\n")[:1] in (b"{", b"["):
                    raise ModelError(f"{where}: starts with {buf.lstrip()[:1].decode()!r}: a JSON file (a base "
                                     "model?), not a CSV log; DATA is the measurements, MODEL the model")
                cut = buf.rfind(b"\n")
                if cut < 0:
                    pending = buf
                else:
                    parser.feed(buf[:cut + 1], first)
                    first, pending = False, buf[cut + 1:]
                if len(pending) > fcap:         # an unfinished line: is its last field too long?
                    start = max(pending.rfind(b","), pending.rfind(b";"), pending.rfind(b"\t")) + 1
                    if len(pending) - start > fcap:
                        col = pending.count(b",") + pending.count(b";") + pending.count(b"\t") + 1
                        raise limits.over_limit(f"{where}: row {parser.line + 1}, column {col}", "the field size",
                                                f"over {fcap} bytes", "MAX_DATA_FIELD_BYTES")
    except OSError as exc:
        raise ModelError(f"{where}: cannot read data file: {exc.strerror or exc}") from None
    if pending:
        parser.feed(pending, first)
    if parser.header is None:
        raise ModelError(f"{where}: no header line; expected a header such as t,q1..qn,tau1..taun")
    m = len(parser.header)
    data = np.concatenate(parser.blocks) if parser.blocks else np.empty((0, m))
    rows = np.concatenate(parser.rowblocks) if parser.rowblocks else np.empty(0, dtype=np.int64)
    return Table(where, parser.header, data, rows, digest.hexdigest())
