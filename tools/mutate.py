"""Mutation testing with a curated list of physics mutants (``make mutate``).

Each mutant in ``tools/mutants.yaml`` is one realistic physics bug: a text edit of one source file
(``find`` must occur exactly ``count`` times, 1 by default, so a mutant that no longer applies after
a refactor is reported as stale instead of silently testing nothing) and the test files that
should catch it. For every mutant the tool copies ``src/``, ``tests/`` and what they read
(``PARTS``) to a scratch directory, applies the edit there, and runs pytest on the mutant's tests
with the copy first on ``PYTHONPATH``. The mutant is killed when pytest fails.

Compile time dominates. numba recompiles a cached function when its own source file changed, but
not when a function it inlines from another file did: so a mutant in a file whose functions are
compiled into the step loop (``COMPILED``) runs with an empty kernel cache, and the other mutants
(pure Python: scenes, analysis, statistics, the Tavares relations) share one cache, filled once.

    python tools/mutate.py                  # all mutants, report per module
    python tools/mutate.py --only hm-kt-x2  # some of them (repeatable, or a prefix with *)
    python tools/mutate.py --ref HEAD~3     # the sources and tests of a commit (score before a change)
    python tools/mutate.py --list
    python tools/mutate.py --ref acc2ce6 --mutants OLD.yaml --test-map tools/mutate_before_map.yaml
                                            # an older suite against the mutants of its time, each
                                            # test file that did not exist yet replaced by the
                                            # older files covering the same physics

Not part of CI: a full run compiles every kernel variant once per mutant (about an hour on 2 cores).
The report goes to stdout and, with ``--out``, to a Markdown file.
"""

import argparse
import fnmatch
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
MUTANTS = ROOT / "tools" / "mutants.yaml"
# what the tests read besides the sources: the materials file, the shipped liner, the workflow,
# the docs, the Makefile, tools and benchmarks they check or name, the licence and citation (a
# missing file would fail the test and count as a kill); only results/ (outputs) stays behind
PARTS = ("src", "tests", "config", "examples", "workflow", "profiles", "docs", "tools", "bench",
         "requirements", ".ci", "Snakefile", "Makefile", "README.md", "pyproject.toml", "LICENSE",
         "CITATION.cff")
REQUIRED = ("id", "file", "find", "replace", "tests", "why")
# Files with functions the compiled loop calls or inlines (a mutant there needs a fresh cache).
COMPILED = ("src/millsim/engine/", "src/millsim/models/contact/", "src/millsim/models/lubrication.py",
            "src/millsim/models/breakage/weibull.py", "src/millsim/models/breakage/damage.py",
            "src/millsim/models/breakage/tavares_engine.py",
            "src/millsim/models/breakage/tavares_log.py", "src/millsim/breakage/weibull.py",
            "src/millsim/breakage/damage.py")


def load_test_map(path):
    """{test file: [files that stand in for it]} (for suites older than a mutant's test files)."""
    if path is None:
        return {}
    table = yaml.safe_load(Path(path).read_text())
    if not isinstance(table, dict) or not all(isinstance(v, list) for v in table.values()):
        raise ValueError(f"{path}: expected a mapping of test file -> list of test files")
    return table


def mapped_tests(tests, test_map):
    out = []
    for t in tests:
        for u in test_map.get(t, [t]):
            if u not in out:
                out.append(u)
    return out


def load_mutants(path=MUTANTS):
    entries = yaml.safe_load(Path(path).read_text())
    seen = set()
    for m in entries:
        missing = [k for k in REQUIRED if k not in m]
        if missing:
            raise ValueError(f"{path}: mutant {m.get('id', '?')!r} lacks {missing}")
        if m["id"] in seen:
            raise ValueError(f"{path}: duplicate mutant id {m['id']!r}")
        seen.add(m["id"])
        m.setdefault("count", 1)
        # the module a mutant belongs to, for the per-module score: path below src/millsim
        m.setdefault("module", str(Path(m["file"]).relative_to("src/millsim").with_suffix("")))
    return entries


def snapshot(ref, dest):
    """The PARTS of the working tree (ref None) or of a commit, copied into dest."""
    if ref is None:
        for part in PARTS:
            if (ROOT / part).is_file():
                shutil.copy2(ROOT / part, dest / part)
            elif (ROOT / part).is_dir():
                shutil.copytree(ROOT / part, dest / part,
                                ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
        return
    present = subprocess.run(["git", "-C", str(ROOT), "ls-tree", "--name-only", ref],
                             check=True, capture_output=True, text=True).stdout.split()
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", ref,
                              *[p for p in PARTS if p in present]],
                             check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)


def staleness(mutant, text):
    """Why ``mutant`` does not apply to ``text`` (its file's source), or None when it does."""
    found = text.count(mutant["find"])
    if found != mutant["count"]:
        return f"stale: 'find' occurs {found} times in {mutant['file']}, expected {mutant['count']}"
    return None


