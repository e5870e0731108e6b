"""The sampled mutation tool (tools/sample_mutants.py): the draw is reproducible, every mutant is
the edit it says, and every module in scope has test files to run its mutants against."""

import ast
import json
import shutil
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

import sample_mutants  # noqa: E402


def test_the_same_seed_draws_the_same_mutants_and_another_seed_others():
    mods = ["util/stats", "engine/timestep"]
    first = [m["id"] for m in sample_mutants.sample(mods, 10, seed=47)]
    assert first == [m["id"] for m in sample_mutants.sample(mods, 10, seed=47)]
    assert first != [m["id"] for m in sample_mutants.sample(mods, 10, seed=48)]
    assert len(first) == 20 and len(set(first)) == 20


def test_each_mutant_replaces_exactly_its_node_and_changes_the_syntax_tree(tmp_path):
    text = (ROOT / "src/millsim/util/stats.py").read_text()
    mutants = sample_mutants.sites("util/stats")
    assert {m["operator"] for m in mutants} >= {"arith", "compare", "const", "drop"}
    (tmp_path / "src/millsim/util").mkdir(parents=True)
    target = tmp_path / "src/millsim/util/stats.py"
    valid = 0
    for m in mutants:
        assert text[m["start"]:m["end"]] == m["original"]
        target.write_text(text)
        if not sample_mutants.apply(m, tmp_path):
            assert target.read_text() == text  # a mutant that does not compile leaves no trace
            continue
        valid += 1
        mutated = target.read_text()
        # the replacement sits where the original was, and nothing else changed
        end = m["start"] + len(m["replacement"])
        assert mutated[m["start"]:end] == m["replacement"]
        assert mutated[:m["start"]] + m["original"] + mutated[end:] == text
        assert ast.dump(ast.parse(mutated)) != ast.dump(ast.parse(text))
    assert valid >= 0.95 * len(mutants)


def test_every_module_in_scope_has_test_files():
    lacking = [m for m in sample_mutants.modules() if not sample_mutants.test_files_for(m)]
    assert lacking == []
    assert "tests/test_silo.py" in sample_mutants.test_files_for("scenes/silo")
    # through a package's re-export: test_insertion imports Pour from millsim.engine
    assert "tests/test_insertion.py" in sample_mutants.test_files_for("engine/insertion")


def test_a_pooled_draw_is_uniform_over_the_sites_and_scored_as_one_pool():
    mods = ["util/stats", "engine/timestep"]
    sizes = {m: len(sample_mutants.sites(m)) for m in mods}
    everything = sum(sizes.values())
    drawn = sample_mutants.sample(mods, None, seed=47, pool=everything)
    assert sorted(m["id"] for m in drawn) == sorted(
        m["id"] for mod in mods for m in sample_mutants.sites(mod))
    few = [m["id"] for m in sample_mutants.sample(mods, None, seed=47, pool=8)]
    assert few == [m["id"] for m in sample_mutants.sample(mods, None, seed=47, pool=8)]
    assert len(set(few)) == 8
    # uniform over sites: over many seeds each module's share tends to its share of the sites
    share = sum(m["module"] == "util/stats" for s in range(200)
                for m in sample_mutants.sample(mods, None, seed=s, pool=4)) / 800
    expected = sizes["util/stats"] / everything
    assert abs(share - expected) < 4 * (expected * (1 - expected) / 800) ** 0.5
    results = [dict(id=f"util/stats:{k}", module="util/stats", outcome=o)
               for k, o in enumerate(["killed", "survived", "killed"])]
    results += [dict(id="engine/timestep:1", module="engine/timestep", outcome="timeout")]
    table = sample_mutants.score_table(results, {}, {"outcome": "passed", "failing": []})
    pooled = next(line for line in table.splitlines() if line.startswith("| all, pooled"))
    assert pooled.split("|")[2:5] == [" 3 ", " 4 ", " 75 % "]
    # the timeout counts as killed and is named as one
    assert pooled.split("|")[6] == " 1 (engine/timestep:1) "
    assert "util/stats:1" in pooled


