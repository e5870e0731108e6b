"""Sampled mutation score: mechanically generated mutants, drawn at random, per module.

``make mutate`` (tools/mutate.py) runs a curated list: it measures the imagination of whoever wrote
the tests. This tool measures the bugs nobody listed. It walks the AST of every physics and
analysis module, lists every place one of these operators applies

    arith    + <-> -, * <-> /, ** -> *
    compare  < <-> <=, > <-> >=, == <-> !=   (single comparisons)
    bool     and <-> or
    const    a numeric constant perturbed: float c -> 1.5 c (0.0 -> 1.0), int n -> n + 1
    sign     a unary minus dropped
    drop     a term of a sum dropped (a + b -> a, a - b -> a)
    index    a constant subscript shifted by one (x[2] -> x[3])

draws ``--per-module`` of them with a fixed seed (the same sample every run, so a score before and
after a change compares the same mutants), and runs each against the test files that import its
module (directly; for a module no test imports, the test files importing its nearest importer;
for a scene, also the test files that name it), and the files ``tools/mutant_runners.yaml`` lists
for it: those that run its physics without importing it (the step loop's passes).
The tree each mutant runs in is a copy of the repository but its outputs (``mutate.PARTS``:
what the tests read besides ``src/`` and ``tests/``); the unmutated copy runs
first (the baseline) and a test file that fails there is left out of every mutant's run and named
in the report, so a missing file never counts as a kill. A mutant's files run in one pytest
process that stops at the first failure, fastest file (by the baseline) first.

Equivalent mutants (no behaviour can tell them apart) are listed by hand with the reason in
``tools/equivalent_mutants.yaml`` and leave the score's denominator. The score per module comes
with its Clopper-Pearson 95 % interval. Results are appended to ``--json`` as each mutant (and each
file of the baseline) ends, so an interrupted run resumes with the same command. A mutant still
running ``--timeout`` seconds beyond 3x the baseline's time for its test files counts as killed
(a hang or a slowdown no user would accept). Not part of CI (hours: a mutant of a compiled file
recompiles the step loop).

    python tools/sample_mutants.py --list                      # the sample, without running it
    python tools/sample_mutants.py --json results/sampled_mutants.json --out results/sampled.md
    python tools/sample_mutants.py --module engine/timestep --json ...   # one module (repeatable)
    python tools/sample_mutants.py --module engine/mesh --module engine/walls --pool 20 --json ...
                                                               # 20 drawn from both modules' sites
    python tools/sample_mutants.py ... --only 'engine/loop/wall_pass:83:*' \
        --tests tests/test_drive_power.py --json after.json   # a survivor against named tests
"""

import argparse
import ast
import fnmatch
import json
import random
import re
import shutil
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

import yaml
from mutate import COMPILED, ROOT, run_tests, snapshot
from scipy import stats

PACKAGE = ROOT / "src" / "millsim"
# physics and analysis: what a wrong number could come from (not the CLI, plots or I/O)
SCOPE = ("engine", "models", "analysis", "scenes", "util/stats.py")
EQUIVALENT = ROOT / "tools" / "equivalent_mutants.yaml"
RUNNERS = ROOT / "tools" / "mutant_runners.yaml"
# a mutant's time limit: --timeout beyond this many times the baseline's time for its test files
# (a mutant of the step loop recompiles it in every file, which the baseline's shared cache does
# once; a test file of whole DEM cases takes minutes unmutated)
SLOWDOWN = 3.0

_ARITH = {ast.Add: ast.Sub, ast.Sub: ast.Add, ast.Mult: ast.Div, ast.Div: ast.Mult,
          ast.Pow: ast.Mult}
_COMPARE = {ast.Lt: ast.LtE, ast.LtE: ast.Lt, ast.Gt: ast.GtE, ast.GtE: ast.Gt,
            ast.Eq: ast.NotEq, ast.NotEq: ast.Eq}


def modules():
    """Module names (path below src/millsim, no suffix) in scope, sorted."""
    out = []
    for entry in SCOPE:
        path = PACKAGE / entry
        files = [path] if path.suffix == ".py" else sorted(path.rglob("*.py"))
        out += [str(f.relative_to(PACKAGE).with_suffix("")) for f in files
                if f.name != "__init__.py"]
    return out


