"""The one scene driver: chunk loop, progress, recording, stop test, the case file.

A scene is a declaration (:class:`~millsim.scenes.base.Scene`): its parameters, and ``build``,
which returns a :class:`Case`, one run's state. The Case says what it records (:class:`Series`,
with units and long names), how many steps to run before it looks again (``chunk``), what to do
between chunks (``after_chunk``: record, change stage), when it is done (``done``), how far it is
(``progress``) and its summaries (``finish``). :func:`drive` does the rest, the same for every
scene: it runs the compiled chunks with the requested threads, hands breakage decisions to the
case's handler, prints progress on stderr with an ETA, takes the particle snapshots, assembles the
dataset and writes the case file (atomically, with the provenance). A long case saves itself
between chunks to a checkpoint beside its output (:class:`Checkpoint`), from which the same
command resumes after an interruption with the same result.

The model is MercuryDPM's ``continueSolve`` / ``actionsAfterTimeStep`` and HOOMD-blue's loggers on
triggers, with the chunk (tens to thousands of steps, all compiled) as the time step.
"""

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from ..util import interrupt


@dataclass(frozen=True)
class Series:
    """A recorded time series: one value (scalar) per record."""

    name: str
    units: str
    long_name: str


class Case:
    """One run of a scene. Subclasses set ``sim`` (the Simulation the driver advances) and
    ``series`` (the Series they record with :meth:`record`), and implement the hooks."""

    series = ()
    time_long_name = "simulated time"
    attrs = {}  # global attributes of the case file besides the provenance

    def __init__(self):
        self._records = {s.name: [] for s in self.series}
        self._times = []

    # ---- what a scene implements -----------------------------------------------------------------
    def chunk(self) -> int:
        """Steps to run before the driver calls :meth:`after_chunk` again."""
        raise NotImplementedError

    def after_chunk(self):
        """Actions between chunks: record, change stage, move walls."""

    def done(self) -> bool:
        raise NotImplementedError

    def progress(self):
        """(fraction done in [0, 1], a short note) for the progress line."""
        return 0.0, ""

    def on_events(self, sim):
        """Handler of breakage decisions (``Simulation.pop_events``); scenes with breakage
        override it."""
        raise RuntimeError(f"{type(self).__name__}: breakage decided but the scene handles none")

    def finish(self):
        """Summaries: ({name: (dims, values, units, long_name)}, {coord: (dims, values, units,
        long_name)}, provenance extras)."""
        return {}, {}, {}

    # ---- recording -----------------------------------------------------------------------------
    def record(self, t, **values):
        """One record of every declared series at time t."""
        names = set(values)
        declared = {s.name for s in self.series}
        if names != declared:
            raise ValueError(f"record: expected {sorted(declared)}, got {sorted(names)}")
        self._times.append(t)
        for name, value in values.items():
            self._records[name].append(value)

    def recorded(self, name):
        return np.asarray(self._records[name], dtype=float)

    def recorded_times(self):
        return np.asarray(self._times, dtype=float)

    def series_dataset(self):
        """The recorded series on a ``time`` coordinate (nothing when the scene declares none)."""
        if not self.series:
            return {}, {}
        data = {s.name: ("time", self.recorded(s.name), {"units": s.units, "long_name": s.long_name})
                for s in self.series}
        # elapsed simulated time: CF's standard name, with the table's canonical unit (no
        # calendar date to count from)
        coords = {"time": ("time", self.recorded_times(),
                           {"units": "s", "long_name": self.time_long_name,
                            "standard_name": "time", "axis": "T"})}
        return data, coords


class Progress:
    """Progress on stderr at most every few seconds: fraction, rate and ETA.

    The first line comes before the first chunk (compiling the step loop can take a minute on a
    fresh machine); the ETA starts after the first chunk, so it does not count the compilation.
    """

    def __init__(self, name, every=5.0, stream=sys.stderr):
        self.name, self.every, self.stream = name, every, stream
        self.start = time.perf_counter()
        self.first = None  # (time, fraction) after the first chunk
        self.last = -math.inf

    def begin(self, n_particles):
        # (numba caches the compiled loop on disk: later runs load it in about a second)
        self._say(f"{self.name}: {n_particles} particles; compiling the step loop "
                  "(first run of this physics on this machine only, ~20-60 s)")

    def update(self, fraction, note, steps, n_particles):
        now = time.perf_counter()
        if self.first is None:
            self.first = (now, fraction)
            return
        if now - self.last < self.every:
            return
        self.last = now
        t0, f0 = self.first
        rate = (fraction - f0) / max(now - t0, 1e-9)
        eta = f"ETA {(1.0 - fraction) / rate:.0f} s" if rate > 0 else "ETA -"
        self._say(f"{self.name}: {100 * fraction:5.1f} %  step {steps}  {n_particles} particles  "
                  f"{eta}" + (f"  {note}" if note else ""))

    def finish(self, steps):
        self._say(f"{self.name}: done, {steps} steps in {time.perf_counter() - self.start:.1f} s")

    def _say(self, text):
        _say(text, self.stream)


