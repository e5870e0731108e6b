"""LIGGGHTS 3.8 single-contact reference: head-on Hertz-Mindlin collisions, pair and wall.

Regenerates ``config/reference/liggghts_collision.csv`` (provenance: config/reference/SOURCES.md)
with one command, from the repository root:

    python bench/liggghts_collision/run.py

Each row is one LIGGGHTS run of ``in.collision`` (this directory) in a temporary work dir:
``pair_style gran model hertz tangential history limitForce off|on`` (pair case: two identical
spheres, atoms at x = -(r + gap/2) and +(r + gap/2), velocities +0.5 and -0.5 m/s) or
``fix wall/gran model hertz tangential history primitive type 1 xplane 0.0 limitForce off|on``
(wall case: one sphere at x = r + gap, velocity -1 m/s), gap = 1e-6 m between surfaces, SI units,
no gravity, ``fix nve/sphere``. Material: r = 1 mm, rho = 2500 kg/m3, E = 5e6 Pa, nu = 0.3,
friction 0.3 (irrelevant head-on), coefficientRestitution e_input in E_INPUTS; the wall is the
same material (type 1).

Per run the thermo output (``%.17g``) gives the final positions and x velocities. The run is
long enough that the contact has ended: the last FREE_LINES thermo lines must show zero force
and identical velocities (free flight), otherwise the script stops with an error.

* ``e_measured`` = rebound relative normal speed / impact relative normal speed (1 m/s):
  pair ``(vx2 - vx1) / 1``, wall ``vx1 / 1``, printed with 10 significant digits;
* ``contact_duration`` = time between the instants at which the free-flight straight lines
  before and after the collision reach zero overlap: t_start = gap / v_impact,
  t_end = t_final - gap_final / v_rebound (gap = surface separation, from the final positions).
  It converges to the continuous contact time as dt -> 0 (differences between time steps show
  its discretisation error).

Convergence in dt: LIGGGHTS' velocity-Verlet step (fix nve/sphere) evaluates the damping force
with the half-step velocity, and the contact ends between two steps, so e_measured converges only
to first order in dt (error ~ 1e-4 relative at dt = 1e-8 for e_input = 0.05). Each
(case, limitForce, e_input) group therefore starts at dt = 1e-8 and halves dt (at least down to
1.25e-9) until e_measured agrees with the run at twice the time step to >= 6 significant digits
for two halvings in a row; ``digits_vs_2dt`` records that agreement per row, and the finest row of
each group carries ``reference = 1``.

Needs only the Python standard library and ``liggghts`` on PATH (Debian package ``liggghts``).
Run time: a few minutes on 2 cores (the low-e groups need dt down to a few 1e-11 s).

Usage: python bench/liggghts_collision/run.py [--out PATH] [--jobs N]
"""
from __future__ import annotations

import argparse
import concurrent.futures as cf
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
DEFAULT_OUT = ROOT / "config" / "reference" / "liggghts_collision.csv"

RADIUS = 1.0e-3          # m (LIGGGHTS input sets diameter 0.002)
GAP = 1.0e-6             # m, initial surface separation
V_IMPACT = 1.0           # m/s, relative normal impact speed
T_RUN = 1.2e-3           # s simulated per run (contact ~3e-4 s; up to ~5.5e-4 s unclipped at low e)
N_THERMO_LINES = 60      # thermo lines per run
FREE_LINES = 10          # last thermo lines that must show free flight
# LIGGGHTS rejects coefficientRestitution <= 0.05 (global_properties.cpp createCoeffRest:
# "0.05 < coefficientRestitution <= 1 required"), so the lowest value is 0.05 + 1e-10.
E_INPUTS = (0.0500000001, 0.2, 0.5, 0.8, 0.95)
CASES = ("pair", "wall")
LIMITS = ("off", "on")
DT0 = 1.0e-8             # s, coarsest time step; each further level halves it
MIN_LEVELS = 4           # always run dt = 1e-8, 5e-9, 2.5e-9, 1.25e-9
TARGET_DIGITS = 6        # stop when e_measured agrees with the 2*dt run to >= 6 digits ...
CONSECUTIVE = 2          # ... for the last 2 halvings in a row (guards against chance agreement)
MAX_LEVELS = 13          # finest allowed dt = 1e-8 / 2**12 = 2.4e-12 s