def _skipped_spans(tree):
    """Line spans whose nodes are not mutated: docstrings and f-strings (their inner positions
    are not reliable), and ``__all__``-style string tables never hold numbers anyway."""
    spans = []
    for node in ast.walk(tree):
        if isinstance(node, ast.JoinedStr):
            spans.append((node.lineno, node.end_lineno))
    return spans


def _mutations(node):
    """(operator, mutated copy) pairs for one node."""
    out = []
    if isinstance(node, ast.BinOp) and type(node.op) in _ARITH:
        out.append(("arith", ast.BinOp(node.left, _ARITH[type(node.op)](), node.right)))
        if isinstance(node.op, (ast.Add, ast.Sub)):
            out.append(("drop", node.left))
    elif isinstance(node, ast.Compare) and len(node.ops) == 1 and type(node.ops[0]) in _COMPARE:
        out.append(("compare", ast.Compare(node.left, [_COMPARE[type(node.ops[0])]()],
                                           node.comparators)))
    elif isinstance(node, ast.BoolOp):
        other = ast.Or() if isinstance(node.op, ast.And) else ast.And()
        out.append(("bool", ast.BoolOp(other, node.values)))
    elif (isinstance(node, ast.Constant) and type(node.value) in (int, float)):
        value = node.value
        new = value + 1 if isinstance(value, int) else (1.0 if value == 0 else value * 1.5)
        out.append(("const", ast.Constant(new)))
    elif isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        out.append(("sign", node.operand))
    elif (isinstance(node, ast.Subscript) and isinstance(node.slice, ast.Constant)
          and type(node.slice.value) is int):
        out.append(("index", ast.Subscript(node.value, ast.Constant(node.slice.value + 1),
                                           node.ctx)))
    return out


def _offsets(text):
    starts, pos = [0], 0
    for line in text.splitlines(keepends=True):
        pos += len(line)
        starts.append(pos)
    return starts


def sites(module):
    """Every mutant of one module: dicts with id, module, file, operator, span and replacement."""
    rel = f"src/millsim/{module}.py"
    text = (ROOT / rel).read_text()
    tree = ast.parse(text)
    skipped = _skipped_spans(tree)
    docstrings = {id(n.body[0].value) for n in ast.walk(tree)
                  if isinstance(n, (ast.Module, ast.FunctionDef, ast.ClassDef, ast.AsyncFunctionDef))
                  and n.body and isinstance(n.body[0], ast.Expr)
                  and isinstance(n.body[0].value, ast.Constant)}
    line_start = _offsets(text)
    out = []
    for node in ast.walk(tree):
        if id(node) in docstrings or not hasattr(node, "end_col_offset"):
            continue
        if any(a <= node.lineno <= b for a, b in skipped):
            continue
        for op, new in _mutations(node):
            start = line_start[node.lineno - 1] + _char_col(text, line_start, node.lineno,
                                                            node.col_offset)
            end = line_start[node.end_lineno - 1] + _char_col(text, line_start, node.end_lineno,
                                                              node.end_col_offset)
            replacement = f"({ast.unparse(new)})"
            if replacement == f"({text[start:end]})":
                continue
            # nested sums share their start: the length tells them apart
            out.append(dict(id=f"{module}:{node.lineno}:{node.col_offset}+{end - start}:{op}",
                            module=module,
                            file=rel, operator=op, start=start, end=end,
                            original=text[start:end], replacement=replacement))
    out.sort(key=lambda m: (m["start"], m["operator"]))
    return out


def _char_col(text, line_start, lineno, byte_col):
    """ast gives columns in UTF-8 bytes; slicing needs characters."""
    line = text[line_start[lineno - 1]:line_start[lineno]]
    return len(line.encode()[:byte_col].decode(errors="ignore"))


def apply(mutant, tree):
    """Write the mutant into ``tree``; False (and the file left unmutated) if it does not compile."""
    path = tree / mutant["file"]
    text = path.read_text()
    mutated = text[:mutant["start"]] + mutant["replacement"] + text[mutant["end"]:]
    try:
        compile(mutated, str(path), "exec")
    except SyntaxError:
        return False
    path.write_text(mutated)
    return True


