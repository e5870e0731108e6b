"""Which source files decide a scene's numbers, and which engine commit a recorded hash names.

``millsim.provenance_hash()`` is one hash over every physics source (the layers below the
studies): right for re-running cached cases and keying the kernel cache, too coarse for asking
whether a published number is still what today's code computes. A change to the 3D mill's scene
cannot move a number of the 2D mill. Here a page's physics is the set of files its scene imports,
followed statically (every ``import`` and ``from ... import`` in the module, at any depth, so
imports inside functions count too) within the physics sources; an engine hash recorded on a page
is mapped back to the commits whose sources hash to it, and the page is current when none of its
scene's files differ between that commit and today's tree.

Static imports are what count: a scene imported by name at run time (``scenes.load_all``) only
registers itself, and tests/test_evidence.py checks that importing a scene pulls in no physics
module outside its set.
"""

from __future__ import annotations

import ast
import hashlib
import json
import os
import subprocess
from functools import lru_cache
from pathlib import Path, PurePosixPath

import millsim

PACKAGE = Path(millsim.__file__).parent
PREFIX = "src/millsim"  # where the package lies in the repository


def physics_paths(root=PACKAGE):
    """Every physics source below ``root`` in the order ``millsim.provenance_hash()`` reads them:
    paths relative to ``root`` (posix)."""
    root = Path(root)
    return millsim.physics_order(q.relative_to(root).as_posix() for q in root.rglob("*.py"))


tree_hash = millsim.source_digest  # the engine hash of {relative path: bytes}


def _module_file(module, root):
    parts = module.split(".")[1:]
    base = Path(root).joinpath(*parts)
    for candidate in (base / "__init__.py", base.with_suffix(".py")):
        if parts and candidate.is_file():
            return candidate
    return None


def _imports(path, root):
    """Names of the millsim modules ``path`` imports (and, for ``from m import n``, ``m.n``, which
    is a module when ``n`` is one); read once per content of the file."""
    stat = path.stat()
    return _parsed_imports(path, Path(root), stat.st_mtime_ns, stat.st_size)


@lru_cache(maxsize=4096)
def _parsed_imports(path, root, mtime_ns, size):
    return _import_names(path.read_text(), path.relative_to(root).as_posix())


def _import_names(text, rel):
    """The millsim modules imported by the source ``text`` of the package file ``rel`` (posix,
    relative to the package)."""
    parts = ["millsim", *PurePosixPath(rel).with_suffix("").parts]
    name = parts[:-1] if parts[-1] == "__init__" else parts
    package = name if rel.endswith("__init__.py") else name[:-1]
    found = set()
    for node in ast.walk(ast.parse(text, rel)):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            found |= {module} | {f"{module}.{a.name}" for a in node.names}
    return {m for m in found if m.split(".")[0] == "millsim"}


def has_scene(scene, root=PACKAGE):
    """Whether ``root`` has the scene module ``millsim.scenes.<scene>``."""
    return _module_file(f"millsim.scenes.{scene}", root) is not None


def _follow(scenes, module_file, imports):
    """The files that the scene modules import (themselves included), followed statically:
    ``module_file(module)`` -> its file or None, ``imports(file)`` -> the modules it imports."""
    todo = [f"millsim.scenes.{scene}" for scene in scenes]
    for module in todo:
        if module_file(module) is None:
            raise ValueError(f"scene {module.rpartition('.')[2]!r}: no module {module}")
    seen = set()
    while todo:
        module = todo.pop()
        path = module_file(module)
        if path is None or path in seen:
            continue
        seen.add(path)
        parts = module.split(".")
        todo += [".".join(parts[:i]) for i in range(2, len(parts))]
        todo += sorted(imports(path))
    return seen


def scene_files(scenes, root=PACKAGE):
    """The physics sources (paths relative to ``root``) that the scene modules ``scenes`` import,
    themselves and their packages' ``__init__`` included."""
    physics = set(physics_paths(root))
    seen = _follow(scenes, lambda m: _module_file(m, root), lambda p: _imports(p, root))
    return sorted(p for p in (s.relative_to(root).as_posix() for s in seen) if p in physics)


def scene_files_at(history, commit, scenes):
    """:func:`scene_files` of the package as ``commit`` has it (read from git's objects)."""
    files = history.tree(commit)
    physics = set(history.physics_order(commit))

    def module_file(module):
        base = "/".join(module.split(".")[1:])
        return next((c for c in (f"{base}/__init__.py", f"{base}.py") if base and c in files),
                    None)

    def imports(path):
        return _import_names(history.blob(files[path]).decode(), path)

    return sorted(p for p in _follow(scenes, module_file, imports) if p in physics)


def blob_id(data):
    """git's object id of a file with content ``data`` (what ``git hash-object`` prints)."""
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