def test_named_tests_replace_the_importers_in_the_baseline_and_every_mutant(tmp_path, monkeypatch):
    """``--tests``: the named node ids run in the baseline and against each mutant, in place of the
    test files importing the module, the report says so, and a record made with other tests is
    not resumed. A mutant's time limit is ``--timeout`` beyond 3x its tests' baseline time (the
    baseline's files took 1 s each here)."""
    calls = []

    def snapshot(ref, tree):
        (tree / "src/millsim/util").mkdir(parents=True)
        shutil.copy(ROOT / "src/millsim/util/stats.py", tree / "src/millsim/util/stats.py")

    def run_tests(tree, tests, timeout, cache):
        mutated = (tree / "src/millsim/util/stats.py").read_text() != (
            ROOT / "src/millsim/util/stats.py").read_text()
        calls.append((mutated, list(tests), timeout))
        return ("killed" if mutated else "survived"), 1.0, ""

    monkeypatch.setattr(sample_mutants, "snapshot", snapshot)
    monkeypatch.setattr(sample_mutants, "run_tests", run_tests)
    named = ["tests/test_stats.py::test_a", "tests/test_other.py"]
    record, report = tmp_path / "after.json", tmp_path / "after.md"
    argv = ["--module", "util/stats", "--per-module", "2", "--seed", "47", "--json", str(record),
            "--out", str(report), "--timeout", "5"] + [a for t in named for a in ("--tests", t)]
    assert sample_mutants.main(argv) == 0
    baseline = [tests for mutated, tests, _ in calls if not mutated]
    assert sorted(baseline) == sorted([[named[0]], [named[1]]])  # one file or node id at a time
    assert [(tests, limit) for mutated, tests, limit in calls if mutated] == [(named, 11.0)] * 2
    assert json.loads(record.read_text())["baseline"]["seconds"] == dict.fromkeys(named, 1.0)
    done = json.loads(record.read_text())
    assert done["tests"] == named and [r["outcome"] for r in done["results"]] == ["killed"] * 2
    assert "tests/test_stats.py::test_a, tests/test_other.py" in report.read_text()
    with pytest.raises(SystemExit):
        sample_mutants.main(argv[:-4])  # the same record, by import


def test_a_mutant_runs_its_test_files_fastest_first(tmp_path, monkeypatch):
    """Each mutant runs its files in the order of their baseline times (ties as given), so that
    a kill by a quick file ends the run before the slow ones start."""
    calls = []
    seconds = {"tests/a.py": 30.0, "tests/b.py": 2.0, "tests/c.py": 9.0, "tests/d.py": 2.0}

    def snapshot(ref, tree):
        (tree / "src/millsim/util").mkdir(parents=True)
        shutil.copy(ROOT / "src/millsim/util/stats.py", tree / "src/millsim/util/stats.py")

    def run_tests(tree, tests, timeout, cache):
        calls.append(list(tests))
        return "survived", seconds[tests[0]] if len(tests) == 1 else 1.0, ""

    monkeypatch.setattr(sample_mutants, "snapshot", snapshot)
    monkeypatch.setattr(sample_mutants, "run_tests", run_tests)
    argv = ["--module", "util/stats", "--per-module", "1", "--json", str(tmp_path / "r.json")]
    argv += [a for t in seconds for a in ("--tests", t)]
    assert sample_mutants.main(argv) == 0
    assert calls[-1] == ["tests/b.py", "tests/d.py", "tests/c.py", "tests/a.py"]


def test_an_interrupted_baseline_resumes_where_it_stopped(tmp_path, monkeypatch):
    """The baseline is kept file by file: stopped in its second file, the same command runs only
    the files not yet run, then the mutants."""
    calls = []

    def snapshot(ref, tree):
        (tree / "src/millsim/util").mkdir(parents=True)
        shutil.copy(ROOT / "src/millsim/util/stats.py", tree / "src/millsim/util/stats.py")

    def run_tests(tree, tests, timeout, cache):
        if len(calls) == 1 and interrupt:
            raise KeyboardInterrupt
        calls.append(list(tests))
        return "survived", 2.0, ""

    monkeypatch.setattr(sample_mutants, "snapshot", snapshot)
    monkeypatch.setattr(sample_mutants, "run_tests", run_tests)
    record = tmp_path / "run.json"
    named = ["tests/a.py", "tests/b.py", "tests/c.py"]
    argv = ["--module", "util/stats", "--per-module", "1", "--json", str(record)] + [
        a for t in named for a in ("--tests", t)]
    interrupt = True
    with pytest.raises(KeyboardInterrupt):
        sample_mutants.main(argv)
    kept = json.loads(record.read_text())["baseline"]
    assert kept["outcome"] is None and kept["seconds"] == {"tests/a.py": 2.0}
    interrupt = False
    calls.clear()
    assert sample_mutants.main(argv) == 0
    assert calls == [["tests/b.py"], ["tests/c.py"], named]  # the rest of the baseline, a mutant
    done = json.loads(record.read_text())
    assert done["baseline"]["outcome"] == "passed" and len(done["baseline"]["seconds"]) == 3


