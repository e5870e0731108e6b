"""A planted mutant against the t10 verdict (issue 48, item 1): apply one mutant of
tools/mutants.yaml to a copy of src/, run a t10 set of single-particle cases with it (its own
NUMBA_CACHE_DIR), aggregate them and print the set's verdict.

    python tools/mutant_t10_set.py MUTANT_ID quick            # copper ore, 3 energies x 20 (make run's)
    python tools/mutant_t10_set.py MUTANT_ID paper_limestone  # limestone, 6 energies x 100 (paper.yaml)

Single impact, 29 mm, breakage at the end of loading, seed 1. Work tree: $TMPDIR/millsim-mutant-*.
"""
import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from mutate import apply, load_mutants

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("mutant", help="id in tools/mutants.yaml")
ap.add_argument("set", choices=("quick", "paper_limestone"))
args = ap.parse_args()
mid, which = args.mutant, args.set
root = Path(__file__).resolve().parents[1]
m = next((x for x in load_mutants() if x["id"] == mid), None)
if m is None:
    sys.exit(f"mutant_t10_set: no mutant {mid!r} in tools/mutants.yaml")
work = Path(tempfile.mkdtemp(prefix=f"millsim-mutant-{mid}-{which}-"))
for part in ("src", "config"):  # all the cases read
    subprocess.run(["cp", "-r", str(root / part), str(work / part)], check=True)
stale = apply(m, work)
if stale:
    sys.exit(f"mutant_t10_set: {mid}: {stale}")
env = dict(os.environ, PYTHONPATH=str(work / "src"), NUMBA_CACHE_DIR=str(work / "numba"))
py = sys.executable
cli = [py, "-c", "import sys; from millsim.cli import main; sys.argv[0] = 'millsim'; sys.exit(main())"]
if which == "quick":
    mat, n, energies = "copper_ore", 20, ["1.0", "2.0", "4.0"]
else:
    mat, n, energies = "limestone", 100, ["0.5", "1.0", "2.0", "3.0", "5.0", "8.0"]
outs = []
for e in energies:
    out = work / f"t10_{e}.nc"
    subprocess.run([*cli, "run", "single_particle", "--quiet", "--set", "seed=1",
                    "--set", f"material={mat}", "--set", "mode=single", "--set", "diameter=0.029",
                    "--set", f"energy_ratio={e}", "--set", f"n_particles={n}",
                    "--set", "breakage_at=end_of_loading", "--set", "dt_factor=0.5",
                    "--out", str(out)], check=True, env=env, cwd=work)
    outs.append(str(out))
agg = work / "agg.nc"
subprocess.run([*cli, "analyse", "tavares", "aggregate", *outs, "--out", str(agg)],
               check=True, env=env, cwd=work)
subprocess.run([*cli, "results-page", "single_particle", str(agg), "--out",
                str(work / "page.md")], check=True, env=env, cwd=work)
print(subprocess.run([py, "-c", "import millsim; print(millsim.provenance_hash())"], env=env,
                     capture_output=True, text=True).stdout.strip())
for line in (work / "page.md").read_text().splitlines():
    if line.startswith("| t10"):
        print(line)