def _say(text, stream=None):
    print(f"[millsim] {text}", file=stream or sys.stderr, flush=True)


class Checkpoint:
    """The whole state of a running case (its :class:`Case`, Simulation included, and the
    driver's counts), saved atomically to ``<out>.ckpt`` at most every ``every`` seconds of wall
    time, between chunks (0: none is saved; one already there is still resumed from).

    The state between chunks decides everything after it (the loop's results do not depend on
    where a chunk ends), so a case resumed from its checkpoint ends exactly as if uninterrupted. A
    checkpoint saved under other parameters, another scene or other code (engine hash, versions)
    is ignored with one line on stderr; the checkpoint is removed once the case file is written.
    The file is no declared output of the workflow, so Snakemake leaves it for the re-run.
    """

    def __init__(self, out, scene, values, every):
        self.path = Path(f"{out}.ckpt")
        self.key = {"scene": scene.name, "parameters": values}
        self.every = every
        self.last = time.perf_counter()

    def load(self):
        """The saved state, or None when there is none usable."""
        from ..io import read_checkpoint

        if not self.path.exists():
            return None
        try:
            return read_checkpoint(self.path, self.key)
        except ValueError as exc:
            _say(f"ignoring checkpoint {self.path}: {exc}; starting from step 0")
            return None

    def due(self):
        return self.every > 0 and time.perf_counter() - self.last >= self.every

    def save(self, state):
        from ..io import write_checkpoint

        write_checkpoint(self.path, self.key, state)
        self.last = time.perf_counter()

    def remove(self):
        self.path.unlink(missing_ok=True)


def drive(scene, values, ctx, out=None):
    """Run one case of ``scene`` with resolved ``values``; write it to ``out`` (netCDF) when
    given, resuming from its checkpoint if one is there. Returns (xarray.Dataset, provenance
    dict)."""
    t_wall = time.perf_counter()
    # Snapshot frames are written as the run goes (and their file is a declared output, which
    # Snakemake deletes before a re-run): a resumed run could not rebuild them, so such a run
    # keeps no checkpoint.
    checkpoint = Checkpoint(out, scene, values, ctx.checkpoint_every) \
        if out is not None and ctx.snapshots is None else None
    saved = checkpoint.load() if checkpoint else None
    progress = Progress(scene.name) if ctx.progress else None
    if saved:
        case, steps_total = saved["case"], saved["steps_total"]
        resumed = saved["resumed_at_steps"] + [steps_total]
        # wall time of the run so far: up to the checkpoint (the work after it is done again)
        t_wall -= saved["wall_time_s"]
        _say(f"{scene.name}: resuming from {checkpoint.path} at step {steps_total} "
             f"(t = {case.sim.time:.6g} s)")
    else:
        case, steps_total, resumed = scene.build(values), 0, []
        ctx.snapshot(case.sim)
    if progress:
        progress.begin(case.sim.n_particles)
    while not case.done():
        n = case.chunk()
        sim = case.sim
        step0, records = sim.step, len(case.recorded_times())
        sim.run(n, chunk=n, threads=ctx.threads,
                on_events=case.on_events if sim.breakage is not None else None)
        steps_total += sim.step - step0
        interrupt.check()  # a Ctrl-C swallowed on the way (util.interrupt)
        case.after_chunk()
        if len(case.recorded_times()) > records:
            ctx.snapshot(case.sim)  # a frame per record
        if progress:
            fraction, note = case.progress()
            progress.update(fraction, note, steps_total, case.sim.n_particles)
        if checkpoint and checkpoint.due() and not case.done():
            checkpoint.save({"case": case, "steps_total": steps_total, "resumed_at_steps": resumed,
                             "wall_time_s": time.perf_counter() - t_wall})
    summaries, coords, extra = case.finish()
    data, series_coords = case.series_dataset()
    data.update(summaries)
    ds = xr.Dataset(data, coords={**series_coords, **coords},
                    attrs={"title": f"millsim {scene.name} case: {scene.summary}", **case.attrs})
    if progress:
        progress.finish(steps_total)
    sim = case.sim
    provenance = {"scene": scene.name, "parameters": values, "seed": values.get("seed", 0),
                  "dt": sim.dt, "steps": steps_total, "wall_time_s": time.perf_counter() - t_wall,
                  "dt_limit": sim.dt_report.limit, "dt_binding": sim.dt_report.binding.kind,
                  "compute_seconds": sim.wall_seconds, "threads": ctx.threads or 0,
                  "resumed_at_steps": " ".join(map(str, resumed)), **extra}
    if out is not None:
        from ..io import write_case

        write_case(out, ds, provenance)
        if checkpoint:
            checkpoint.remove()
    return ds, provenance
