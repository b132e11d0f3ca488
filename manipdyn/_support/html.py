"""Self-contained HTML pages: escaping, tables, inline figures, the page skeleton.

Layer 0 (support).  The building blocks of the reports ``identify``, ``validate`` and
``montecarlo`` write with ``--report FILE.html``; each result's page lives with its package
(``identification/results/html.py``, ``control/montecarlo/html.py``) and is assembled from
these.

What a page built here is:

* **one file**: no external resource (no network, no CDN, no ``<script>`` at all); the
  styles are inline and the figures are PNG images inside the page as ``data:`` URIs;
  a ``Content-Security-Policy`` ``<meta>`` forbids the browser to fetch anything else,
  so a page that tried would show it as broken rather than phone home;
* **read without JavaScript**: tables are ``<table>`` (with ``<th scope>`` headers), every
  figure has ``alt`` text and a caption;
* **escaped**: every piece of text is passed through :func:`escape` unless it is
  :class:`Markup` built by these functions, so a model, file or log name such as
  ``<script>alert(1)</script>`` is shown as text, never run;
* **machine-checkable**: a numeric cell carries its full value in ``data-value`` (``repr``
  of the float, ``""`` for none), so a test (or a user's script) reads the numbers back
  exactly while the page shows them to 4 significant digits (:func:`read_tables`).
"""

from __future__ import annotations

import base64
import hashlib
import html as _html
import io
import math
import os
from html.parser import HTMLParser

from .files import atomic_write_text

__all__ = ["Markup", "escape", "number", "table", "figure", "section", "paragraph", "facts", "bullets", "verdict",
           "page", "write_page", "read_tables", "sha256_of", "version", "CSP"]

#: what the page allows the browser to load: nothing but its own inline styles and data: images
CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'"