def sample(mods, per_module, seed, pool=None):
    """The same draw for the same modules, seed and sources: one RNG per module, seeded by both.
    With ``pool``, ``pool`` mutants drawn uniformly from all the modules' sites together (each
    module weighted by its size: a score for a package whose modules are too slow to sample 30
    each, as engine/ is where every mutant recompiles the step loop)."""
    if pool is not None:
        everything = [m for module in mods for m in sites(module)]
        rng = random.Random(f"{seed}:pool:{','.join(sorted(mods))}")
        return sorted(rng.sample(everything, min(pool, len(everything))),
                      key=lambda m: (m["module"], m["start"]))
    chosen = []
    for module in mods:
        everything = sites(module)
        rng = random.Random(f"{seed}:{module}")
        chosen += sorted(rng.sample(everything, min(per_module, len(everything))),
                         key=lambda m: m["start"])
    return chosen


_IMPORT = re.compile(r"^\s*(?:from\s+([.\w]+)\s+import\s+([\w, ()]+)|import\s+([\w.]+))", re.M)


def _imports(path, package):
    """Dotted millsim modules a file imports (relative imports resolved against ``package``)."""
    found = set()
    for frm, names, plain in _IMPORT.findall(path.read_text()):
        if plain:
            found.add(plain)
            continue
        if frm.startswith("."):
            depth = len(frm) - len(frm.lstrip("."))
            base = package.split(".")[:len(package.split(".")) - depth + 1]
            frm = ".".join(base + ([frm.lstrip(".")] if frm.lstrip(".") else []))
        found.add(frm)
        found.update(f"{frm}.{n.split()[0]}" for n in names.strip("()").split(",") if n.strip())
    return {f for f in found if f.startswith("millsim")}


def load_runners(path=RUNNERS):
    """Module -> the test files that run its physics without importing it."""
    table = yaml.safe_load(Path(path).read_text()) or {}
    if not isinstance(table, dict) or not all(isinstance(v, list) for v in table.values()):
        raise ValueError(f"{path}: expected a mapping of module -> list of test files")
    return table


def test_files_for(module, runners=None):
    """Test files importing ``module``, or if none its nearest importer; for a scene, also the
    test files that name it (scenes are registered by name and loaded on demand, so the tests
    that run a scene seldom import it); and the files ``runners`` (tools/mutant_runners.yaml)
    lists for it."""
    dotted = "millsim." + module.replace("/", ".")
    tests = {p: _imports(p, "tests") for p in sorted((ROOT / "tests").glob("test_*.py"))}
    sources = {}
    for p in PACKAGE.rglob("*.py"):
        name = "millsim." + str(p.relative_to(PACKAGE).with_suffix("")).replace("/", ".")
        package = name.rsplit(".", 1)[0] if p.name != "__init__.py" else name.removesuffix(
            ".__init__")
        sources[name.removesuffix(".__init__")] = _imports(p, package)
    # a name a package re-exports (``from millsim.engine import Pour``) imports the module that
    # defines it (engine/insertion): the package's __init__ imported it from there
    defined_in = {}
    for package, imported in sources.items():
        for item in imported:
            owner, _, name = item.rpartition(".")
            if owner.startswith(package + ".") and owner in sources:
                defined_in[f"{package}.{name}"] = owner
    tests = {p: imp | {defined_in[i] for i in imp if i in defined_in} for p, imp in tests.items()}
    wanted, seen, hits = {dotted}, set(), []
    while wanted and not hits:
        hits = [p for p, imp in tests.items() if imp & wanted]
        seen |= wanted
        wanted = {name for name, imp in sources.items() if imp & wanted} - seen
    scenes = sorted(m.rsplit(".", 1)[-1] for m in seen if m.startswith("millsim.scenes."))
    if scenes:
        quoted = re.compile(rf"[\"']({'|'.join(map(re.escape, scenes))})[\"']")
        hits += [p for p in tests if p not in hits and quoted.search(p.read_text())]
    named = (load_runners() if runners is None else runners).get(module, [])
    return sorted({str(p.relative_to(ROOT)) for p in hits} | set(named))


