"""`millsim evidence`: the results pages computed with another engine than today's (issue 48)."""

import json
import os
import re
import subprocess
import sys

import pytest

import millsim
from millsim.analysis import evidence, physics_files
from millsim.cli import main

STALE_HASH = "0123456789ab"  # not today's: 12 hex digits no source tree hashes to by design


def pages(folder, today):
    folder.mkdir()
    (folder / "fresh.md").write_text(f"# Fresh\n\nMeasured today, engine {today}:\n\n| a |\n")
    (folder / "old.md").write_text(
        "# Old\n\n## Quick study\n\nMeasured 2026-11-21, engine\n"
        f"{STALE_HASH} (a hash on the line after the word)\n\n## Paper scale\n\n"
        f"with engine {today}; checksum deadbeef0123 of a file is no engine hash\n")
    (folder / "bare.md").write_text("# Bare\n\n1.5 W, no hash; commit 16a5317da64c alone\n")
    return folder


def test_evidence_lists_the_stale_page_with_its_section_and_counts_the_current(tmp_path, capsys):
    today = millsim.provenance_hash()
    folder = pages(tmp_path / "results", today)
    result = evidence.evidence(folder)
    status = {p["page"].rsplit("/", 1)[1]: p["status"] for p in result["pages"]}
    assert status == {"fresh.md": "current", "old.md": "stale", "bare.md": "no engine hash"}
    assert (result["total"], result["current"], result["stale"], result["no_hash"]) == (3, 1, 1, 1)
    old = next(p for p in result["pages"] if p["page"].endswith("old.md"))
    # why: no commit hashes to it; a copy without git (the mutation tool's) cannot look
    why = ("no commit of this repository's history has this engine hash"
           if physics_files.repository() is not None
           else "another engine (no git history here to compare its files)")
    assert old["stale"] == [dict(line=6, section="Quick study", engine=STALE_HASH, old=False,
                                 current=False, why=why)]
    # the command: a count line first, then the pages that are not current
    assert main(["evidence", "--docs", str(folder), "--json", str(tmp_path / "e.json")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == (f"millsim evidence: 1 of 3 results pages current (engine {today}); "
                      "1 stale, 1 without an engine hash")
    assert any(line.startswith("STALE") and line.endswith("old.md") for line in out)
    assert f"line 6: engine {STALE_HASH}  (Quick study)" in "\n".join(out)
    assert not any(line.endswith("fresh.md") for line in out)
    assert any(line.startswith("NO ENGINE HASH") and line.endswith("bare.md") for line in out)
    assert json.loads((tmp_path / "e.json").read_text())["current"] == 1


def test_a_current_page_is_listed_only_for_the_numbers_it_keeps_for_comparison(tmp_path, capsys):
    today = millsim.provenance_hash()
    folder = tmp_path / "results"
    folder.mkdir()
    (folder / "kept.md").write_text(f"engine {today}: 1.5 W; old engine {STALE_HASH}: 1.7 W\n")
    (folder / "plain.md").write_text(f"engine {today}: 1.5 W\n")
    assert main(["evidence", "--docs", str(folder)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("millsim evidence: 2 of 2 results pages current")
    assert [line.split()[-1].rsplit("/", 1)[-1] for line in out[1:] if "results/" in line] == \
        ["kept.md"]
    assert any(f"engine {STALE_HASH}" in line and "kept for comparison" in line for line in out)


def test_evidence_of_a_missing_folder_is_refused_in_one_line(tmp_path, capsys):
    assert main(["evidence", "--docs", str(tmp_path / "nowhere")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nowhere" in err[0]


def test_a_second_hash_counts_within_60_characters_after_the_first():
    first, second = "aaaaaaaaaaaa", "bbbbbbbbbbbb"
    near = f"engine {first}" + "." * 59 + f" and {second}"  # 60 characters between them
    far = f"engine {first}" + "." * 60 + f" and {second}"
    assert [h for _, _, h in evidence.engine_hashes(near)] == [first, second]
    assert [h for _, _, h in evidence.engine_hashes(far)] == [first]


def test_the_word_engine_ending_the_line_before_reaches_back_60_characters():
    hexes = "cccccccccccc"
    within = "engine" + " " * 54 + "\n" + hexes  # "engine" starts the line's last 60 characters
    assert evidence.engine_hashes(within) == [(2, "", hexes)]
    assert evidence.engine_hashes("engine" + " " * 55 + "\n" + hexes) == []


# --- judged by the physics a page uses (its scenes' imports), not by the whole hash ---


def _git(repo, *args):
    subprocess.run(["git", "-C", str(repo), *args], check=True, capture_output=True,
                   env={**os.environ, "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t",
                        "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@t"})


def _toy_repository(repo):
    """A package laid out like millsim: scene ``one`` imports the engine core, scene ``two`` the
    core and a model (inside a function: static imports at any depth count)."""
    package = repo / "src" / "millsim"
    files = {
        "__init__.py": "LAYERS = (('base', ('util', 'io')), ('engine', ('engine',)), "
                       "('models', ('models',)), ('scenes', ('scenes',)), ('studies', ('cli',)))\n",
        "io.py": "X = 1\n", "util/__init__.py": "", "engine/__init__.py": "",
        "engine/core.py": "STEP = 1.0\n", "models/__init__.py": "", "models/extra.py": "K = 2\n",
        "scenes/__init__.py": "", "scenes/one.py": "from ..engine import core\n",
        "scenes/two.py": "from ..engine.core import STEP\n\ndef run():\n"
                         "    from millsim.models import extra\n    return extra.K\n",
        "cli.py": "print('not physics')\n",
    }
    for name, text in files.items():
        (package / name).parent.mkdir(parents=True, exist_ok=True)
        (package / name).write_text(text)
    _git(repo, "init", "-q")
    _git(repo, "add", ".")
    _git(repo, "commit", "-q", "-m", "toy")
    return package


def _today(package):
    return physics_files.tree_hash({p: (package / p).read_bytes()
                                    for p in physics_files.physics_paths(package)})


def test_a_page_stays_current_when_only_another_scenes_physics_changed(tmp_path):
    repo = tmp_path / "repo"
    package = _toy_repository(repo)
    assert physics_files.scene_files(["one"], package) == [
        "engine/__init__.py", "engine/core.py", "scenes/__init__.py", "scenes/one.py"]
    assert "models/extra.py" in physics_files.scene_files(["two"], package)
    then = _today(package)  # the hash the committed tree records
    history = physics_files.History(repo)
    assert history.commit_hash("HEAD") == then
    history.close()
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "one.md").write_text(f"# One\n\nPhysics: scene `one`\n\nengine {then}: 1.5 W\n")
    (docs / "two.md").write_text(f"# Two\n\nPhysics: scene `two`\n\nengine {then}: 2.5 W\n")
    (docs / "whole.md").write_text(f"# Whole\n\nengine {then}: 3.5 W\n")
    # a change to a model only scene two imports, and to a file outside the physics
    (package / "models" / "extra.py").write_text("K = 3\n")
    (package / "cli.py").write_text("print('changed')\n")
    now = _today(package)
    assert now != then
    result = evidence.evidence(docs, now, package)
    status = {p["page"].rsplit("/", 1)[1]: p for p in result["pages"]}
    assert status["one.md"]["status"] == evidence.CURRENT and not status["one.md"]["stale"]
    assert status["two.md"]["status"] == evidence.STALE
    assert "models/extra.py changed" in status["two.md"]["stale"][0]["why"]
    assert status["whole.md"]["status"] == evidence.STALE  # no scenes named: the whole hash
    # the engine both scenes use: both stale
    (package / "engine" / "core.py").write_text("STEP = 0.5\n")
    result = evidence.evidence(docs, _today(package), package)
    assert result["current"] == 0 and result["stale"] == 3


def test_an_unknown_scene_on_a_page_is_refused_naming_the_page(tmp_path):
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "p.md").write_text(f"Physics: scene `nowhere`\n\nengine {STALE_HASH}\n")
    with pytest.raises(ValueError, match=r"p\.md: scene 'nowhere'"):
        evidence.evidence(docs)


def test_a_hash_kept_for_comparison_neither_counts_nor_makes_the_page_stale():
    today = millsim.provenance_hash()
    both = f"today, engine {today}: 1.5 W; old engine {STALE_HASH}: 1.7 W\n"
    status, listed = evidence.page_status(both, today)
    assert status == evidence.CURRENT
    assert [(s["engine"], s["old"]) for s in listed] == [(STALE_HASH, True)]
    # only old numbers: nothing on the page is current
    assert evidence.page_status(f"previous engine {STALE_HASH}\n", today)[0] == evidence.STALE
    # "old" must stand right before "engine": an old number elsewhere on the line does not count
    assert evidence.page_status(f"old values; engine {STALE_HASH}\n", today)[0] == evidence.STALE


@pytest.mark.skipif(physics_files.repository() is None, reason="not a git checkout")
def test_the_history_hashes_a_commit_as_provenance_hash_does():
    repo = physics_files.repository()
    dirty = subprocess.run(["git", "-C", str(repo), "status", "--porcelain", "--", "src/millsim"],
                           capture_output=True, text=True, check=True).stdout
    if any(line[3:].split("/")[2] in ("engine", "models", "scenes", "util", "io.py")
           for line in dirty.splitlines()):
        pytest.skip("physics sources edited and not committed: HEAD is not today's engine")
    history = physics_files.History(repo)
    assert history.commit_hash("HEAD") == millsim.provenance_hash()
    history.close()


def test_importing_a_scene_pulls_in_no_physics_module_outside_its_files():
    """The static set must hold every physics module a scene's import loads (a module loaded by
    name, e.g. through importlib, would be missed by the static reading). One process imports
    the modules all scenes share, then forks one child per scene."""
    from millsim.scenes import SCENE_MODULES

    code = """
import importlib, os, sys

def child(scene, keep):
    read, write = os.pipe()
    if os.fork() == 0:
        importlib.import_module('millsim.scenes.' + scene)
        os.write(write, ' '.join(m for m in sys.modules if keep(m)).encode())
        os._exit(0)
    os.close(write)
    with os.fdopen(read) as pipe:
        names = pipe.read().split()
    os.wait()
    return names

# the modules in every scene's set, loaded once here: a child still lists them (it inherits
# them), so nothing they pull in goes unchecked
for name in sys.argv[1].split(','):
    importlib.import_module(name)
for scene in sys.argv[2:]:
    print(scene, ' '.join(child(scene, lambda m: m.startswith('millsim.'))))
"""
    scenes = SCENE_MODULES
    common = set.intersection(*(set(physics_files.scene_files([s])) for s in scenes))
    modules = sorted("millsim." + path.removesuffix(".py").removesuffix("/__init__").replace("/", ".")
                     for path in common)
    out = subprocess.run([sys.executable, "-c", code, ",".join(modules), *scenes],
                         capture_output=True,
                         text=True, check=True).stdout.splitlines()
    assert [line.split()[0] for line in out] == list(scenes)
    physics = set(physics_files.physics_paths())
    for line in out:
        scene, *loaded = line.split()
        assert f"millsim.scenes.{scene}" in loaded
        files = set(physics_files.scene_files([scene]))
        for module in loaded:
            rel = physics_files._module_file(module, physics_files.PACKAGE)
            rel = rel.relative_to(physics_files.PACKAGE).as_posix()
            assert rel not in physics or rel in files, (scene, rel)


# --- the registry of identity checks: engine changes verified bit-identical for some scenes ---


def _commit(repo, package, edits, message):
    """Write ``edits`` ({path in the package: text}), commit them, and return the new hash."""
    for name, text in edits.items():
        (package / name).write_text(text)
    _git(repo, "commit", "-q", "-am", message)
    return _today(package)


def _entry(old, new, identical, differs=None, date="2026-12-02"):
    text = (f"- old: {old!r}\n  new: {new!r}\n  date: {date}\n  command: \"tools/x.sh\"\n"
            f"  identical: [{', '.join(identical)}]\n  why: \"a bookkeeping change\"\n")
    if differs:
        text += f"  differs: {{{', '.join(f'{k}: [{v}]' for k, v in differs.items())}}}\n"
    return text


def _judged(docs, today, package, registry=None):
    """{page name: (status, [why of each hash not listed as kept for comparison])}."""
    path = docs / evidence.REGISTRY
    if registry is None:
        path.unlink(missing_ok=True)
    else:
        path.write_text(registry)
    result = evidence.evidence(docs, today, package)
    return {p["page"].rsplit("/", 1)[1]: (p["status"], [s["why"] for s in p["stale"]])
            for p in result["pages"]}


@pytest.fixture
def toy(tmp_path, monkeypatch):
    """The toy repository (its first commit's hash as ``first``) and a folder for pages; the
    commit-hash cache kept inside tmp_path."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    repo = tmp_path / "repo"
    package = _toy_repository(repo)
    docs = tmp_path / "docs"
    docs.mkdir()
    return repo, package, docs, _today(package)


def test_an_identity_check_makes_the_pages_of_its_identical_scenes_current(toy):
    repo, package, docs, first = toy
    for name in ("one", "two"):
        (docs / f"{name}.md").write_text(f"Physics: scene `{name}`\n\nengine {first}: 1.5 W\n")
    (docs / "whole.md").write_text(f"engine {first}: 3.5 W\n")
    # the engine core both scenes import changes (not committed: today's tree is the new engine)
    (package / "engine" / "core.py").write_text("STEP = 1.0\nBOOK = 0\n")
    today = _today(package)
    changed = (evidence.STALE, [f"since {_rev(repo)}: engine/core.py changed"])
    assert _judged(docs, today, package) == {"one.md": changed, "two.md": changed, "whole.md": (
        evidence.STALE, ["another engine (the page names no scenes: judged by the whole hash)"])}
    # an entry naming scene one only: its page current, with the check it went through; scene
    # two (not in `identical`) and the page without scenes stay stale
    got = _judged(docs, today, package, _entry(first, today, ["one"]))
    assert got["one.md"] == (evidence.CURRENT, [
        f"current through the identity check of 2026-12-02 ({first} -> {today})"])
    assert got["two.md"][0] == evidence.STALE and got["whole.md"][0] == evidence.STALE
    # a scene whose variables moved (`differs`) is not covered by the entry
    got = _judged(docs, today, package, _entry(first, today, ["two"], {"one": "energy_book"}))
    assert got["one.md"][0] == evidence.STALE and got["two.md"][0] == evidence.CURRENT
    # a page naming both scenes needs both in `identical`
    (docs / "both.md").write_text(f"Physics: scenes `one`, `two`\n\nengine {first}: 1 W\n")
    assert _judged(docs, today, package, _entry(first, today, ["one"]))["both.md"][0] == \
        evidence.STALE
    assert _judged(docs, today, package, _entry(first, today, ["two", "one"]))["both.md"][0] == \
        evidence.CURRENT


def _rev(repo):
    return subprocess.run(["git", "-C", str(repo), "rev-parse", "HEAD"], capture_output=True,
                          text=True, check=True).stdout.strip()[:10]


def test_identity_checks_chain_and_a_loop_of_them_ends(toy):
    repo, package, docs, first = toy
    second = _commit(repo, package, {"engine/core.py": "STEP = 1.0\nA = 0\n"}, "book a")
    third = _commit(repo, package, {"engine/core.py": "STEP = 1.0\nA = 0\nB = 0\n"}, "book b")
    assert len({first, second, third}) == 3
    (docs / "one.md").write_text(f"Physics: scene `one`\n\nengine {first}: 1.5 W\n")
    a, b = _entry(first, second, ["one"]), _entry(second, third, ["one"], date="2026-12-03")
    assert _judged(docs, third, package, a)["one.md"][0] == evidence.STALE  # second is not today
    assert _judged(docs, third, package, a + b)["one.md"] == (evidence.CURRENT, [
        f"current through the identity checks of 2026-12-02 ({first} -> {second}), "
        f"2026-12-03 ({second} -> {third})"])
    # first -> second -> first never reaches today: stale, and the judge returns
    loop = a + _entry(second, first, ["one"])
    assert _judged(docs, third, package, loop)["one.md"][0] == evidence.STALE


def test_a_hash_before_the_checks_old_engine_counts_only_with_the_same_scene_files(toy):
    """H older than the entry's O: current when H's commit has O's content in the scene's files
    (a change between them elsewhere), stale when it differs there."""
    repo, package, docs, first = toy
    # between H (first) and O: a model that only scene two imports
    old = _commit(repo, package, {"models/extra.py": "K = 3\n"}, "model")
    assert physics_files.changed_between(physics_files.History(repo), "HEAD~1", "HEAD",
                                         ["models/extra.py", "engine/core.py"]) == \
        ["models/extra.py"]
    new = _commit(repo, package, {"engine/core.py": "STEP = 1.0\nBOOK = 0\n"}, "book")
    for name in ("one", "two"):
        (docs / f"{name}.md").write_text(f"Physics: scene `{name}`\n\nengine {first}: 1.5 W\n")
    got = _judged(docs, new, package, _entry(old, new, ["one", "two"]))
    assert got["one.md"] == (evidence.CURRENT, [
        f"current through the identity check of 2026-12-02 ({old} -> {new})"])
    assert got["two.md"][0] == evidence.STALE  # models/extra.py differs between H and O


def test_a_file_only_the_old_scene_imported_still_counts_between_h_and_o(toy):
    """H and O both import a model that today's scene no longer imports: a change of that model
    between H and O is a change of H's numbers, though no file of today's set differs."""
    repo, package, docs, _ = toy
    one = "from ..engine import core\nfrom ..models import extra\n"
    first = _commit(repo, package, {"scenes/one.py": one}, "one uses the model")
    old = _commit(repo, package, {"models/extra.py": "K = 3\n"}, "model")
    new = _commit(repo, package, {"scenes/one.py": "from ..engine import core\n"}, "no model")
    history = physics_files.History(repo)
    assert physics_files.scene_files_at(history, "HEAD~1", ["one"]) == [
        "engine/__init__.py", "engine/core.py", "models/__init__.py", "models/extra.py",
        "scenes/__init__.py", "scenes/one.py"]
    history.close()
    assert "models/extra.py" not in physics_files.scene_files(["one"], package)
    (docs / "one.md").write_text(f"Physics: scene `one`\n\nengine {first}: 1.5 W\n")
    assert _judged(docs, new, package, _entry(old, new, ["one"]))["one.md"][0] == evidence.STALE
    # the same page with O's hash itself: current through the check
    (docs / "one.md").write_text(f"Physics: scene `one`\n\nengine {old}: 1.5 W\n")
    assert _judged(docs, new, package, _entry(old, new, ["one"]))["one.md"][0] == evidence.CURRENT


def test_an_entry_whose_engine_no_commit_has_does_not_apply_and_is_said_once(toy, capsys):
    repo, package, docs, first = toy
    (package / "engine" / "core.py").write_text("STEP = 1.0\nBOOK = 0\n")
    today = _today(package)
    for name in ("a", "b"):
        (docs / f"{name}.md").write_text(f"Physics: scene `one`\n\nengine {first}: 1.5 W\n")
    (docs / evidence.REGISTRY).write_text(_entry(STALE_HASH, today, ["one"]))
    result = evidence.evidence(docs, today, package)
    assert result["stale"] == 2
    assert result["registry_notes"] == [
        f"{(docs / evidence.REGISTRY).as_posix()}: identity check of 2026-12-02 ({STALE_HASH} "
        f"-> {today}) does not apply: no commit of this repository's history has engine "
        f"{STALE_HASH}"]
    out = "\n".join(evidence.lines(result))
    assert out.count("does not apply") == 1


GOOD = dict(old="'aaaaaaaaaaaa'", new="'bbbbbbbbbbbb'", date="2026-12-02", command="x",
            identical="[one]", why="w")


@pytest.mark.parametrize("change, message", [
    (dict(why=None), r"entry 2 \(aaaaaaaaaaaa -> bbbbbbbbbbbb\): missing key 'why'"),
    (dict(identical="[one, three]"), r"entry 2 .*: scene 'three': no module millsim.scenes.three"),
    (dict(differs="{nowhere: [x]}"), r"entry 2 .*: scene 'nowhere'"),
    (dict(new="'bbbbbbbbbbbz'"), r"entry 2 .*: new: 'bbbbbbbbbbbz' is not an engine hash"),
    (dict(old="'aaaa'"), r"entry 2 .*: old: 'aaaa' is not an engine hash"),
    # twelve digits unquoted: YAML reads a number, which is refused rather than guessed at
    (dict(old="123456789012"), r"entry 2 .*: old: 123456789012 is not an engine hash"),
    (dict(differs="{one: [x]}"), r"entry 2 .*: scene 'one' both identical and differing"),
    (dict(date="yesterday"), r"entry 2 .*: date: 'yesterday' is not a date"),
    (dict(identicl="[one]"), r"entry 2 .*: unknown key 'identicl'"),
])
def test_a_malformed_registry_entry_is_refused_in_one_line_naming_file_and_entry(
        toy, capsys, change, message):
    _, package, docs, first = toy
    (docs / "p.md").write_text(f"Physics: scene `one`\n\nengine {first}\n")
    good = "- " + "\n  ".join(f"{k}: {v}" for k, v in GOOD.items()) + "\n"
    bad = {**GOOD, **change}
    path = docs / evidence.REGISTRY
    path.write_text(good + "- " + "\n  ".join(f"{k}: {v}" for k, v in bad.items()
                                               if v is not None) + "\n")
    with pytest.raises(ValueError, match=re.escape(str(path)) + ": " + message) as caught:
        evidence.evidence(docs, first, package)
    assert "\n" not in str(caught.value)
    # the well-formed first entry alone is read
    path.write_text(good)
    assert [e["old"] for e in evidence.read_registry(path, package)] == ["aaaaaaaaaaaa"]


def test_the_repositorys_registry_is_read_and_well_formed():
    """docs/results/engine_identity.yaml parses against today's scenes (a typo there would make
    `millsim evidence` refuse the folder)."""
    path = physics_files.PACKAGE.parents[1] / "docs" / "results" / evidence.REGISTRY
    if not path.is_file():
        pytest.skip("no docs/results here (an installed copy)")
    from millsim.scenes import SCENE_MODULES

    entries = evidence.read_registry(path)
    assert entries and all(set(e["identical"]) <= set(SCENE_MODULES) for e in entries)


@pytest.mark.parametrize("page, scene, block, overlay", [
    ("ballmill_paper", "ballmill2d", "ballmill", None),
    ("bed_impact_paper", "bed_impact", "bed_impact", None),
    # the cuts that fit a 2-core session, merged over paper.yaml (docs/pipeline.md's commands)
    ("ballmill3d_paper", "ballmill3d", "ballmill3d", "ballmill3d_lab_power.yaml"),
    ("stirred_mill_paper", "stirred_mill", "stirred_mill", "ls1_power.yaml"),
])
def test_a_paper_page_was_run_with_the_parameters_config_paper_gives_today(page, scene, block,
                                                                           overlay):
    """A results page lists the parameters its cases were run with ("fixed: k = v, ..."); the
    scene's parameters as the page's command gives them today must still be those, or re-running
    it would run other cases: config/config.yaml (the Snakefile's configfile), then
    config/paper.yaml and the page's overlay merged over it as Snakemake merges --configfile
    (their scalars; the rest at the scene's defaults)."""
    import yaml

    from millsim.scenes.base import get_scene

    root = os.path.join(os.path.dirname(__file__), "..")
    with open(os.path.join(root, "docs", "results", f"{page}.md")) as f:
        line = re.search(r"^- fixed: (.*)$", f.read(), re.M)[1]
    fixed = dict(item.split(" = ", 1) for item in line.split(", "))
    block_params = {}
    for name in ("config.yaml", "paper.yaml", overlay):
        if name:
            with open(os.path.join(root, "config", name)) as f:
                given = yaml.safe_load(f).get(block, {})
            block_params.update(given.get("parameters", given))
    sc = get_scene(scene)
    names = {p.name for p in sc.params}
    values = sc.resolve({k: v for k, v in block_params.items()
                         if k in names and not isinstance(v, (list, dict))})
    compared = 0
    for key, text in fixed.items():
        if key not in values:
            continue
        got = values[key]
        try:
            # the page prints 4 significant digits (results_page.fmt): the value so rounded
            same = float(text) == float(f"{float(got):.4g}")
        except (TypeError, ValueError):
            same = str(got) == text
        assert same, f"{page}: {key} = {text} on the page, {got!r} from the config files"
        compared += 1
    assert compared >= 5
