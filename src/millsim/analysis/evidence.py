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

A change of the engine that leaves a scene's trajectories bit-identical (bookkeeping, a
restructuring) is written in the registry of identity checks, ``engine_identity.yaml`` beside the
pages (:data:`REGISTRY`): an entry (old O, new N) names the scenes whose case files
``tools/compare_cases.py`` found identical between the engines O and N (``identical``) and those
where some variables moved (``differs``). A hash H on a page naming scenes S that fails the test
above is still current when an entry has every scene of S in ``identical``, H's commit has the
same content as O's in S's physics files (today's set and O's), and N is current for S (by the
test above, or again through an entry: chains are followed, each entry once). The page lists such
a hash with the entry it went through. A page naming no scenes never uses the registry.

``millsim evidence`` lists, per page and section, the hashes that are not current with the files
that changed since, the hashes current through an identity check, the pages without any engine
hash, the registry's entries that do not apply (no commit has their O or N), and how many pages
are current.
"""

from __future__ import annotations

import datetime
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
REGISTRY = "engine_identity.yaml"  # the registry of identity checks, in the pages' folder
_KEYS = ("old", "new", "date", "command", "identical", "differs", "why")


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
    """(status, [dict(line, section, engine, old, current, why)] of the hashes that are not
    current, kept for comparison, or current with a reason (through an identity check)).

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
            ok, why = False, "kept for comparison (old engine)"
        elif ok:
            fresh += 1
            if not why:
                continue
        listed.append(dict(line=number, section=section, engine=h, old=old, current=ok, why=why))
    stale = any(not (s["old"] or s["current"]) for s in listed) or not fresh
    return (STALE if stale else CURRENT), listed


def _refuse(path, number, entry, what):
    pair = f" ({entry.get('old')} -> {entry.get('new')})" \
        if isinstance(entry, dict) and "old" in entry and "new" in entry else ""
    raise ValueError(f"{path}: entry {number}{pair}: {what}")


def read_registry(path, root=None):
    """The entries of the registry of identity checks at ``path`` (a YAML list; none where the
    file is absent), checked: every key of :data:`_KEYS` (``differs`` may be left out when
    every scene run was identical), hashes of 12 hex digits, scenes of the package at ``root``
    (default: this one), none both identical and differing. ValueError in one line naming the
    file and the entry otherwise."""
    import yaml

    from . import physics_files

    root = physics_files.PACKAGE if root is None else Path(root)
    path = Path(path)
    if not path.is_file():
        return []
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"{path}: not YAML ({' '.join(str(exc).split())})") from None
    if data is None:
        return []
    if not isinstance(data, list):
        raise ValueError(f"{path}: expected a list of identity checks, got {type(data).__name__}")
    entries = []
    for number, entry in enumerate(data, 1):
        if not isinstance(entry, dict):
            _refuse(path, number, entry, f"expected a mapping with keys {', '.join(_KEYS)}")
        missing = [k for k in _KEYS if k not in entry and k != "differs"]
        unknown = sorted(str(k) for k in entry if k not in _KEYS)
        if missing or unknown:
            _refuse(path, number, entry, "; ".join(
                ([f"missing key {', '.join(map(repr, missing))}"] if missing else [])
                + ([f"unknown key {', '.join(map(repr, unknown))}"] if unknown else [])))
        for key in ("old", "new"):
            # YAML reads a hash of digits only as a number: it must be quoted
            if not (isinstance(entry[key], str) and re.fullmatch(r"[0-9a-f]{12}", entry[key])):
                _refuse(path, number, entry, f"{key}: {entry[key]!r} is not an engine hash (12 "
                        "hex digits, quoted when all are digits)")
        date = entry["date"]
        if isinstance(date, str):
            try:
                date = datetime.date.fromisoformat(date)
            except ValueError:
                pass
        if not isinstance(date, datetime.date):
            _refuse(path, number, entry, f"date: {date!r} is not a date (YYYY-MM-DD)")
        for key in ("command", "why"):
            if not (isinstance(entry[key], str) and entry[key].strip()):
                _refuse(path, number, entry, f"{key}: expected a non-empty text")
        identical, differs = entry["identical"], entry.get("differs") or {}
        if not (isinstance(identical, list) and identical
                and all(isinstance(x, str) for x in identical)):
            _refuse(path, number, entry, "identical: expected a list of scene names")
        if not (isinstance(differs, dict) and all(
                isinstance(v, list) and v and all(isinstance(x, str) for x in v)
                for v in differs.values())):
            _refuse(path, number, entry, "differs: expected {scene: [variables that moved]}")
        for scene in [*identical, *differs]:
            if not (isinstance(scene, str) and physics_files.has_scene(scene, root)):
                _refuse(path, number, entry,
                        f"scene {scene!r}: no module millsim.scenes.{scene}")
        both = sorted(set(identical) & set(differs))
        if both:
            _refuse(path, number, entry, f"scene {both[0]!r} both identical and differing")
        entries.append(dict(old=entry["old"], new=entry["new"], date=date.isoformat(),
                            identical=tuple(identical), differs=dict(differs),
                            command=entry["command"], why=entry["why"]))
    return entries