def apply(mutant, tree):
    path = tree / mutant["file"]
    text = path.read_text()
    why = staleness(mutant, text)
    if why is None:
        path.write_text(text.replace(mutant["find"], mutant["replace"]))
    return why


def run_tests(tree, tests, timeout, cache):
    tests = [t for t in tests if (tree / t.split("::")[0]).exists()]
    if not tests:
        return "no-tests", 0.0, ""
    env = dict(os.environ, PYTHONPATH=str(tree / "src"), NUMBA_CACHE_DIR=str(cache),
               PYTHONDONTWRITEBYTECODE="1")
    cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *tests]
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return "timeout", time.perf_counter() - t0, ""
    elapsed = time.perf_counter() - t0
    tail = (proc.stdout + proc.stderr).strip().splitlines()[-1:] or [""]
    outcome = {0: "survived", 1: "killed", 5: "no-tests"}.get(proc.returncode, "error")
    return outcome, elapsed, tail[0]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", action="append", help="mutant id or glob (repeatable)")
    ap.add_argument("--ref", help="git ref whose src/ and tests/ to mutate (default: working tree)")
    ap.add_argument("--timeout", type=float, default=1200.0, help="seconds per mutant")
    ap.add_argument("--mutants", default=str(MUTANTS), help="mutant list (default: %(default)s)")
    ap.add_argument("--test-map", help="YAML {test file: [stand-in files]} for an older suite")
    ap.add_argument("--list", action="store_true", help="list the mutants and exit")
    ap.add_argument("--out", help="also write the report (Markdown) here")
    ap.add_argument("--json", help="also write the outcomes (JSON) here")
    args = ap.parse_args(argv)

    mutants = load_mutants(args.mutants)
    test_map = load_test_map(args.test_map)
    if args.only:
        mutants = [m for m in mutants if any(fnmatch.fnmatch(m["id"], p) for p in args.only)]
        if not mutants:
            ap.error(f"--only: no mutant matches {args.only}")
    if args.list:
        for m in mutants:
            print(f"{m['id']:34s} {m['module']:24s} {m['why']}")
        return 0

    results = []
    with tempfile.TemporaryDirectory(prefix="millsim-mutate-") as tmp:
        tmp = Path(tmp)
        shared = tmp / "cache-shared"  # kernels of the unmutated compiled files
        for k, m in enumerate(mutants, 1):
            # the same tree path for every mutant (numba's cache is keyed by the source path);
            # copies keep the files' times, so unmutated files stay fresh in the shared cache
            tree = tmp / "tree"
            shutil.rmtree(tree, ignore_errors=True)
            tree.mkdir()
            snapshot(args.ref, tree)
            stale = apply(m, tree)
            compiled = m["file"].startswith(COMPILED)
            cache = tmp / "cache-mutant" if compiled else shared
            if stale:
                outcome, elapsed, detail = "stale", 0.0, stale
            else:
                outcome, elapsed, detail = run_tests(tree, mapped_tests(m["tests"], test_map),
                                                    args.timeout, cache)
            if compiled:  # kernels compiled with this mutant inlined are useless to the next one
                shutil.rmtree(cache, ignore_errors=True)
            results.append(dict(id=m["id"], module=m["module"], why=m["why"], outcome=outcome,
                                seconds=round(elapsed, 1), detail=detail))
            print(f"[{k}/{len(mutants)}] {m['id']:34s} {outcome:9s} {elapsed:6.0f} s  {detail}",
                  flush=True)

    report = render(results, args.ref)
    print(report)
    if args.out:
        Path(args.out).write_text(report)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return 0


def render(results, ref):
    """Kill rate per module; survivors, timeouts, errors and stale mutants listed by name."""
    by_module = defaultdict(list)
    for r in results:
        by_module[r["module"]].append(r)
    counted = [r for r in results if r["outcome"] in ("killed", "survived", "timeout", "error")]
    killed = [r for r in counted if r["outcome"] != "survived"]
    lines = [f"# Mutation score ({'working tree' if ref is None else ref})", "",
             f"killed {len(killed)} of {len(counted)} ({100 * len(killed) / max(len(counted), 1):.0f} %)"
             " (timeouts and errors count as killed; stale mutants and mutants without tests are not "
             "counted)", "", "| module | killed | mutants | survivors |", "|---|---|---|---|"]
    for module in sorted(by_module):
        rows = [r for r in by_module[module] if r in counted]
        k = sum(r["outcome"] != "survived" for r in rows)
        surv = ", ".join(r["id"] for r in rows if r["outcome"] == "survived") or "-"
        lines.append(f"| {module} | {k} | {len(rows)} | {surv} |")
    odd = [r for r in results if r["outcome"] not in ("killed", "survived")]
    if odd:
        lines += ["", "Not plainly killed or survived:"]
        lines += [f"- {r['id']}: {r['outcome']} {r['detail']}" for r in odd]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
