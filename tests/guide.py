"""The user's documentation as the tests read it: ``README.md``, then the guide's pages (``docs/guide/``).

The README keeps what manipdyn is, its set-up commands, five lines and a map; the rest moved into the
guide's pages (issue 38 item 15), whose code the tests run as they ran the README's.  The pages are
taken in the order of the guide's table of contents (``docs/guide/index.md``), the order a reader
follows them, so the shell blocks run in one working folder in that order.

* :data:`TEXT`: every page's text, README first, one after another (for the tests that look for a
  sentence, a table row or a figure wherever it now is);
* :func:`blocks`: the fenced blocks of a language, each with its page, line and skip reason;
* :func:`section`: a heading's section, up to the next heading of its level or above.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import NamedTuple

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "guide"
README = ROOT / "README.md"

#: the comment on the line before a fence that tells the tests to skip its block, and why
SKIP = re.compile(r"<!-- tests skip this block: (.+?) -->\n$")


def toc() -> list:
    """The guide's page names in the order of ``docs/guide/index.md``'s toctree."""
    text = (GUIDE / "index.md").read_text(encoding="utf-8")
    body = re.search(r"^```\{toctree\}\n(.*?)^```", text, flags=re.S | re.M)
    assert body, "docs/guide/index.md has its toctree"
    return [line.strip() for line in body.group(1).splitlines() if line.strip() and not line.startswith(":")]


def pages() -> list:
    """README.md, then every guide page in the toctree's order."""
    return [README, *(GUIDE / f"{name}.md" for name in toc())]


def rel(path: Path) -> str:
    return str(path.relative_to(ROOT))


#: every page's text, README first
TEXT = "\n".join(p.read_text(encoding="utf-8") for p in pages())


class Block(NamedTuple):
    page: str          # "docs/guide/arms.md"
    line: int          # the fence's line in that page
    text: str
    skip: str | None   # the reason the tests skip it, or None

    @property
    def where(self) -> str:
        return f"{self.page}:{self.line}"


def blocks(lang: str) -> list:
    """Every ```` ```lang ```` block of the README and the guide, in reading order."""
    out = []
    for path in pages():
        text = path.read_text(encoding="utf-8")
        for m in re.finditer(r"^```" + re.escape(lang) + r"\n(.*?)^```", text, flags=re.S | re.M):
            before = text[:m.start()]
            prev = before[before.rstrip("\n").rfind("\n") + 1:]       # the line before the fence
            skip = SKIP.search(prev)
            out.append(Block(rel(path), before.count("\n") + 1, m.group(1), skip.group(1) if skip else None))
    return out


def section(heading: str, text: str = TEXT) -> str:
    """From ``heading`` (a whole line, e.g. ``"## Conventions in brief"``) to the next heading of
    its level or above (a page's title included)."""
    start = text.index(heading + "\n")
    level = len(heading) - len(heading.lstrip("#"))
    nxt = re.compile(r"^#{1,%d} " % level, flags=re.M).search(text, start + len(heading) + 1)
    # a '# ...' line inside a fenced shell block is a comment, not a heading
    while nxt and text.count("\n```", start, nxt.start()) % 2:
        nxt = re.compile(r"^#{1,%d} " % level, flags=re.M).search(text, nxt.end())
    return text[start:nxt.start() if nxt else None]


def page(name: str) -> str:
    """A guide page's text (``"identification"``)."""
    return (GUIDE / f"{name}.md").read_text(encoding="utf-8")


def row(label: str, text: str = TEXT) -> list:
    """The cells after the label of the one table row that starts ``| label |`` (stripped strings)."""
    rows = [line for line in text.splitlines() if line.startswith(f"| {label} |")]
    assert len(rows) == 1, f"expected one table row '| {label} |' in the README and the guide, found {len(rows)}"
    return [c.strip() for c in rows[0].strip().strip("|").split("|")[1:]]