_STYLE = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,"DejaVu Sans",sans-serif;margin:0 auto;
max-width:1100px;padding:1.2em 1.6em 3em;color:#1d1f21;line-height:1.45;background:#fff}
h1{font-size:1.55em;margin:.2em 0 .1em}h2{font-size:1.2em;margin:1.6em 0 .5em;border-bottom:1px solid #ccd;
padding-bottom:.15em}h3{font-size:1.02em;margin:1.1em 0 .4em}
p.sub{color:#555;margin:.1em 0 1em}
.verdict{font-size:1.08em;padding:.7em 1em;border-left:5px solid #2a7;background:#eef8f1;margin:1em 0}
.verdict.warn{border-color:#c60;background:#fdf3e6}.verdict.bad{border-color:#c22;background:#fbeaea}
table{border-collapse:collapse;margin:.4em 0 1em;font-size:.92em}
caption{text-align:left;font-weight:600;padding:.3em 0;caption-side:top}
th,td{border:1px solid #d4d7dd;padding:.25em .6em;vertical-align:top}
th{background:#f1f3f6;text-align:left}th[scope=row]{white-space:nowrap}td.num{text-align:right;font-variant-numeric:tabular-nums;
font-family:ui-monospace,"DejaVu Sans Mono",monospace;font-size:.95em}
tr.flag td,tr.flag th{background:#fde7e4}tr.flag th{border-left:4px solid #c22}
td.best{font-weight:700;background:#e6f4ea}
span.flag{color:#b11;font-weight:700}
dl.facts{display:grid;grid-template-columns:max-content 1fr;gap:.2em 1em;margin:.5em 0 1em}
dl.facts dt{font-weight:600;color:#444}dl.facts dd{margin:0;overflow-wrap:anywhere}
code{font-family:ui-monospace,"DejaVu Sans Mono",monospace;font-size:.92em;background:#f4f4f6;padding:0 .2em}
figure{margin:1em 0}figure img{max-width:100%;height:auto;border:1px solid #e2e4e8}
figcaption{color:#444;font-size:.9em;margin-top:.3em}
ul.notes li{margin:.15em 0}footer{color:#777;font-size:.85em;margin-top:3em}
"""


class Markup(str):
    """Text that is already HTML (built by this module): :func:`escape` leaves it as it is."""


def escape(text) -> Markup:
    """``text`` as HTML text: ``& < > " '`` escaped; :class:`Markup` unchanged; None as ``""``."""
    if isinstance(text, Markup):
        return text
    from .text import visible        # control and invisible characters shown escaped, never raw

    return Markup(_html.escape("" if text is None else visible(text, keep="\n\t"), quote=True))


def number(x, digits: int = 4, unit: str = "") -> str:
    """``x`` to ``digits`` significant digits (``-`` for None, ``NaN``/``inf`` spelt out)."""
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return f"{x}{' ' + unit if unit else ''}"
    x = float(x)
    if math.isnan(x):
        return "NaN"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return f"{x:.{digits}g}{' ' + unit if unit else ''}"


def _cell(value, tag: str, cls: str = "") -> str:
    """One cell: a number (right-aligned, its exact value in ``data-value``), Markup, or text."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) or value is None:
        exact = "" if value is None else repr(float(value) if isinstance(value, float) else int(value))
        classes = " ".join(c for c in ("num", cls) if c)
        return f'<{tag} class="{classes}" data-value="{escape(exact)}">{escape(number(value))}</{tag}>'
    attr = f' class="{cls}"' if cls else ""
    if isinstance(value, bool):
        value = "yes" if value else "no"
    return f"<{tag}{attr}>{escape(value)}</{tag}>"


def table(headers, rows, caption: str | None = None, flagged=(), best=None, name: str | None = None,
          row_headers: bool = True) -> Markup:
    """A ``<table>``: ``headers`` (column titles), ``rows`` (lists of cells: numbers, text or
    :class:`Markup`), the row indices in ``flagged`` highlighted (``class="flag"``), ``best`` a
    set of ``(row, column)`` cells marked best; ``name`` becomes ``data-table`` (how
    :func:`read_tables` finds it).  With ``row_headers`` the first cell of a row is its ``<th>``."""
    flagged = set(flagged)
    best = set(best or ())
    out = [f'<table data-table="{escape(name)}">' if name else "<table>"]
    if caption:
        out.append(f"<caption>{escape(caption)}</caption>")
    out.append("<thead><tr>" + "".join(f'<th scope="col">{escape(h)}</th>' for h in headers) + "</tr></thead><tbody>")
    for i, row in enumerate(rows):
        cells = []
        for k, v in enumerate(row):
            tag = "th" if row_headers and k == 0 else "td"
            cls = "best" if (i, k) in best else ""
            c = _cell(v, tag, cls)
            cells.append(c.replace("<th", '<th scope="row"', 1) if tag == "th" else c)
        out.append('<tr class="flag">' if i in flagged else "<tr>")
        out.append("".join(cells) + "</tr>")
    out.append("</tbody></table>")
    return Markup("".join(out))


def figure(fig, alt: str, caption: str | None = None, dpi: int = 96) -> Markup:
    """A matplotlib figure as an inline PNG (``data:`` URI) with ``alt`` text and a caption;
    the figure is closed."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    try:
        import matplotlib.pyplot as plt

        plt.close(fig)
    except ImportError:      # pragma: no cover - a figure exists, so matplotlib does
        pass
    data = base64.b64encode(buf.getvalue()).decode("ascii")
    cap = f"<figcaption>{escape(caption)}</figcaption>" if caption else ""
    return Markup(f'<figure><img src="data:image/png;base64,{data}" alt="{escape(alt)}">{cap}</figure>')


def paragraph(text, cls: str | None = None) -> Markup:
    """``<p>`` around escaped ``text``."""
    return Markup(f'<p class="{escape(cls)}">{escape(text)}</p>' if cls else f"<p>{escape(text)}</p>")


def facts(pairs) -> Markup:
    """A definition list of ``(term, value)`` pairs (what was done: command, data, options...)."""
    items = "".join(f"<dt>{escape(k)}</dt><dd>{escape(v)}</dd>" for k, v in pairs)
    return Markup(f'<dl class="facts">{items}</dl>')


def bullets(items, cls: str = "notes") -> Markup:
    """``<ul>`` of escaped items."""
    return Markup(f'<ul class="{escape(cls)}">' + "".join(f"<li>{escape(x)}</li>" for x in items) + "</ul>")


def verdict(text, level: str = "ok") -> Markup:
    """The verdict in a sentence, boxed: ``level`` ``"ok"`` (green), ``"warn"`` (orange) or ``"bad"`` (red)."""
    cls = {"ok": "verdict", "warn": "verdict warn", "bad": "verdict bad"}[level]
    return Markup(f'<p class="{cls}" data-verdict="{escape(level)}">{escape(text)}</p>')


def section(title: str, *parts, level: int = 2) -> Markup:
    """``<section>`` with a heading and the parts (Markup, or text as paragraphs)."""
    body = "".join(p if isinstance(p, Markup) else paragraph(p) for p in parts if p)
    return Markup(f"<section><h{level}>{escape(title)}</h{level}>{body}</section>")


def page(title: str, subtitle: str, parts, generator: str = "manipdyn") -> str:
    """The whole document: ``<!DOCTYPE html>``, the CSP, inline styles, a title, the parts."""
    body = "".join(p if isinstance(p, Markup) else paragraph(p) for p in parts if p)
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f'<meta http-equiv="Content-Security-Policy" content="{CSP}">'
            '<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<meta name=\"generator\" content=\"{escape(generator)}\">"
            f"<title>{escape(title)}</title><style>{_STYLE}</style></head><body>"
            f"<header><h1>{escape(title)}</h1><p class=\"sub\">{escape(subtitle)}</p></header>"
            f"<main>{body}</main><footer>Written by {escape(generator)}. One self-contained file: "
            "no scripts, nothing fetched; the tables carry each number's full value in data-value."
            "</footer></body></html>\n")


def write_page(path, text: str) -> None:
    """Write the page to ``path`` atomically (:func:`.files.atomic_write_text`, UTF-8)."""
    atomic_write_text(os.fspath(path), text)


def version() -> str:
    """manipdyn's installed version (the distribution's metadata), or ``"unknown"``."""
    try:
        from importlib.metadata import version as _v

        return _v("manipdyn")
    except Exception:        # not installed as a distribution (a bare source tree)
        return "unknown"


def sha256_of(path) -> str | None:
    """Hex sha256 of a regular file's bytes, or None when ``path`` is not one (a folder, a bag)."""
    try:
        if not os.path.isfile(path):
            return None
        with open(path, "rb") as fh:
            return hashlib.file_digest(fh, "sha256").hexdigest()
    except (OSError, TypeError, ValueError):
        return None


class _Tables(HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.tables, self._t, self._row, self._cell = {}, None, None, None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "table":
            self._t = {"name": a.get("data-table"), "rows": []}
        elif tag == "tr" and self._t is not None:
            self._row = []
        elif tag in ("td", "th") and self._row is not None:
            self._cell = {"text": "", "value": a.get("data-value"), "header": tag == "th",
                          "class": a.get("class") or ""}

    def handle_data(self, data):
        if self._cell is not None:
            self._cell["text"] += data

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            c = self._cell
            v = c["value"]
            self._row.append(c["text"].strip() if v is None else (None if v == "" else float(v)))
            self._cell = None
        elif tag == "tr" and self._row is not None:
            self._t["rows"].append(self._row)
            self._row = None
        elif tag == "table" and self._t is not None:
            key = self._t["name"] or f"table{len(self.tables) + 1}"
            self.tables[key] = self._t["rows"]
            self._t = None


def read_tables(text: str) -> dict:
    """The tables of a page: ``{data-table name: [row, ...]}``, the header row first; a numeric
    cell read back as its exact float (None for none), any other cell as its text."""
    p = _Tables()
    p.feed(text)
    p.close()
    return p.tables
