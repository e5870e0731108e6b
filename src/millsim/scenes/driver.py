"""The one scene driver: chunk loop, progress, recording, stop test, the case file.

A scene is a declaration (:class:`~millsim.scenes.base.Scene`): its parameters, and ``build``,
which returns a :class:`Case`, one run's state. The Case declares what it records (``series``, a
table of :class:`Series`) and its summaries (``outputs``, a table of :class:`Output`: name, dims,
units, long name, how computed), once each; it says how many steps to run before it looks again
(``chunk``), what to do between chunks (``after_chunk``: record, change stage), when it is done
(``done``), how far it is (``progress``) and the values of its summaries (``finish``).
:func:`drive` does the rest, the same for every scene: it runs the compiled chunks with the
requested threads, hands breakage decisions to the case's handler, prints progress on stderr with
an ETA, takes the particle snapshots, assembles the dataset from the tables and the values (every
declared output returned, nothing undeclared) and writes the case file (atomically, with the
provenance). A long case saves itself between chunks to a checkpoint beside its output
(:class:`Checkpoint`), from which the same command resumes after an interruption with the same
result.

The model is MercuryDPM's ``continueSolve`` / ``actionsAfterTimeStep`` and HOOMD-blue's loggers on
triggers, with the chunk (tens to thousands of steps, all compiled) as the time step.
"""

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
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


@dataclass(frozen=True)
class Output:
    """A summary variable (or coordinate) of the case file, declared once in the scene's table
    (``Case.outputs``): its ``units`` and ``long_name`` attributes come from here, ``finish``
    returns only its value."""

    name: str
    dims: tuple  # dimension names; () for a scalar
    units: str
    long_name: str
    how: str = ""  # how it is computed, where the long name does not say
    when: Callable | None = None  # when(parameter values): written only where this holds
    coord: bool = False  # a coordinate of the dataset
    cf: dict = field(default_factory=dict)  # further CF attributes: axis, positive, bounds, ...

    def attrs(self):
        return {"units": self.units, "long_name": self.long_name, **self.cf}

    def describe(self):
        how = f"; {self.how}" if self.how else ""
        when = " (with some parameters only)" if self.when else ""
        dims = f"({', '.join(self.dims)})" if self.dims else ""
        return f"{self.name}{dims} [{self.units}]: {self.long_name}{how}{when}"


class Case:
    """One run of a scene. Subclasses set ``sim`` (the Simulation the driver advances),
    ``series`` (the Series they record with :meth:`record`) and ``outputs`` (the Outputs whose
    values :meth:`finish` returns), and implement the hooks."""

    series = ()
    outputs = ()
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
        """(fraction done in [0, 1], a short note) for the progress line; the fraction is None
        where the case cannot tell (it ends on an event)."""
        return None, ""

    def on_events(self, sim):
        """Handler of breakage decisions (``Simulation.pop_events``); scenes with breakage
        override it."""
        raise RuntimeError(f"{type(self).__name__}: breakage decided but the scene handles none")

    def finish(self):
        """The values of the summaries: {name: value or array} for every declared output that
        applies (``outputs``)."""
        return {}

    def provenance(self):
        """What the case adds to the provenance attributes of its case file."""
        return {}

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
    """Progress on stderr at most every few seconds: fraction, rate and ETA where the case knows
    how far it is, elapsed wall time and simulated time where it does not (a case that ends on an
    event: a bed at rest, a ball clear of it).

    numba compiles the step loop of a physics once and keeps it in the kernel cache; a line says
    so when a compilation actually starts (numba's compile event) during the build or the first
    chunk, which can take a minute on a fresh machine. The ETA counts from the end of the first
    chunk, so it does not count the compilation.
    """

    def __init__(self, name, every=5.0, stream=None):
        # None: sys.stderr as it is when a line is written (pytest's capture replaces it)
        self.name, self.every, self.stream = name, every, stream
        self.start = time.perf_counter()
        self.first = None  # time after the first chunk
        self.origin = None  # (time, fraction) at the first known fraction after the first chunk
        self.last = -math.inf
        self.compiling = False
        self._watch = _watch_compiles(self)

    def begin(self, n_particles):
        self._say(f"{self.name}: {n_particles} particles")

    def compile_started(self):
        if not self.compiling:
            self.compiling = True
            self._say(f"{self.name}: compiling the step loop (first run of this physics on this "
                      "machine or of this code version, ~20-60 s; later runs load it from the "
                      "kernel cache)")

    def update(self, fraction, note, steps, n_particles, sim_time=None):
        """``fraction``: done in [0, 1], or None where the case cannot tell (it ends on an
        event); 0 counts as not known yet."""
        now = time.perf_counter()
        known = fraction is not None and fraction > 0
        if self.first is None:
            self.first = now
            self._watch()  # a compilation after this is no longer the first chunk's
            if known:
                self.origin = (now, fraction)
            return
        if known and self.origin is None:
            self.origin = (now, fraction)
        if now - self.last < self.every:
            return
        self.last = now
        elapsed = f"{now - self.start:.0f} s elapsed"
        simulated = "" if sim_time is None else f"  t = {sim_time:.4g} s simulated"
        if known:
            t0, f0 = self.origin
            rate = (fraction - f0) / max(now - t0, 1e-9)
            eta = f"ETA {(1.0 - fraction) / rate:.0f} s" if rate > 0 else elapsed
            line = f"{100 * fraction:5.1f} %  step {steps}  {n_particles} particles  {eta}"
        else:
            line = f"step {steps}  {n_particles} particles{simulated}  {elapsed}"
        self._say(f"{self.name}: {line}" + (f"  {note}" if note else ""))

    def finish(self, steps):
        self._watch()
        self._say(f"{self.name}: done, {steps} steps in {time.perf_counter() - self.start:.1f} s")

    def _say(self, text):
        _say(text, self.stream)