def test_the_scratch_tree_holds_every_part_of_the_repository_but_its_outputs():
    """A mutant runs in a copy of the repository's parts (mutate.PARTS); a file a test reads that
    the copy lacks fails the test for every mutant and counts as a kill (issue 47: test_habits
    read LICENSE and the bench/ scripts the sources name, and failed in every scene mutant's
    baseline). Every tracked top-level entry is copied but results/ (outputs) and .gitignore, so
    a new one must be placed deliberately."""
    import subprocess

    import mutate

    tracked = subprocess.run(["git", "-C", str(ROOT), "ls-tree", "--name-only", "HEAD"],
                             capture_output=True, text=True, check=True).stdout.split()
    assert set(tracked) - {"results", ".gitignore"} <= set(mutate.PARTS)


def test_the_step_loop_s_passes_run_against_the_files_that_run_their_physics():
    """tools/mutant_runners.yaml: every module it names exists and every file it lists is a test
    file; the files it lists join the importers (the walls pass's importers run no moving wall,
    no film and no mesh)."""
    runners = sample_mutants.load_runners()
    assert set(runners) <= set(sample_mutants.modules())
    assert all((ROOT / f).is_file() and Path(f).name.startswith("test_")
               for files in runners.values() for f in files)
    by_import = sample_mutants.test_files_for("engine/loop/wall_pass", runners={})
    assert "tests/test_wall_kinds.py" not in by_import
    assert sample_mutants.test_files_for("engine/loop/wall_pass") == sorted(
        set(by_import) | set(runners["engine/loop/wall_pass"]))


def test_a_record_made_against_other_test_files_is_not_resumed(tmp_path, monkeypatch):
    """A module whose test files changed (a runner added to tools/mutant_runners.yaml) does not
    resume a record whose mutants ran against the old files: the scores would mix two sets. A
    finished record still prints its table."""
    def snapshot(ref, tree):
        (tree / "src/millsim/util").mkdir(parents=True)
        shutil.copy(ROOT / "src/millsim/util/stats.py", tree / "src/millsim/util/stats.py")

    monkeypatch.setattr(sample_mutants, "snapshot", snapshot)
    monkeypatch.setattr(sample_mutants, "run_tests", lambda *a: ("survived", 1.0, ""))
    record = tmp_path / "r.json"
    argv = ["--module", "util/stats", "--per-module", "2", "--json", str(record)]
    first = sample_mutants.sample(["util/stats"], 2, seed=47)[0]["id"]
    monkeypatch.setattr(sample_mutants, "load_runners", lambda: {})
    assert sample_mutants.main(argv + ["--only", first]) == 0
    assert sample_mutants.main(argv + ["--only", first]) == 0  # the same files: resumes
    monkeypatch.setattr(sample_mutants, "load_runners",
                        lambda: {"util/stats": ["tests/test_verdicts.py"]})
    assert sample_mutants.main(argv + ["--only", first]) == 0  # finished: its table
    with pytest.raises(SystemExit):
        sample_mutants.main(argv)  # the second mutant would run against other files
    assert len(json.loads(record.read_text())["results"]) == 1


def test_every_kernel_the_step_loop_is_handed_lives_in_a_file_mutated_with_a_fresh_cache():
    """A mutant of a file whose functions the compiled loop calls runs with an empty kernel cache
    (mutate.COMPILED): numba caches the loop under the runner's file and does not see a callee's
    file change, so with the baseline's cache such a mutant runs the unmutated loop and survives
    whatever its tests (issue 47, seed 57: tavares_log's kernels were outside the list, and six
    of its ten mutants "survived" in 5 s). Every breakage model's and the film's kernels, and
    every contact law's force, checked by the file its Python source lives in."""
    import inspect

    from mutate import COMPILED

    import millsim.models  # noqa: F401  registers the models
    import millsim.models.breakage.tavares_log  # noqa: F401
    from millsim.engine.models import ParticleModel
    from millsim.models import Lubrication
    from millsim.models.contact import LAWS

    def subclasses(cls):
        for sub in cls.__subclasses__():
            yield sub
            yield from subclasses(sub)

    handed = [k for cls in subclasses(ParticleModel)
              if isinstance(getattr(cls, "kernels", None), tuple) for k in cls.kernels]
    handed += list(Lubrication(eta=0.01, h_min=0.001, h_max=0.05).kernels)
    handed += [law.force for law in LAWS.values()]
    assert len(handed) > 30
    files = {str(Path(inspect.getsourcefile(getattr(k, "py_func", k))).relative_to(ROOT))
             for k in handed}
    assert {f for f in files if not f.startswith(COMPILED)} == set()
