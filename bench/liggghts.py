"""LIGGGHTS 3.8 side of the DEM throughput benchmark (shared/reference/peers.md part B).

Two cases, both N = 10,000 spheres (r = 1 mm, rho = 2500, Hertz-Mindlin with tangential
history, E = 5e6 Pa, nu = 0.3, COR = 0.5, mu = 0.3), inputs in bench/liggghts/:

* ``box``:  jittered 20x20x25 lattice in a 44 x 44 mm open-top box, settled 25k steps at dt 1e-5.
* ``drum``: D 80 mm x L 40 mm drum (rotating STL shell, fixed end planes), ~35 % fill, settled
  15k steps at dt 1e-5, then spun up at 9.5 rad/s for 60k steps at dt 1e-5.

Each run has two stages, both run in ``workdir``:

1. untimed preparation (``in.<case>_settle``): writes ``<case>_settled.csv`` (the settled bed,
   so millsim can start the same case from the same state), for the drum also
   ``<case>_settled_spun.csv`` (the state after spin-up, i.e. at the start of the timed run),
   and ``<case>_settled.restart`` (the start of the timed stage, with contact histories).
   CSV columns: id,x,y,z,vx,vy,vz,omegax,omegay,omegaz,radius (SI units, sorted by id);
2. the timed stage (``in.<case>_bench``): 20,000 steps at dt 1e-6 from that restart.

particle-steps/s = atoms * 20000 / "Loop time" of the timed stage. One core runs plain
``liggghts``, more cores ``mpirun -np <cores> liggghts`` (box split in x/y, drum split along its
axis, where the charge is uniform). ``timed_cpu_use_per_core`` well below 1 means other
processes competed for the cores and the number is not clean.

Cache: when the restart and the settled CSV already exist in ``workdir`` the preparation is
skipped and only the timed stage runs (the same workdir may serve several core counts; the
restart reads on any number of ranks). ``--quick`` shortens the preparation (box: settle 10k
steps; drum: settle 10k + spin-up 15k steps, so the drum flow is not yet steady); its files
carry a ``_quick`` suffix so they never stand in for a full preparation. The timed stage is
always the same 20,000 steps at dt 1e-6.

Usage: python bench/liggghts.py --case box|drum --cores N [--workdir DIR] [--quick]
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import os
import re
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

TEMPLATES = Path(__file__).resolve().with_name("liggghts")
DEFAULT_OUT = Path(__file__).resolve().parent / "out" / "liggghts"
N_PARTICLES = 10_000
TIMED_STEPS = 20_000
# untimed preparation steps (dt = 1e-5 s): full and --quick
PREP_STEPS = {
    ("box", False): {"nsettle": 25_000},
    ("box", True): {"nsettle": 10_000},
    ("drum", False): {"nsettle": 15_000, "nspin": 60_000},
    ("drum", True): {"nsettle": 10_000, "nspin": 15_000},
}
LOOP_RE = re.compile(r"Loop time of ([\d.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms")


def log(msg: str) -> None:
    print(f"[liggghts-bench] {msg}", file=sys.stderr, flush=True)


def find_liggghts() -> tuple[str, str]:
    """Return (path of the liggghts binary, "found" or "installed"); apt-installs it as root."""
    binary = shutil.which("liggghts")
    if binary:
        log(f"using LIGGGHTS found at {binary}")
        return binary, "found"
    if os.geteuid() != 0:
        raise RuntimeError("liggghts not on PATH; install it with: apt-get install -y liggghts")
    log("liggghts not found; installing the Debian package with apt-get")
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    subprocess.run(["apt-get", "update"], check=True, env=env)
    subprocess.run(["apt-get", "install", "-y", "liggghts"], check=True, env=env)
    binary = shutil.which("liggghts")
    if not binary:
        raise RuntimeError("apt-get install liggghts succeeded but liggghts is still not on PATH")
    log(f"installed LIGGGHTS at {binary}")
    return binary, "installed"


def liggghts_version(binary: str) -> str:
    out = subprocess.run([binary, "-h"], capture_output=True, text=True).stdout
    m = re.search(r"Version (\S+ [\d.]+)", out)
    return m.group(1) if m else "unknown"


def write_drum_stl(path: Path, radius: float = 0.04, length: float = 0.04,
                   centre_xz: tuple[float, float] = (0.04, 0.04),
                   n_around: int = 120, n_along: int = 4) -> int:
    """Write the drum shell (axis = y, from y = 0 to length) as ASCII STL; return the facet count.

    Normals point inwards (towards the particles)."""
    xc, zc = centre_xz

    def vertex(i: int, j: int) -> tuple[float, float, float]:
        a = 2.0 * math.pi * i / n_around
        return (xc + radius * math.cos(a), length * j / n_along, zc + radius * math.sin(a))

    lines = ["solid drum"]
    for j in range(n_along):
        for i in range(n_around):
            a, b, c, d = vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1), vertex(i, j + 1)
            for tri in ((a, b, c), (a, c, d)):
                u = [tri[1][k] - tri[0][k] for k in range(3)]
                v = [tri[2][k] - tri[0][k] for k in range(3)]
                n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
                norm = math.sqrt(sum(x * x for x in n))
                lines.append("facet normal " + " ".join(f"{x / norm:g}" for x in n))
                lines.append(" outer loop")
                lines.extend("  vertex " + " ".join(f"{c:.9e}" for c in p) for p in tri)
                lines.append(" endloop")
                lines.append("endfacet")
    lines.append("endsolid drum")
    path.write_text("\n".join(lines) + "\n")
    return 2 * n_around * n_along


def dump_to_csv(dump: Path, out: Path) -> Path:
    """Replace a LIGGGHTS 'dump custom' snapshot by a plain CSV with a header row."""
    lines = dump.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
    columns = lines[start].split()[2:]
    with out.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        writer.writerows(line.split() for line in lines[start + 1:] if line.strip())
    dump.unlink()
    return out


def _children_cpu_s() -> float:
    """CPU seconds of all finished child processes (and their children) of this process."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _run_stage(binary: str, cores: int, template: str, workdir: Path, variables: dict) -> tuple[str, float, float]:
    """Run one LIGGGHTS input in workdir; return (screen output, wall seconds, CPU use per core).

    CPU use per core well below 1 means other processes competed for the cores."""
    name = template.removeprefix("in.")
    # stdbuf: the Debian build loses its ERROR text on MPI_Abort when stdout is block-buffered
    cmd = ["stdbuf", "-oL", binary, "-in", str(TEMPLATES / template), "-log", f"log.{name}", "-nocite",
           "-var", "tpl", str(TEMPLATES)]
    for key, value in variables.items():
        cmd += ["-var", key, str(value)]
    if cores > 1:
        mpirun = shutil.which("mpirun")
        if not mpirun:
            raise RuntimeError("mpirun not found (Debian package openmpi-bin)")
        cmd = [mpirun, "--allow-run-as-root", "--oversubscribe", "-np", str(cores)] + cmd
    log(f"running {template} on {cores} core(s) in {workdir}")
    cpu0, t0 = _children_cpu_s(), time.perf_counter()
    proc = subprocess.run(cmd, cwd=workdir, env=dict(os.environ, OMP_NUM_THREADS="1"),
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wall = time.perf_counter() - t0
    cpu_use = (_children_cpu_s() - cpu0) / (wall * cores)
    (workdir / f"{name}.stdout").write_text(proc.stdout)
    if proc.returncode != 0 or not LOOP_RE.search(proc.stdout):
        tail = "\n".join(proc.stdout.splitlines()[-30:])
        raise RuntimeError(f"LIGGGHTS {template} failed (rc {proc.returncode}) in {workdir}:\n{tail}")
    return proc.stdout, wall, cpu_use


def _timed_stats(text: str) -> dict:
    """Loop time, atoms and steps of the last run in text, plus contact and neighbour statistics."""
    loop_time, procs, steps, atoms = LOOP_RE.findall(text)[-1]
    head, tail = text.rsplit("Loop time of", 1)
    # thermo rows of the timed run: step atoms ke c_rke c_cnave cpu
    rows = [r.split() for r in head.splitlines() if re.fullmatch(r"(\s+[\d.eE+-]+){6}\s*", r)]
    builds = re.search(r"Neighbor list builds = (\d+)", tail)
    return {
        "loop_time_s": float(loop_time),
        "procs": int(procs),
        "steps": int(steps),
        "n_particles": int(atoms),
        "contacts_per_particle": sum(float(r[4]) for r in rows) / len(rows) if rows else None,
        "neighbor_list_builds": int(builds.group(1)) if builds else None,
    }


def run_liggghts(case: str, cores: int, workdir: Path, quick: bool = False,
                 prep_from: Path | None = None) -> dict:
    """Run the LIGGGHTS benchmark for case "box" or "drum" on `cores` MPI ranks; see module doc.

    prep_from: a directory holding the prepared state of an earlier run (any rank count: a
    restart file does not depend on it), copied here instead of settling again."""
    if (case, quick) not in PREP_STEPS:
        raise ValueError(f"unknown case {case!r}")
    binary, binary_source = find_liggghts()
    workdir = Path(workdir).resolve()
    workdir.mkdir(parents=True, exist_ok=True)
    state = f"{case}_settled" + ("_quick" if quick else "")
    restart = workdir / f"{state}.restart"
    settled_csv = workdir / f"{state}.csv"
    spun_csv = workdir / f"{state}_spun.csv"
    if case == "drum":
        write_drum_stl(workdir / "drum_shell.stl")

    if prep_from is not None and Path(prep_from).resolve() != workdir:
        for f in Path(prep_from).glob(f"{state}*"):
            if f.suffix in (".restart", ".csv") and not (workdir / f.name).exists():
                shutil.copy2(f, workdir / f.name)
    prep_cached = restart.exists() and settled_csv.exists() and (case == "box" or spun_csv.exists())
    prep_wall = None
    if prep_cached:
        log(f"reusing the prepared state {restart}")
    else:
        _, prep_wall, _ = _run_stage(binary, cores, f"in.{case}_settle", workdir,
                                     {"state": state, **PREP_STEPS[case, quick]})
        dump_to_csv(workdir / f"{state}.dump", settled_csv)
        if case == "drum":
            dump_to_csv(workdir / f"{state}_spun.dump", spun_csv)

    text, timed_wall, cpu_use = _run_stage(binary, cores, f"in.{case}_bench", workdir, {"state": state})
    stats = _timed_stats(text)
    if cpu_use < 0.9:
        log(f"timed stage got only {cpu_use:.0%} of {cores} core(s): other load; rerun for a clean number")
    if stats["steps"] != TIMED_STEPS or stats["n_particles"] != N_PARTICLES:
        raise RuntimeError(f"unexpected timed run: {stats}")
    return {
        "case": case,
        "cores": cores,
        "quick": quick,
        "liggghts_psps": stats["n_particles"] * stats["steps"] / stats["loop_time_s"],
        **stats,
        "timed_wall_s": timed_wall,
        "timed_cpu_use_per_core": cpu_use,
        "prep_wall_s": prep_wall,
        "prep_cached": prep_cached,
        "prep_steps": PREP_STEPS[case, quick],
        "settled_state_path": str(settled_csv),
        "spun_state_path": str(spun_csv) if case == "drum" else None,
        "restart_path": str(restart),
        "workdir": str(workdir),
        "liggghts_version": liggghts_version(binary),
        "binary": binary,
        "binary_source": binary_source,
    }


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", choices=["box", "drum"], required=True)
    ap.add_argument("--cores", type=int, default=1, help="MPI ranks")
    ap.add_argument("--workdir", type=Path, help="default: bench/out/liggghts/<case>_<cores>")
    ap.add_argument("--quick", action="store_true", help="shorter untimed settle/spin-up (see module doc)")
    args = ap.parse_args(argv)
    workdir = args.workdir or DEFAULT_OUT / f"{args.case}_{args.cores}"
    print(json.dumps(run_liggghts(args.case, args.cores, workdir, args.quick), indent=2))


if __name__ == "__main__":
    main()