class Judge:
    """Decides whether a hash that is not today's computed the same physics as today's tree for
    a page's scenes (:mod:`millsim.analysis.physics_files`), directly or through the registry's
    identity checks (``registry``: the entries of :func:`read_registry`; ``current``: today's
    engine hash, current whether committed or not)."""

    def __init__(self, root=None, registry=(), current=None):
        from . import physics_files

        self.files_module = physics_files
        self.root = physics_files.PACKAGE if root is None else Path(root)
        repo = physics_files.repository(self.root)
        self.history = physics_files.History(repo) if repo is not None else None
        self.registry, self.current = list(registry), current
        self._files = {}
        self._files_at = {}

    def files(self, scenes):
        """The physics files of ``scenes`` (ValueError naming an unknown scene)."""
        if scenes not in self._files:
            self._files[scenes] = self.files_module.scene_files(scenes, self.root)
        return self._files[scenes]

    def _same_as_today(self, engine, scenes):
        if engine == self.current:
            return True
        commit = self.history.commits().get(engine)
        return commit is not None and not self.files_module.changed_since(
            self.history, commit, self.files(scenes), self.root)

    def _old_files(self, commit, scenes):
        """Today's physics files of ``scenes`` and those ``commit`` had (a file only the old
        scene imported counts too); None where the scene is not in ``commit``."""
        key = (commit, scenes)
        if key not in self._files_at:
            try:
                then = self.files_module.scene_files_at(self.history, commit, scenes)
            except ValueError:
                then = None
            self._files_at[key] = None if then is None else sorted({*self.files(scenes), *then})
        return self._files_at[key]

    def through(self, engine, scenes, used=()):
        """The chain of registry entries through which ``engine`` is current for ``scenes``
        (empty where there is none); each entry is used once on a chain."""
        commits = self.history.commits()
        commit = commits.get(engine)
        if commit is None or not scenes:
            return []
        for entry in self.registry:
            old, new = entry["old"], entry["new"]
            if (old, new) in used or not set(scenes) <= set(entry["identical"]) \
                    or old not in commits:
                continue
            paths = self._old_files(commits[old], scenes)
            if paths is None or self.files_module.changed_between(
                    self.history, commit, commits[old], paths):
                continue
            if self._same_as_today(new, scenes):
                return [entry]
            rest = self.through(new, scenes, (*used, (old, new)))
            if rest:
                return [entry, *rest]
        return []

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
        chain = self.through(engine, scenes)
        if chain:
            checks = ", ".join(f"{e['date']} ({e['old']} -> {e['new']})" for e in chain)
            return True, (f"current through the identity check{'s' if len(chain) > 1 else ''} "
                          f"of {checks}")
        more = f" and {len(changed) - 3} more" if len(changed) > 3 else ""
        return False, f"since {commit[:10]}: {', '.join(changed[:3])}{more} changed"

    def unapplied(self):
        """A line for each registry entry that cannot apply: no commit has its O or N (N may be
        today's uncommitted engine)."""
        if self.history is None or not self.registry:
            return []
        commits, out = self.history.commits(), []
        for e in self.registry:
            lost = [h for h in (e["old"], e["new"]) if h not in commits and h != self.current]
            if lost:
                out.append(f"identity check of {e['date']} ({e['old']} -> {e['new']}) does not "
                           f"apply: no commit of this repository's history has engine "
                           f"{' or '.join(lost)}")
        return out

    def close(self):
        if self.history is not None:
            self.history.close()


def evidence(folder, current=None, root=None):
    """Every page (``*.md``) of ``folder``: its status against the engine hash ``current``
    (default: today's ``millsim.provenance_hash()``) and the package sources at ``root``
    (default: this one's), through the identity checks of ``folder``'s :data:`REGISTRY` where
    there is one, and the counts."""
    if current is None:
        import millsim

        current = millsim.provenance_hash()
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder}: not a folder of results pages")
    registry = read_registry(folder / REGISTRY, root)
    judge, pages = Judge(root, registry, current), []
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
        notes = [f"{(folder / REGISTRY).as_posix()}: {line}" for line in judge.unapplied()]
    finally:
        judge.close()
    count = {s: sum(p["status"] == s for p in pages) for s in (CURRENT, STALE, NONE)}
    return dict(engine=current, pages=pages, total=len(pages), current=count[CURRENT],
                stale=count[STALE], no_hash=count[NONE], registry_notes=notes)


def headline(result):
    """One line: how many pages are current (the README's and the landing page's count)."""
    return (f"{result['current']} of {result['total']} results pages current (engine "
            f"{result['engine']}); {result['stale']} stale, {result['no_hash']} without an "
            "engine hash")


def lines(result):
    """The report of ``millsim evidence``: the headline, the registry's entries that do not
    apply, then each page with the hashes that are not current (why: the files changed since),
    those current through an identity check, and those kept for comparison."""
    out = [f"millsim evidence: {headline(result)}", *result.get("registry_notes", [])]
    for page in result["pages"]:
        if page["status"] == CURRENT and not page["stale"]:
            continue
        out.append(f"{page['status'].upper():14s}  {page['page']}")
        for s in page["stale"]:
            out.append(f"{'':14s}    line {s['line']}: engine {s['engine']}"
                       + (f"  ({s['section']})" if s["section"] else "")
                       + (f": {s['why']}" if s["why"] else ""))
    return out