VERSION_RE = re.compile(r"LIGGGHTS \(Version ([^)]*)\)")


def log(msg: str) -> None:
    print(f"[liggghts-collision] {msg}", file=sys.stderr, flush=True)


def liggghts_cmd() -> list[str]:
    binary = shutil.which("liggghts")
    if not binary:
        raise SystemExit("liggghts not on PATH; install it with: apt-get install -y liggghts")
    # The Debian binary loses its ERROR text on MPI_Abort unless stdout is unbuffered.
    stdbuf = shutil.which("stdbuf")
    return ([stdbuf, "-o0"] if stdbuf else []) + [binary]


def run_one(cmd: list[str], workdir: Path, case: str, limit: str, e: float, dt: float,
            t_run: float) -> dict:
    nsteps = int(round(t_run / dt))
    nthermo = max(1, nsteps // N_THERMO_LINES)
    nsteps = nthermo * N_THERMO_LINES
    if case == "pair":
        half = RADIUS + 0.5 * GAP
        pos = {"px1": -half, "pv1": 0.5 * V_IMPACT, "px2": half, "pv2": -0.5 * V_IMPACT}
        extra = "v_x2 v_vx2"
    else:
        pos = {"px1": RADIUS + GAP, "pv1": -V_IMPACT, "px2": 0.0, "pv2": 0.0}
        extra = ""
    var = {"tpl": str(HERE), "case": case, "limit": limit, "e": repr(e), "dt": repr(dt),
           "nsteps": str(nsteps), "nthermo": str(nthermo), "thermo_extra": extra}
    var.update({k: repr(v) for k, v in pos.items()})
    args = cmd + ["-nocite", "-echo", "none", "-log", "none", "-in", str(HERE / "in.collision")]
    for k, v in var.items():
        args += ["-var", k, v]
    rundir = workdir / f"{case}_{limit}_{e!r}_{dt!r}"
    rundir.mkdir()
    proc = subprocess.run(args, cwd=rundir, capture_output=True, text=True)
    out = proc.stdout + proc.stderr
    if proc.returncode != 0 or "ERROR" in out:
        raise RuntimeError(f"liggghts failed ({case} {limit} e={e} dt={dt}):\n{out[-3000:]}")
    version = VERSION_RE.search(out)
    # thermo lines: step x1 vx1 fx1 [x2 vx2]
    ncol = 6 if case == "pair" else 4
    rows = []
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == ncol and parts[0].isdigit():
            try:
                rows.append([int(parts[0])] + [float(p) for p in parts[1:]])
            except ValueError:
                continue
    if not rows or rows[-1][0] != nsteps:
        raise RuntimeError(f"no final thermo line ({case} {limit} e={e} dt={dt}):\n{out[-3000:]}")
    tail = rows[-FREE_LINES:]
    for r in tail:
        if r[3] != 0.0 or r[2] != tail[0][2] or (case == "pair" and r[5] != tail[0][5]):
            raise RuntimeError(f"contact not over by the end of the run ({case} {limit} e={e} "
                               f"dt={dt}); increase T_RUN")
    step, x1, vx1 = rows[-1][0], rows[-1][1], rows[-1][2]
    t_final = step * dt
    if case == "pair":
        x2, vx2 = rows[-1][4], rows[-1][5]
        v_reb = vx2 - vx1
        gap_final = x2 - x1 - 2.0 * RADIUS
    else:
        v_reb = vx1
        gap_final = x1 - RADIUS
    t_end = t_final - gap_final / v_reb
    t_start = GAP / V_IMPACT
    return {"case": case, "limitForce": limit, "e_input": e, "dt": dt, "nsteps": nsteps,
            "e_measured": v_reb / V_IMPACT, "contact_duration": t_end - t_start,
            "version": version.group(1) if version else "?"}


def agree_digits(a: float, b: float) -> int:
    """Number of significant digits in which a and b agree (relative difference)."""
    if a == b:
        return 16
    return max(0, int(math.floor(-math.log10(abs(a - b) / abs(b)))))


def run_group(cmd: list[str], workdir: Path, case: str, limit: str, e: float) -> list[dict]:
    """Halve dt from DT0 until e_measured is converged (see module docstring)."""
    out: list[dict] = []
    t_run = T_RUN
    for level in range(MAX_LEVELS):
        dt = DT0 / 2**level
        r = run_one(cmd, workdir, case, limit, e, dt, t_run)
        r["digits_vs_2dt"] = agree_digits(r["e_measured"], out[-1]["e_measured"]) if out else None
        out.append(r)
        # next run: 1.5 x the time at which this one's contact ended (cuts the free flight)
        t_run = min(T_RUN, 1.5 * (GAP / V_IMPACT + r["contact_duration"]))
        if (level + 1 >= MIN_LEVELS and
                all(x["digits_vs_2dt"] >= TARGET_DIGITS for x in out[-CONSECUTIVE:])):
            break
    else:
        raise RuntimeError(f"{case} {limit} e={e}: not converged to {TARGET_DIGITS} digits "
                           f"at dt = {out[-1]['dt']!r}")
    log(f"{case} limitForce {limit} e_input {e!r}: e_measured {out[-1]['e_measured']:.10g} "
        f"at dt {out[-1]['dt']!r} ({len(out)} levels)")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    a = ap.parse_args()
    cmd = liggghts_cmd()
    t0 = time.time()
    # slowest groups (low e: long contacts, many levels) first
    groups = sorted(((c, lim, e) for c in CASES for lim in LIMITS for e in E_INPUTS),
                    key=lambda g: (g[2], g[1] == "on", g[0] == "pair"))
    with tempfile.TemporaryDirectory(prefix="liggghts_collision_") as tmp, \
            cf.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        futs = {g: pool.submit(run_group, cmd, Path(tmp), *g) for g in groups}
        results = {g: f.result() for g, f in futs.items()}
    nruns = sum(len(v) for v in results.values())
    log(f"{nruns} runs in {time.time() - t0:.1f} s")
    versions = sorted({r["version"] for v in results.values() for r in v})

    lines = [
        "# LIGGGHTS single head-on collision reference (Hertz-Mindlin, tangential history).",
        "# Provenance, set-up and definitions: config/reference/SOURCES.md; regenerate with",
        "#   python bench/liggghts_collision/run.py",
        f"# LIGGGHTS version: {'; '.join(versions)} (Debian package liggghts)",
        "# r = 1 mm, rho = 2500 kg/m3, E = 5e6 Pa, nu = 0.3, mu = 0.3, impact speed 1 m/s "
        "(pair: 0.5 m/s each), no gravity",
        "# e_measured = rebound / impact relative normal speed; contact_duration in s "
        "(free-flight extrapolated); digits_vs_2dt = significant digits of e_measured agreeing "
        "with the row at twice dt; reference = 1 on the finest (converged) row of each group",
        "case,limitForce,e_input,dt,nsteps,e_measured,contact_duration,digits_vs_2dt,reference",
    ]
    for c in CASES:
        for lim in LIMITS:
            for e in E_INPUTS:
                rows = results[(c, lim, e)]
                for i, r in enumerate(rows):
                    dig = "" if r["digits_vs_2dt"] is None else str(r["digits_vs_2dt"])
                    ref = int(i == len(rows) - 1)
                    lines.append(f"{c},{lim},{e!r},{r['dt']!r},{r['nsteps']},"
                                 f"{r['e_measured']:.10g},{r['contact_duration']:.8g},{dig},{ref}")
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text("\n".join(lines) + "\n")
    log(f"wrote {a.out}")


if __name__ == "__main__":
    main()
