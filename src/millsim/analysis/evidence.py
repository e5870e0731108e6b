"""Stale evidence: which pages of docs/results were computed by another engine than today's.

Every measured number in docs/results names the engine it was computed with, as the engine hash
(``millsim.provenance_hash()``: 12 hex digits over every source file below the studies layer,
the same hash the case files record as ``engine_hash``), written right after the word "engine"
("measured 2026-11-21, engine 16a5317da64c"), a second one soon after it with "with" or "and"
("engine ef9d37fb6224 and 27 with d72ca7c83c26").

A page may say which scenes its numbers come from, on a line of its own:
``Physics: scenes `bed_impact`, `single_particle```. Its hashes are then judged by the physics it
uses (:mod:`millsim.analysis.physics_files`): a hash is current when the commit it names has the
same content as today's tree in every file those scenes import, so a change to another scene
leaves the page current. A page without that line is judged by the whole hash: any change of the
engine, models or scenes makes it stale. A hash written as "old engine <hash>" (also "older",
"previous") is a number kept for comparison beside today's: listed, never current, and it does
not make the page stale; a page with only such hashes is stale.

``millsim evidence`` lists, per page and section, the hashes that are not current with the files
that changed since, the pages without any engine hash, and how many pages are current.
"""

from __future__ import annotations

import re
from pathlib import Path

# an engine hash: 12 hex digits right after "engine" (or "engine hash"), and a second one named
# soon after it with "with" or "and" ("engine ef9d37fb6224 and 27 with d72ca7c83c26")
_HEX = r"`?([0-9a-f]{12})(?![0-9a-fA-F])"
_ENGINE = re.compile(r"\bengines?\s+(?:hash(?:es)?\s+)?" + _HEX, re.IGNORECASE)
_MORE = re.compile(r"\b(?:with|and)\s+" + _HEX)
_OLD = re.compile(r"\b(?:old|older|previous)\s+$", re.IGNORECASE)
_SCENES = re.compile(r"^Physics:\s*scenes?\s+(.+)$", re.MULTILINE)
REACH = 60
CURRENT, STALE, NONE = "current", "stale", "no engine hash"


def _mentions(text):
    """[(line number, section heading, hash, kept for comparison)] of every engine hash."""
    found, section = [], ""
    lines = text.splitlines()
    for number, line in enumerate(lines, 1):
        if line.startswith("#"):
            section = line.lstrip("#").strip()
        # the end of the line before joined on, so "engine" ending a line still counts
        before = lines[number - 2][-REACH:] + " " if number > 1 else ""
        here = before + line
        direct = list(_ENGINE.finditer(here))
        hits = {m.start(1): (m.group(1), bool(_OLD.search(here[:m.start()]))) for m in direct}
        for m in _MORE.finditer(here):
            near = [d for d in direct if 0 <= m.start() - d.end() <= REACH]
            if near:
                hits[m.start(1)] = (m.group(1), hits[near[-1].start(1)][1])
        found += [(number, section, h, old) for at, (h, old) in sorted(hits.items())
                  if at >= len(before)]
    return found


def engine_hashes(text):
    """[(line number, section heading, hash)] of every engine hash in a page's ``text``."""
    return [(number, section, h) for number, section, h, _ in _mentions(text)]


def page_scenes(text):
    """The scenes a page names on its ``Physics: scenes ...`` line (none: judged by the whole
    hash)."""
    return tuple(name for match in _SCENES.finditer(text)
                 for name in re.findall(r"[a-z][a-z0-9_]*", match.group(1).replace("scenes", "")))


def page_status(text, current, judge=None):
    """(status, [dict(line, section, engine, old, why)] of the hashes that are not current).

    ``judge(hash, scenes)`` -> (current, why) decides a hash that is not ``current``; without
    one, only ``current`` itself is."""
    mentions = _mentions(text)
    if not mentions:
        return NONE, []
    scenes = page_scenes(text)
    listed, fresh = [], 0
    for number, section, h, old in mentions:
        ok, why = (True, "") if h == current else \
            (judge(h, scenes) if judge is not None else (False, "another engine"))
        if old:
            why = "kept for comparison (old engine)"
        elif ok:
            fresh += 1
            continue
        listed.append(dict(line=number, section=section, engine=h, old=old, why=why))
    stale = any(not s["old"] for s in listed) or not fresh
    return (STALE if stale else CURRENT), listed


class Judge:
    """Decides whether a hash that is not today's computed the same physics as today's tree for
    a page's scenes (:mod:`millsim.analysis.physics_files`)."""

    def __init__(self, root=None):
        from . import physics_files

        self.files_module = physics_files
        self.root = physics_files.PACKAGE if root is None else Path(root)
        repo = physics_files.repository(self.root)
        self.history = physics_files.History(repo) if repo is not None else None
        self._files = {}

    def files(self, scenes):
        """The physics files of ``scenes`` (ValueError naming an unknown scene)."""
        if scenes not in self._files:
            self._files[scenes] = self.files_module.scene_files(scenes, self.root)
        return self._files[scenes]

    def __call__(self, engine, scenes):
        if self.history is None:
            return False, "another engine (no git history here to compare its files)"
        commit = self.history.commits().get(engine)
        if commit is None:
            return False, "no commit of this repository's history has this engine hash"
        if not scenes:
            return False, "another engine (the page names no scenes: judged by the whole hash)"
        changed = self.files_module.changed_since(self.history, commit, self.files(scenes),
                                                  self.root)
        if not changed:
            return True, ""
        more = f" and {len(changed) - 3} more" if len(changed) > 3 else ""
        return False, f"since {commit[:10]}: {', '.join(changed[:3])}{more} changed"

    def close(self):
        if self.history is not None:
            self.history.close()


def evidence(folder, current=None, root=None):
    """Every page (``*.md``) of ``folder``: its status against the engine hash ``current``
    (default: today's ``millsim.provenance_hash()``) and the package sources at ``root``
    (default: this one's), and the counts."""
    if current is None:
        import millsim

        current = millsim.provenance_hash()
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder}: not a folder of results pages")
    judge, pages = Judge(root), []
    try:
        for path in sorted(folder.glob("*.md")):
            text = path.read_text()
            try:
                if page_scenes(text):
                    judge.files(page_scenes(text))
                status, listed = page_status(text, current, judge)
            except ValueError as exc:
                raise ValueError(f"{path}: {exc}") from None
            pages.append(dict(page=path.as_posix(), status=status, stale=listed))
    finally:
        judge.close()
    count = {s: sum(p["status"] == s for p in pages) for s in (CURRENT, STALE, NONE)}
    return dict(engine=current, pages=pages, total=len(pages), current=count[CURRENT],
                stale=count[STALE], no_hash=count[NONE])


def headline(result):
    """One line: how many pages are current (the README's and the landing page's count)."""
    return (f"{result['current']} of {result['total']} results pages current (engine "
            f"{result['engine']}); {result['stale']} stale, {result['no_hash']} without an "
            "engine hash")


def lines(result):
    """The report of ``millsim evidence``: the headline, then each page with the hashes that are
    not current (why: the files changed since), and those kept for comparison."""
    out = [f"millsim evidence: {headline(result)}"]
    for page in result["pages"]:
        if page["status"] == CURRENT and not page["stale"]:
            continue
        out.append(f"{page['status'].upper():14s}  {page['page']}")
        for s in page["stale"]:
            out.append(f"{'':14s}    line {s['line']}: engine {s['engine']}"
                       + (f"  ({s['section']})" if s["section"] else "")
                       + (f": {s['why']}" if s["why"] else ""))
    return out
