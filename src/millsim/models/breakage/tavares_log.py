"""The Tavares model with a stress log: every stressing event that ends, reported.

:class:`TavaresLogModel` is :class:`~millsim.models.breakage.tavares_engine.TavaresModel` whose
loop also keeps, per particle, the absorbed specific energy of each event that ended unbroken and
damaged it (at or above e_min), and reports them with the breaking events. From such a sequence
and eqs 1-6 the breakage a particle should have seen can be predicted
(``tavares_predictions.sequence_survival``; the 3D mill's ``stress_log``). Its kernels call the
plain model's and add the log around them, so the decision itself is the plain model's; its loop
is a compiled variant of its own, and a scene without the log compiles the plain one.
"""

from collections import namedtuple
from typing import NamedTuple

import numpy as np
from numba import njit

from ...engine.events import room_for
from ...engine.models import stable_identity
from .tavares_engine import E_MIN, KERNELS, TavaresBundle, TavaresModel

# Per particle, the absorbed specific energies of its ended events not yet drained
# (log_energy[i, :log_count[i]]); log_pending: some particle's log is nearly full.
TavaresLogBundle = namedtuple("TavaresLogBundle", [*TavaresBundle._fields, "log_energy",
                                                   "log_count", "log_pending"])
# Events a particle holds. Two short of it, it asks for a drain (log_pending): the next step's
# pair pass stops the chunk before its particle pass, so that the chunk ends at a step boundary
# like one that reached its length (a stop raised in the particle pass takes back the drift the
# particles had begun, which changes the last bits of the trajectory). Only where no pair slot
# is apart (no pair pass to see it) does a full log stop the chunk from the particle pass.
LOG_DEPTH = 32
# Event-table rows of this model: a seventh column says which kind of row it is.
ROW_BREAKAGE, ROW_STRESS = 0.0, 1.0

_plain_pair_apart = KERNELS.pair_apart
_plain_particle_decide = KERNELS.particle_decide
_plain_collect = KERNELS.collect


def _pair_apart_log(bs, state, k, base, o, col, step, i, j, radius, body, rsum, dist2, seen,
                    stop):
    # the plain kernel, and a drain asked for stops the chunk before this step's particle pass
    _plain_pair_apart(bs, state, k, base, o, col, step, i, j, radius, body, rsum, dist2, seen,
                      stop)
    if bs.log_pending[0] != 0:
        stop[0] = 1


def _particle_decide_log(bs, i, acc, inv_mass, material, stop):
    # the plain decision; an event that it ended unbroken, having damaged the particle, is logged
    # with the absorbed specific energy it damaged by; a full log stops the chunk for a drain
    ending = not acc[0] > 0.0 and bs.e_acc[i] > 0.0
    specific = bs.e_acc[i] * inv_mass
    _plain_particle_decide(bs, i, acc, inv_mass, material, stop)
    if ending and bs.broke[i] == 0 and specific >= bs.table[material, E_MIN]:
        n = bs.log_count[i]
        if n < bs.log_energy.shape[1]:  # (a count beyond it is refused at the drain)
            bs.log_energy[i, n] = specific
        bs.log_count[i] = n + 1
        if n + 3 >= bs.log_energy.shape[1]:
            bs.log_pending[0] = 1
        if n + 1 >= bs.log_energy.shape[1]:
            stop[0] = 1


