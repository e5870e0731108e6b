"""The breakage rate of ``ballmill3d`` predicted from its stress log (Tavares et al. 2021, eqs
1-6), beside the breakage counted in the mill (issue 52 item 3; docs/ballmill3d.md).

With ``stress_log: true`` the engine reports every stressing event of the ore that ends: its
absorbed specific energy Ek'/m, and whether it broke the particle (tavares_log.TavaresLogModel).
:class:`StressBook` keeps each breakable ore particle's sequence (by particle id, from the drum's
start, when every ore particle gets a fresh fracture energy; progeny start fresh when they are
made). Over the measured interval [t_w, t_end] the expected number of breakage events of a
particle is the compensator of its breakage counting process,

    Lambda = ln S(history up to t_w) - ln S(history up to t_end),

S the probability that a fresh particle of its size survives its sequence (eqs 1-3 for the
fracture energy, eqs 5-6 between events; ``tavares_predictions.sequence_survival``); an event in
progress at t_w or t_end enters with its energy so far. The counted events minus the summed
Lambda is a martingale of mean zero (Aalen 1978), whatever the mill does to the energies, because
every energy is known before the particle faces it. Why a compensator and not the sum of each
particle's probability of having broken by the end: a particle that broke leaves no energies
after its break, and that sum undercounts (for two equal events of probability h each it expects
2h - 2h^2 + h^3 instead of 2h - h^2). Why ln S and not 1 - S per event: the engine breaks a
particle as soon as its absorbed energy reaches E (``first_reach``), in the middle of an event,
so the breaking event's logged energy is only what it had absorbed up to the break; summed step
by step the hazard of an event is -ln S(event) / S(before) to first order in a step's share of it.
Its variance is the same sum of Lambda (continuous compensator), so z = (counted - predicted) /
sqrt(predicted) and the two-sided p-value of the normal law. An event that breaks every fracture
energy of the distribution (above its truncation Emax) counts 1, exactly.
"""

import math

import numpy as np

from ..models.breakage import progeny_families
from ..models.breakage.tavares_predictions import sequence_survival


class StressBook:
    """Per breakable ore particle (by id): its size and its logged event energies; the counts at
    the start of the measured interval. ``ore``: material index; ``mat``: its TavaresMaterial."""

    def __init__(self, mat, ore, d_min, policy="standard"):
        self.mat, self.ore, self.d_min, self.policy = mat, ore, d_min, policy
        self.size, self.energies = {}, {}
        self.dead = {}  # ids of the broken (dicts, not sets: a checkpoint stores dicts)
        self.start = None  # {id: (events before t_w, energy of the event in progress at t_w)}
        self.dead_at_open = {}
        self.end = {}  # {id: energy of the event in progress at t_end}
        self.seen = -1  # largest particle id registered

    def register(self, sim):
        """Book the breakable ore particles made since the last call (fresh fracture energy)."""
        p, ids = sim.particles, sim.particle_ids
        new = np.flatnonzero((ids > self.seen) & (p.material == self.ore) & (p.body < 0)
                             & np.isfinite(sim.breakage.e_frac))
        for i in new:
            d = 2.0 * float(p.radius[i])
            if progeny_families.is_breakable(self.mat, d, self.d_min, self.policy):
                self.size[int(ids[i])] = d
                self.energies[int(ids[i])] = []
        if len(ids):
            self.seen = max(self.seen, int(ids.max()))

    def add(self, events):
        """Append drained StressEvents to their particles' sequences."""
        for ev in events:
            seq = self.energies.get(ev.particle_id)
            if seq is not None:
                seq.append(ev.specific_energy)
                if ev.broke:
                    self.dead[ev.particle_id] = True

    def _in_progress(self, sim):
        ids, e_acc, inv_mass = sim.particle_ids, sim.breakage.e_acc, sim.particles.inv_mass
        return {int(ids[i]): float(e_acc[i] * inv_mass[i]) for i in range(len(ids))
                if int(ids[i]) in self.size}

    def open(self, sim):
        """The start of the measured interval: drain the log, note each living particle's place."""
        self.add(sim.breakage.take_stress_log())
        now = self._in_progress(sim)
        self.start = {pid: (len(seq), now.get(pid, 0.0)) for pid, seq in self.energies.items()
                      if pid not in self.dead}
        self.dead_at_open = dict(self.dead)

    def close(self, sim):
        """The end of the measured interval: drain the log, note the events in progress."""
        self.add(sim.breakage.take_stress_log())
        self.end = self._in_progress(sim)

    def compensators(self):
        """[(diameter, Lambda)] of the particles at risk in the measured interval."""
        out = []
        for pid, seq in self.energies.items():
            if pid in self.dead_at_open:
                continue
            before, partial = self.start.get(pid, (0, 0.0))  # absent: made inside the interval
            out.append((self.size[pid], self._compensator(pid, seq, before, partial)))
        return out

    def _compensator(self, pid, seq, before, partial):
        d, mat = self.size[pid], self.mat
        head = np.array(seq[:before] + ([partial] if partial > 0 else []))
        end = self.end.get(pid, 0.0)
        full = np.array(seq + ([end] if end > 0 else []))
        s0 = sequence_survival(mat, d, head, [len(head)])[0]
        s1, s_prev = sequence_survival(mat, d, full, [len(full), max(len(full) - 1, 0)])
        if s1 > 0:
            return math.log(s0) - math.log(s1)
        # the last event breaks every fracture energy of the distribution: its hazard is 1
        return math.log(s0) - math.log(s_prev) + 1.0


def compare(book, event_times, event_diameters, t_w, lower_edges):
    """Predicted (summed Lambda) and counted breakage events per size class over [t_w, end],
    and the z-score and two-sided p-value of their totals (module text)."""
    lam = book.compensators()
    edges = -np.asarray(lower_edges)
    k = len(lower_edges)
    predicted = np.zeros(k)
    if lam:
        d, val = np.array(lam).T
        cls = np.searchsorted(edges, -d, side="right")
        predicted = np.bincount(cls, weights=val, minlength=k + 1)[:k]
    t = np.asarray(event_times, dtype=float)
    dd = np.asarray(event_diameters, dtype=float)[t > t_w]  # t_w: the interval opened after them
    counted = np.bincount(np.searchsorted(edges, -dd, side="right"), minlength=k + 1)[:k]
    total_p, total_c = float(predicted.sum()), int(counted.sum())
    z = (total_c - total_p) / math.sqrt(total_p) if total_p > 0 else math.nan
    p_value = math.erfc(abs(z) / math.sqrt(2.0)) if total_p > 0 else math.nan
    return predicted, counted.astype(float), z, p_value