def load_equivalent(path=EQUIVALENT):
    if not Path(path).exists():
        return {}
    table = yaml.safe_load(Path(path).read_text()) or {}
    if not isinstance(table, dict):
        raise ValueError(f"{path}: expected a mapping of mutant id -> reason")
    return table


def score_table(results, equivalent, baseline, tests=None):
    """Markdown: per module, killed of non-equivalent with the Clopper-Pearson 95 % interval."""
    by_module = defaultdict(list)
    for r in results:
        by_module[r["module"]].append(r)
    lines = ["# Sampled mutation score", "",
             f"Baseline (unmutated copy): {baseline['outcome']}; test files left out because they "
             f"fail there: {', '.join(baseline['failing']) or 'none'}.", "",
             *([f"Tests run against every mutant (not those importing its module): "
                f"{', '.join(tests)}.", ""] if tests else []),
             "| module | killed | non-equivalent | score | 95 % interval | of the killed, timeouts "
             "| equivalent | survivors |",
             "|---|---|---|---|---|---|---|---|"]
    groups = [(module, by_module[module]) for module in sorted(by_module)]
    if len(groups) > 1:
        groups.append(("all, pooled", list(results)))
    for module, rows in groups:
        counted = [r for r in rows if r["id"] not in equivalent
                   and r["outcome"] in ("killed", "survived", "timeout", "error")]
        k, n = sum(r["outcome"] != "survived" for r in counted), len(counted)
        low = stats.beta.ppf(0.025, k, n - k + 1) if k > 0 else 0.0
        high = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
        survivors = ", ".join((r["id"].split(":", 1)[1] if r["module"] == module else r["id"])
                              for r in counted if r["outcome"] == "survived") or "-"
        # a timeout counts as killed (a hang), but on a loaded machine it can be the load: named
        timeouts = [r["id"].split(":", 1)[1] if r["module"] == module else r["id"]
                    for r in counted if r["outcome"] == "timeout"]
        eq = sum(r["id"] in equivalent for r in rows)
        score = f"{100 * k / n:.0f} %" if n else "-"
        lines.append(f"| {module} | {k} | {n} | {score} | {100 * low:.0f}-{100 * high:.0f} % | "
                     f"{len(timeouts)}{' (' + ', '.join(timeouts) + ')' if timeouts else ''} | "
                     f"{eq} | {survivors} |")
    listed = [f"- `{i}`: {why}" for i, why in sorted(equivalent.items())]
    return "\n".join(lines + ["", "Equivalent mutants (by hand):", *(listed or ["- none"])]) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--module", action="append", help="module below src/millsim, e.g. "
                    "engine/timestep (repeatable; default: every module in scope)")
    ap.add_argument("--per-module", type=int, default=30)
    ap.add_argument("--pool", type=int, help="instead of --per-module: this many mutants drawn "
                    "uniformly from the named modules' sites together (scored also as one pool)")
    ap.add_argument("--seed", type=int, default=47)
    ap.add_argument("--timeout", type=float, default=1800.0, help="seconds per mutant beyond "
                    f"{SLOWDOWN}x the baseline's time for its test files")
    ap.add_argument("--only", action="append", help="of the sample, only the mutants whose id "
                    "matches this glob (repeatable), e.g. to re-run the survivors")
    ap.add_argument("--tests", action="append", help="run these test files or node ids "
                    "(repeatable) against every mutant instead of those importing its module, "
                    "e.g. the survivors against the tests written for them")
    ap.add_argument("--list", action="store_true", help="print the sample and exit")
    ap.add_argument("--json", help="outcomes, appended as each mutant ends (resumes from it)")
    ap.add_argument("--out", help="also write the report (Markdown) here")
    args = ap.parse_args(argv)

    mods = args.module or modules()
    unknown = [m for m in mods if not (PACKAGE / f"{m}.py").exists()]
    if unknown:
        ap.error(f"--module: no such module {unknown}")
    mutants = sample(mods, args.per_module, args.seed, args.pool)
    if args.only:
        mutants = [m for m in mutants if any(fnmatch.fnmatchcase(m["id"], g) for g in args.only)]
    if args.list:
        for m in mutants:
            print(f"{m['id']:44s} {m['original'][:40]!r:44s} -> {m['replacement'][:40]!r}")
        print(f"{len(mutants)} mutants in {len(mods)} modules")
        return 0

    done = json.loads(Path(args.json).read_text()) if args.json and Path(args.json).exists() \
        else {"baseline": None, "results": []}
    if (done["results"] or done["baseline"]) and done.get("tests") != args.tests:
        ap.error(f"{args.json} holds mutants run against tests {done.get('tests') or 'by import'}"
                 f", not {args.tests or 'by import'}: name another --json")
    done["tests"] = args.tests
    finished = {r["id"] for r in done["results"]}
    # only the modules drawn: the baseline runs their test files, not every module's
    tests_of = {m: args.tests or test_files_for(m) for m in sorted({m["module"] for m in mutants})}
    # a record made before tools/mutant_runners.yaml ran its modules' importers alone
    started = done["results"] or done["baseline"]
    held = done.get("tests_of") or ({m: args.tests or test_files_for(m, runners={})
                                     for m in tests_of} if started else tests_of)
    changed = [m for m, ts in tests_of.items() if held.get(m, ts) != ts]
    # a finished record still prints its table; only running more would mix the two sets
    pending = [m for m in mutants if m["id"] not in finished]
    if changed and (pending or (done["baseline"] or {}).get("outcome") is None):
        ap.error(f"{args.json} holds mutants of {changed} run against other test files than "
                 f"these modules now have: name another --json")
    if changed:  # the record's own files, for its table
        tests_of = {m: held.get(m, ts) for m, ts in tests_of.items()}
    done["tests_of"] = {**done.get("tests_of", {}), **tests_of}
    with tempfile.TemporaryDirectory(prefix="millsim-sampled-") as tmp:
        tmp = Path(tmp)
        shared = tmp / "cache-shared"
        tree = tmp / "tree"

        def fresh_tree():
            shutil.rmtree(tree, ignore_errors=True)
            tree.mkdir()
            snapshot(None, tree)

        def save():
            if args.json:
                Path(args.json).write_text(json.dumps(done, indent=1))

        if done["baseline"] is None or done["baseline"]["outcome"] is None:
            # kept file by file: an interrupted baseline (an hour over a scene's files) resumes
            base = done["baseline"] or {"outcome": None, "failing": [], "seconds": {}}
            done["baseline"] = base
            fresh_tree()
            for test in sorted({t for ts in tests_of.values() for t in ts} - set(base["seconds"])):
                outcome, base["seconds"][test], _ = run_tests(tree, [test], args.timeout, shared)
                if outcome != "survived":  # "survived" = pytest passed
                    base["failing"].append(test)
                save()
            base["outcome"] = "passed" if not base["failing"] else "some test files fail"
            save()
            print(f"baseline: {base}", flush=True)
        left_out = set(done["baseline"]["failing"])
        baseline_seconds = done["baseline"].get("seconds", {})
        for k, m in enumerate(mutants, 1):
            if m["id"] in finished:
                continue
            fresh_tree()
            # fastest first: with -x a kill ends the run, and most kills come from any file
            tests = sorted((t for t in tests_of[m["module"]] if t not in left_out),
                           key=lambda t: baseline_seconds.get(t, 0.0))
            compiled = m["file"].startswith(COMPILED)
            cache = tmp / "cache-mutant" if compiled else shared
            if not apply(m, tree):
                outcome, elapsed, detail = "invalid", 0.0, "does not compile"
            else:
                # a mutant that only runs long is no kill: its limit scales with its tests' time
                limit = args.timeout + SLOWDOWN * sum(baseline_seconds.get(t, 0.0) for t in tests)
                outcome, elapsed, detail = run_tests(tree, tests, limit, cache)
            if compiled:
                shutil.rmtree(cache, ignore_errors=True)
            done["results"].append(dict(id=m["id"], module=m["module"], operator=m["operator"],
                                        original=m["original"], replacement=m["replacement"],
                                        outcome=outcome, seconds=round(elapsed, 1),
                                        detail=detail))
            save()
            print(f"[{k}/{len(mutants)}] {m['id']:44s} {outcome:9s} {elapsed:6.0f} s  {detail}",
                  flush=True)

    report = score_table(done["results"], load_equivalent(), done["baseline"], args.tests)
    print(report)
    if args.out:
        Path(args.out).write_text(report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