def _collect_log(bs, events, n_events, out, col, start, nbr, inv_mass, step):
    # Rows: every logged event [particle, absorbed specific energy, step of the drain, broke = 0,
    # 0, 0, ROW_STRESS] in particle order, then each breaking particle's event in the log
    # [particle, specific energy, step, broke = 1, 0, 0, ROW_STRESS], then the plain model's
    # decisions [particle, specific energy, step, direction (3), ROW_BREAKAGE].
    broke, count = bs.broke, bs.log_count
    needed = n_events[0]
    for i in range(broke.shape[0]):
        if count[i] > bs.log_energy.shape[1]:
            raise RuntimeError("stress log: a particle ended more events than it holds")
        needed += count[i] + broke[i]
    events = room_for(events, n_events[0], needed)
    for i in range(broke.shape[0]):
        for k in range(count[i]):
            row = events[n_events[0]]
            row[0], row[1], row[2] = i, bs.log_energy[i, k], step
            row[3], row[4], row[5], row[6] = 0.0, 0.0, 0.0, ROW_STRESS
            n_events[0] += 1
        count[i] = 0
    bs.log_pending[0] = 0
    for i in range(broke.shape[0]):
        if broke[i]:
            row = events[n_events[0]]
            row[0], row[1], row[2] = i, bs.e_acc[i] * inv_mass[i], step
            row[3], row[4], row[5], row[6] = 1.0, 0.0, 0.0, ROW_STRESS
            n_events[0] += 1
    first = n_events[0]
    events = _plain_collect(bs, events, n_events, out, col, start, nbr, inv_mass, step)
    for r in range(first, n_events[0]):
        events[r, 6] = ROW_BREAKAGE
    return events


def _kernel(fn):
    return stable_identity(njit(inline="always", cache=True)(fn), f"tavares.{fn.__name__}")


LOG_KERNELS = KERNELS._replace(
    pair_apart=_kernel(_pair_apart_log), particle_decide=_kernel(_particle_decide_log),
    collect=stable_identity(njit(cache=True)(_collect_log), "tavares._collect_log"))


class StressEvent(NamedTuple):
    """A stressing event that ended: unbroken, having damaged the particle by eqs 5-6, or the one
    that broke it."""

    particle_id: int  # Simulation.particle_ids of the particle (never reused)
    specific_energy: float  # absorbed Ek'/m of the event [J/kg] (a breaking one: up to the break)
    step: int  # step at which it was drained (the event ended at or before it)
    broke: bool


class TavaresLogModel(TavaresModel):
    """:class:`TavaresModel` that reports every stressing event that ends (unbroken at or above
    e_min, or broken) as a :class:`StressEvent` (``take_stress_log``); the breaking decisions are
    the plain model's, to the bit (tests/test_stress_log.py).

    Args: as :class:`TavaresModel`.
    """

    name = "tavares_log"
    kernels = LOG_KERNELS
    event_columns = 7
    particle_fields = {**TavaresModel.particle_fields,
                       "log_energy": ((np.float64, LOG_DEPTH), 0.0), "log_count": (np.int64, 0)}

    def __init__(self, materials):
        super().__init__(materials)
        self.stress_rows = []  # drained StressEvents not yet taken
        self.log_pending = np.zeros(1, dtype=np.int64)

    def bundle(self, fields):
        return TavaresLogBundle(*super().bundle(fields), fields.log_energy, fields.log_count,
                                self.log_pending)

    def records(self, rows):
        # the log's rows are kept (by particle id) for take_stress_log
        stress = rows[:, 6] == ROW_STRESS
        ids = self.sim.particle_ids
        self.stress_rows += [StressEvent(int(ids[int(r[0])]), float(r[1]), int(r[2]), bool(r[3]))
                             for r in rows[stress]]
        return super().records(rows[~stress])

    def take_stress_log(self):
        """The ended stressing events since the last call, in the order they were drained (a
        particle's in the order they ended): those the loop handed over at its stops
        (``Simulation.pop_events``, which the on_events handler calls, moves them here), then
        those still held per particle."""
        ids, step = self.sim.particle_ids, self.sim.step
        if (self.log_count > LOG_DEPTH).any():
            raise RuntimeError("stress log: a particle ended more events than it holds")
        for i in np.flatnonzero(self.log_count):
            self.stress_rows += [StressEvent(int(ids[i]), float(e), step, False)
                                 for e in self.log_energy[i, :self.log_count[i]]]
        self.log_count[:] = 0
        self.log_pending[0] = 0
        out, self.stress_rows = self.stress_rows, []
        return out