class History:
    """The engine hashes of a repository's commits, read from git's objects (no checkout)."""

    def __init__(self, repo):
        self.repo = Path(repo)
        self._blobs = {}
        self._trees = {}
        self._cat = None
        self._commits = None

    def _git(self, *args):
        return subprocess.run(["git", "-C", str(self.repo), *args], capture_output=True,
                              text=True, check=True).stdout

    def tree(self, commit):
        """{path relative to the package: blob id} of the package at ``commit``."""
        if commit not in self._trees:
            files = {}
            for line in self._git("ls-tree", "-r", commit, f"{PREFIX}/").splitlines():
                meta, path = line.split("\t", 1)
                files[PurePosixPath(path).relative_to(PREFIX).as_posix()] = meta.split()[2]
            self._trees[commit] = files
        return self._trees[commit]

    def blob(self, oid):
        if oid not in self._blobs:
            if self._cat is None:
                self._cat = subprocess.Popen(["git", "-C", str(self.repo), "cat-file", "--batch"],
                                             stdin=subprocess.PIPE, stdout=subprocess.PIPE)
            self._cat.stdin.write(oid.encode() + b"\n")
            self._cat.stdin.flush()
            size = int(self._cat.stdout.readline().split()[2])
            self._blobs[oid] = self._cat.stdout.read(size)
            self._cat.stdout.read(1)
        return self._blobs[oid]

    def physics_order(self, commit):
        """The physics sources of ``commit`` in ``millsim.provenance_hash()``'s order (its own
        ``PHYSICS_SOURCES``)."""
        files = self.tree(commit)
        parts = _parts(self.blob(files["__init__.py"])) if "__init__.py" in files else None
        return millsim.physics_order(files, parts or millsim.PHYSICS_SOURCES)

    def commit_hash(self, commit):
        """The engine hash ``commit`` recorded: its ``PHYSICS_SOURCES`` hashed as
        ``millsim.provenance_hash()`` does."""
        files = self.tree(commit)
        order = self.physics_order(commit)
        return tree_hash({path: self.blob(files[path]) for path in order})

    def commits(self):
        """{engine hash: the newest commit with it} over the history of HEAD.

        Only the commits that touched the package are read (any other has the tree of one of
        them), and a commit's hash never changes, so each is computed once per machine and kept
        in ``$XDG_CACHE_HOME/millsim/engine-commits.json``."""
        if self._commits is not None:
            return self._commits
        cache = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "millsim" \
            / "engine-commits.json"
        try:
            known = json.loads(cache.read_text())
        except (OSError, ValueError):
            known = {}
        found, new = {}, {}
        for commit in self._git("rev-list", "HEAD", "--", PREFIX).split():
            engine = known.get(commit) or new.setdefault(commit, self.commit_hash(commit))
            found.setdefault(engine, commit)
        if new:
            try:  # a cache that cannot be written only costs time
                cache.parent.mkdir(parents=True, exist_ok=True)
                tmp = cache.with_suffix(f".{os.getpid()}.tmp")
                tmp.write_text(json.dumps({**known, **new}))
                tmp.replace(cache)
            except OSError:
                pass
        self._commits = found
        return found

    def close(self):
        if self._cat is not None:
            self._cat.stdin.close()
            self._cat.wait()
            self._cat = None


def _parts(init):
    """``PHYSICS_SOURCES`` of a commit, read from its ``millsim/__init__.py`` (a literal tuple in
    older commits, the layers below the studies in today's); None where neither is found."""
    values = {}
    for node in ast.parse(init).body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1 and \
                isinstance(node.targets[0], ast.Name):
            try:
                values[node.targets[0].id] = ast.literal_eval(node.value)
            except ValueError:
                pass
    if isinstance(values.get("PHYSICS_SOURCES"), tuple):
        return values["PHYSICS_SOURCES"]
    if "LAYERS" in values:
        return tuple(part for _, parts in values["LAYERS"][:-1] for part in parts)
    return None


def repository(root=PACKAGE):
    """The git repository holding the package at ``root``, or None (an installed copy)."""
    repo = Path(root).parent.parent
    return repo if (repo / ".git").exists() and (repo / PREFIX).resolve() == Path(root).resolve() \
        else None


def changed_since(history, commit, paths, root=PACKAGE):
    """Of ``paths`` (relative to the package), those whose content today differs from
    ``commit``'s (absent on either side counts as differing)."""
    then = history.tree(commit)
    changed = []
    for path in paths:
        here = Path(root) / path
        now = blob_id(here.read_bytes()) if here.is_file() else None
        if then.get(path) != now:
            changed.append(path)
    return changed


def changed_between(history, a, b, paths):
    """Of ``paths`` (relative to the package), those whose content differs between the commits
    ``a`` and ``b`` (absent on one side counts as differing)."""
    first, second = history.tree(a), history.tree(b)
    return [path for path in paths if first.get(path) != second.get(path)]