def _watch_compiles(progress):
    """Tell ``progress`` when numba starts a compilation; returns the function that stops
    watching (also called once ``progress`` is garbage: a run that raised leaves no watcher)."""
    import weakref

    from numba.core import event

    class Notice(event.Listener):
        def on_start(self, _):
            target = ref()
            if target is not None:
                target.compile_started()

        def on_end(self, _):
            pass

    ref = weakref.ref(progress)
    notice = Notice()
    event.register("numba:compile", notice)
    return weakref.finalize(progress, event.unregister, "numba:compile", notice)


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
        # a scene from outside millsim (--scene-module, a plugin) has its Case in its own package
        top = getattr(scene.build, "__module__", "millsim").split(".")[0]
        self.packages = () if top == "millsim" else (top,)
        self.every = every
        self.last = time.perf_counter()

    def load(self):
        """The saved state, or None when there is none usable."""
        from ..io import read_checkpoint

        if not self.path.exists():
            return None
        try:
            return read_checkpoint(self.path, self.key, self.packages)
        except ValueError as exc:
            _say(f"ignoring checkpoint {self.path}: {exc}; starting from step 0")
            return None

    def due(self):
        return self.every > 0 and time.perf_counter() - self.last >= self.every

    def save(self, state):
        """Save ``state``; a save that fails for the filesystem's sake (disk full, quota,
        permission) leaves no file, says so in one line and the run goes on: the checkpoint is
        a convenience, the case file what matters. The next try comes at the next due time."""
        from ..io import write_checkpoint

        try:
            write_checkpoint(self.path, self.key, state, self.packages)
        except (OSError, ValueError) as exc:  # ValueError: check_writable's refusal
            cause = str(exc) if str(exc).startswith("cannot write") else \
                f"cannot write {self.path}: {getattr(exc, 'strerror', None) or exc}"
            _say(f"checkpoint not saved: {cause}; the run goes on without it, next try in "
                 f"{self.every:g} s")
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
        ctx.check_snapshot_space(values)  # the first frame's size times the frames to come
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
            progress.update(fraction, note, steps_total, case.sim.n_particles, case.sim.time)
        if checkpoint and checkpoint.due() and not case.done():
            checkpoint.save({"case": case, "steps_total": steps_total, "resumed_at_steps": resumed,
                             "wall_time_s": time.perf_counter() - t_wall})
    summaries, coords = summary_variables(scene.name, case.outputs, values, case.finish())
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
                  "resumed_at_steps": " ".join(map(str, resumed)), **case.provenance()}
    if out is not None:
        from ..io import write_case

        write_case(out, ds, provenance)
        if checkpoint:
            checkpoint.remove()
    return ds, provenance


def summary_variables(scene, outputs, values, returned):
    """({name: (dims, value, attrs)} of the data variables, the same of the coordinates) from the
    declared ``outputs`` of ``scene`` and the values ``returned`` by its ``finish``: every output
    that applies to the parameter ``values`` returned, nothing else."""
    wanted = [o for o in outputs if o.when is None or o.when(values)]
    names = {o.name for o in wanted}
    for name in returned:
        if name not in names:
            why = "does not apply to these parameters" if any(
                o.name == name for o in outputs) else "is not declared in its outputs"
            raise ValueError(f"scene {scene}: finish returned {name!r}, which {why}")
    for o in wanted:
        if o.name not in returned:
            raise ValueError(f"scene {scene}: finish did not return the declared output {o.name!r}")
    data = {o.name: (o.dims, returned[o.name], o.attrs()) for o in wanted if not o.coord}
    coords = {o.name: (o.dims, returned[o.name], o.attrs()) for o in wanted if o.coord}
    return data, coords
