"""Stale evidence: which pages of docs/results were computed by another engine than today's.

Every measured number in docs/results names the engine it was computed with, as the engine hash
(``millsim.provenance_hash()``: 12 hex digits over every source file below the studies layer,
the same hash the case files record as ``engine_hash``), written right after the word "engine"
("measured 2026-11-21, engine 16a5317da64c"), a second one soon after it with "with" or "and"
("engine ef9d37fb6224 and 27 with d72ca7c83c26").
The hash is one for all physics: any change of the engine, models or scenes makes every older
page stale, whether or not it touched the physics that page uses; re-running the page's command
is what makes it current again.

``millsim evidence`` lists, per page and section, the hashes that differ from today's, the pages
without any engine hash, and how many pages are current.
"""

from __future__ import annotations

import re
from pathlib import Path

# an engine hash: 12 hex digits right after "engine" (or "engine hash"), and a second one named
# soon after it with "with" or "and" ("engine ef9d37fb6224 and 27 with d72ca7c83c26")
_HEX = r"`?([0-9a-f]{12})(?![0-9a-fA-F])"
_ENGINE = re.compile(r"\bengines?\s+(?:hash(?:es)?\s+)?" + _HEX, re.IGNORECASE)
_MORE = re.compile(r"\b(?:with|and)\s+" + _HEX)
REACH = 60
CURRENT, STALE, NONE = "current", "stale", "no engine hash"


def engine_hashes(text):
    """[(line number, section heading, hash)] of every engine hash in a page's ``text``."""
    found, section = [], ""
    lines = text.splitlines()
    for number, line in enumerate(lines, 1):
        if line.startswith("#"):
            section = line.lstrip("#").strip()
        # the end of the line before joined on, so "engine" ending a line still counts
        before = lines[number - 2][-REACH:] + " " if number > 1 else ""
        here = before + line
        direct = [m for m in _ENGINE.finditer(here)]
        hits = {m.start(1): m.group(1) for m in direct}
        for m in _MORE.finditer(here):
            if any(0 <= m.start() - d.end() <= REACH for d in direct):
                hits[m.start(1)] = m.group(1)
        found += [(number, section, h) for at, h in sorted(hits.items()) if at >= len(before)]
    return found


def page_status(text, current):
    """(status, [(line, section, hash)] of the hashes that are not ``current``)."""
    hashes = engine_hashes(text)
    if not hashes:
        return NONE, []
    old = [h for h in hashes if h[2] != current]
    return (STALE if old else CURRENT), old


def evidence(folder, current=None):
    """Every page (``*.md``) of ``folder``: its status against the engine hash ``current``
    (default: today's ``millsim.provenance_hash()``), and the counts."""
    if current is None:
        import millsim

        current = millsim.provenance_hash()
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder}: not a folder of results pages")
    pages = []
    for path in sorted(folder.glob("*.md")):
        status, old = page_status(path.read_text(), current)
        pages.append(dict(page=path.as_posix(), status=status,
                          stale=[dict(line=n, section=s, engine=h) for n, s, h in old]))
    count = {s: sum(p["status"] == s for p in pages) for s in (CURRENT, STALE, NONE)}
    return dict(engine=current, pages=pages, total=len(pages), current=count[CURRENT],
                stale=count[STALE], no_hash=count[NONE])


def headline(result):
    """One line: how many pages are current (the README's and the landing page's count)."""
    return (f"{result['current']} of {result['total']} results pages current (engine "
            f"{result['engine']}); {result['stale']} stale, {result['no_hash']} without an "
            "engine hash")


def lines(result):
    """The report of ``millsim evidence``: the headline, then each page that is not current with
    the sections and hashes that make it so."""
    out = [f"millsim evidence: {headline(result)}"]
    for page in result["pages"]:
        if page["status"] == CURRENT:
            continue
        out.append(f"{page['status'].upper():14s}  {page['page']}")
        for s in page["stale"]:
            out.append(f"{'':14s}    line {s['line']}: engine {s['engine']}"
                       + (f"  ({s['section']})" if s["section"] else ""))
    return out
