"""The Tavares model's part in the step loop (Tavares et al. 2021, sections 2.1-2.3).

Per contact, the loading work (elastic + damping) done while the overlap grows, trapezoidal in the
overlap, is split between the two bodies by eq 4 (each takes the other's stiffness over the sum).
Per particle, the work of all its contacts in one step is added to the stressing event's absorbed
energy (eq 14); the particle breaks as soon as that reaches its (damaged) fracture energy
(``first_reach``), or, with ``break_at_end``, when the event ends with its whole energy. An event
that ends without breakage damages the particle (eqs 5-6). Progeny are born overlapping each other,
the parent's neighbours and walls: only overlap beyond the creation state counts (the reference
shrinks as they part).

:class:`TavaresModel` is what a scene hands the Simulation; the replacement of broken particles by
progeny is :class:`~millsim.models.breakage.replacement.TavaresReplacement`.
"""

import math
from collections import namedtuple
from typing import NamedTuple

import numpy as np
from numba import njit

from ...engine.events import room_for
from ...engine.kinematics import MESH, W_KIND
from ...engine.models import NO_BREAKAGE, ParticleModel, stable_identity
from ...engine.walls import wall_contact_bounded
from ...util.validation import check_range
from .damage import damage_fraction

# Contact-state columns (after the law's tangential spring), the same for wall contacts: overlap
# and normal force one step ago (loading work), reference overlap of progeny created inside
# each other (only overlap beyond it counts). Slot record: the loading work given to i and to j.
PREV, FPREV, REF = 0, 1, 2
WORK_I, WORK_J = 0, 1
# Per-material table: Hertzian stiffness Y/(1 - nu^2) (eq 4), damage gamma (eq 6), e_min.
K, GAMMA, E_MIN = 0, 1, 2

TavaresBundle = namedtuple("TavaresBundle", ["table", "e_acc", "e_frac", "break_at_end", "broke",
                                             "stress_dir"])
# With the stress log: per particle, the absorbed specific energies of its ended events not yet
# drained (log_energy[i, :log_count[i]]).
TavaresLogBundle = namedtuple("TavaresLogBundle", [*TavaresBundle._fields, "log_energy",
                                                   "log_count", "log_pending"])
# Events a particle holds. Two short of it, it asks for a drain (log_pending): the next step's
# pair pass stops the chunk before its particle pass, so that the chunk ends at a step boundary
# like one that reached its length (a stop raised in the particle pass takes back the drift the
# particles had begun, which changes the last bits of the trajectory). Only where no pair slot
# is apart (no pair pass to see it) does a full log stop the chunk from the particle pass.
LOG_DEPTH = 32
# Event-table rows of the stress-log variant: a seventh column says which kind of row it is.
ROW_BREAKAGE, ROW_STRESS = 0.0, 1.0


def _pair_reference(bs, state, k, base, apart, rsum, dist2):
    ref = state[k, base + REF]
    if not apart and ref > 0.0:
        xi_now = rsum - math.sqrt(dist2)
        state[k, base + REF] = min(ref, xi_now)
        return ref, xi_now <= ref
    return 0.0, apart


def _pair_apart(bs, state, k, base, o, col, step, i, j, radius, body, rsum, dist2, seen, stop):
    # Keep the (negative) overlap: the step that brings the pair into contact then counts the
    # work of its whole approach, as the integrator does (the force acts over that whole step).
    state[k, base + PREV] = seen
    state[k, base + FPREV] = 0.0
    if dist2 >= rsum * rsum:
        state[k, base + REF] = 0.0


def _pair_apart_log(bs, state, k, base, o, col, step, i, j, radius, body, rsum, dist2, seen,
                    stop):
    # _pair_apart, and a drain asked for stops the chunk before this step's particle pass
    state[k, base + PREV] = seen
    state[k, base + FPREV] = 0.0
    if dist2 >= rsum * rsum:
        state[k, base + REF] = 0.0
    if bs.log_pending[0] != 0:
        stop[0] = 1


def _pair_loaded(bs, state, k, base, o, col, fn, xi, material_i, material_j):
    # Loading work while the overlap grows, trapezoidal in the overlap; eq 4 split.
    dxi = xi - state[k, base + PREV]
    work = 0.5 * (fn + state[k, base + FPREV]) * dxi if dxi > 0.0 else 0.0
    state[k, base + PREV] = xi
    state[k, base + FPREV] = fn
    ki = bs.table[material_i, K]
    kj = bs.table[material_j, K]
    o[col + WORK_I] = work * kj / (ki + kj)
    o[col + WORK_J] = work * ki / (ki + kj)


def _slot_share(bs, acc, o, col, side):
    work, fbig, d0, d1, d2 = acc
    if side == 0:
        work += o[col + WORK_I]
        if o[7] > fbig:
            fbig, d0, d1, d2 = o[7], o[0], o[1], o[2]
    else:
        work += o[col + WORK_J]
        if o[7] > fbig:
            fbig, d0, d1, d2 = o[7], -o[0], -o[1], -o[2]
    return work, fbig, d0, d1, d2


def _wall_reference(bs, hist, i, iw, base, xi):
    ref = hist[i, iw, base + REF]
    if ref > 0.0:
        seen = xi - ref
        hist[i, iw, base + REF] = min(ref, xi)
        if seen <= 0.0:
            for c in range(base + REF):
                hist[i, iw, c] = 0.0
            hist[i, iw, base + PREV] = seen
            return seen, False
        return seen, True
    return xi, True


def _wall_apart(bs, hist, i, iw, base, xi):
    hist[i, iw, base + PREV] = xi


def _wall_loaded(bs, hist, i, iw, base, xi, fn, g0, g1, g2, material_i, material_w, acc):
    work, fbig, d0, d1, d2 = acc
    dxi = xi - hist[i, iw, base + PREV]
    if dxi > 0.0:
        kp = bs.table[material_i, K]
        kw = bs.table[material_w, K]
        work += 0.5 * (fn + hist[i, iw, base + FPREV]) * dxi * kw / (kp + kw)
    hist[i, iw, base + PREV] = xi
    hist[i, iw, base + FPREV] = fn
    if fn > fbig:
        fbig, d0, d1, d2 = fn, g0, g1, g2
    return work, fbig, d0, d1, d2


def _particle_decide(bs, i, acc, inv_mass, material, stop):
    # Stressing event: absorbed energy summed over contacts (eq 14). Break as soon as it reaches
    # the fracture energy; when no contact loads any more the event ends and an unbroken particle
    # is damaged (eqs 5-6). With break_at_end the decision waits for the end of the event and
    # uses its whole energy (what the handler does with it is its business).
    work, fbig, d0, d1, d2 = acc
    e_acc, e_frac = bs.e_acc, bs.e_frac
    bs.broke[i] = 0
    if work > 0.0:
        e_acc[i] += work
        if e_acc[i] * inv_mass >= e_frac[i] and not bs.break_at_end[i]:
            bs.broke[i] = 1
            bs.stress_dir[i, 0], bs.stress_dir[i, 1], bs.stress_dir[i, 2] = d0, d1, d2
            stop[0] = 1
    elif e_acc[i] > 0.0:
        specific = e_acc[i] * inv_mass
        if bs.break_at_end[i] and specific >= e_frac[i]:
            bs.broke[i] = 1
            stop[0] = 1
        else:
            if specific >= bs.table[material, E_MIN]:
                e_frac[i] *= 1.0 - damage_fraction(specific / e_frac[i], bs.table[material, GAMMA])
            e_acc[i] = 0.0


def _particle_decide_log(bs, i, acc, inv_mass, material, stop):
    # _particle_decide, and every event that ends unbroken is logged with its absorbed specific
    # energy (the one it damaged by); a full log stops the chunk so that it is drained.
    work, fbig, d0, d1, d2 = acc
    e_acc, e_frac = bs.e_acc, bs.e_frac
    bs.broke[i] = 0
    if work > 0.0:
        e_acc[i] += work
        if e_acc[i] * inv_mass >= e_frac[i] and not bs.break_at_end[i]:
            bs.broke[i] = 1
            bs.stress_dir[i, 0], bs.stress_dir[i, 1], bs.stress_dir[i, 2] = d0, d1, d2
            stop[0] = 1
    elif e_acc[i] > 0.0:
        specific = e_acc[i] * inv_mass
        if bs.break_at_end[i] and specific >= e_frac[i]:
            bs.broke[i] = 1
            stop[0] = 1
        else:
            if specific >= bs.table[material, E_MIN]:
                e_frac[i] *= 1.0 - damage_fraction(specific / e_frac[i], bs.table[material, GAMMA])
                n = bs.log_count[i]
                if n < bs.log_energy.shape[1]:  # (a count beyond it is refused at the drain)
                    bs.log_energy[i, n] = specific
                bs.log_count[i] = n + 1
                if n + 3 >= bs.log_energy.shape[1]:
                    bs.log_pending[0] = 1
                if n + 1 >= bs.log_energy.shape[1]:
                    stop[0] = 1
            e_acc[i] = 0.0


def _collect(bs, events, n_events, out, col, start, nbr, inv_mass, step):
    # Rows in particle order: [particle, absorbed specific energy, step, direction of the
    # largest contact force (3)].
    broke = bs.broke
    needed = n_events[0]
    for i in range(broke.shape[0]):
        needed += broke[i]
    events = room_for(events, n_events[0], needed)
    for i in range(broke.shape[0]):
        if broke[i]:
            row = events[n_events[0]]
            row[0] = i
            row[1] = bs.e_acc[i] * inv_mass[i]
            row[2] = step
            row[3], row[4], row[5] = bs.stress_dir[i, 0], bs.stress_dir[i, 1], bs.stress_dir[i, 2]
            n_events[0] += 1
            broke[i] = 0
            if bs.break_at_end[i]:
                bs.e_acc[i] = 0.0  # the event has ended: reported once
    return events


def _collect_log(bs, events, n_events, out, col, start, nbr, inv_mass, step):
    # Rows: first every logged event [particle, absorbed specific energy, step of the drain,
    # broke = 0, 0, 0, ROW_STRESS] in particle order, then per breaking particle its decision
    # [particle, specific energy, step, direction (3), ROW_BREAKAGE] and its event in the log
    # [particle, specific energy, step, broke = 1, 0, 0, ROW_STRESS].
    broke, count = bs.broke, bs.log_count
    needed = n_events[0]
    for i in range(broke.shape[0]):
        if count[i] > bs.log_energy.shape[1]:
            raise RuntimeError("stress log: a particle ended more events than it holds")
        needed += count[i] + 2 * broke[i]
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
            specific = bs.e_acc[i] * inv_mass[i]
            row = events[n_events[0]]
            row[0], row[1], row[2] = i, specific, step
            row[3], row[4], row[5] = bs.stress_dir[i, 0], bs.stress_dir[i, 1], bs.stress_dir[i, 2]
            row[6] = ROW_BREAKAGE
            row = events[n_events[0] + 1]
            row[0], row[1], row[2] = i, specific, step
            row[3], row[4], row[5], row[6] = 1.0, 0.0, 0.0, ROW_STRESS
            n_events[0] += 2
            broke[i] = 0
            if bs.break_at_end[i]:
                bs.e_acc[i] = 0.0  # the event has ended: reported once
    return events


def _kernel(fn):
    return stable_identity(njit(inline="always", cache=True)(fn), f"tavares.{fn.__name__}")


KERNELS = NO_BREAKAGE._replace(
    pair_reference=_kernel(_pair_reference), pair_apart=_kernel(_pair_apart),
    pair_loaded=_kernel(_pair_loaded), slot_share=_kernel(_slot_share),
    wall_reference=_kernel(_wall_reference), wall_apart=_kernel(_wall_apart),
    wall_loaded=_kernel(_wall_loaded),
    particle_decide=_kernel(_particle_decide),
    collect=stable_identity(njit(cache=True)(_collect), "tavares._collect"))
# The stress-log variant (TavaresModel(stress_log=True)): its own loop, compiled only for a scene
# that asks for it; the loop of every other scene is the one above.
LOG_KERNELS = KERNELS._replace(
    pair_apart=_kernel(_pair_apart_log), particle_decide=_kernel(_particle_decide_log),
    collect=stable_identity(njit(cache=True)(_collect_log), "tavares._collect_log"))


class BreakageDecision(NamedTuple):
    """A particle whose stressing event reached its fracture energy (Tavares et al. 2021)."""

    particle: int
    specific_energy: float  # absorbed Ek'/m of the event [J/kg]
    step: int
    direction: np.ndarray  # unit vector of its largest contact force


class StressEvent(NamedTuple):
    """A stressing event that ended (``TavaresModel(stress_log=True)``): unbroken, having damaged
    the particle by eqs 5-6, or the one that broke it."""

    particle_id: int  # Simulation.particle_ids of the particle (never reused)
    specific_energy: float  # absorbed Ek'/m of the event [J/kg] (a breaking one: up to the break)
    step: int  # step at which it was drained (the event ended at or before it)
    broke: bool


class TavaresModel(ParticleModel):
    """Tavares et al. 2021 breakage for the engine: loading work per stressing event vs a damaged
    fracture energy.

    Args:
        materials: {material name: (gamma, e_min)}, the damage coefficient of eqs 5-6 and the
            smallest absorbed specific energy [J/kg] an event must reach to damage; materials not
            named never break.
        stress_log: report every stressing event that ends (unbroken at or above e_min, or
            broken) as a :class:`StressEvent` (``take_stress_log``). Off: the loop is the one
            without it (other kernels, a compiled variant of its own when on).

    Per particle (``sim.breakage.<field>``): ``e_frac`` the (damaged) specific fracture energy
    [J/kg] (inf: never breaks; set by the caller), ``e_acc`` the energy absorbed in the current
    event [J], ``break_at_end`` (decide at the end of the event, with its whole energy),
    ``t10_recorded`` the t10' [%] recorded for a resolved-unbreakable particle's first breaking
    event (NaN: none; Tavares et al. 2021, section 2.3).
    """

    kind, name = "breakage", "tavares"
    contact_columns = ("overlap_before", "normal_force_before", "reference_overlap")
    wall_columns = contact_columns
    slot_columns = ("work_i", "work_j")
    particle_fields = {"e_acc": (np.float64, 0.0), "e_frac": (np.float64, np.inf),
                       "break_at_end": (np.bool_, False), "broke": (np.int8, 0),
                       "stress_dir": ((np.float64, 3), 0.0), "t10_recorded": (np.float64, np.nan)}
    kernels = KERNELS
    event_columns = 6

    def __init__(self, materials, stress_log=False):
        self.stress_log = bool(stress_log)
        if self.stress_log:
            self.name = "tavares_log"
            self.kernels = LOG_KERNELS
            self.event_columns = 7
            self.particle_fields = {**TavaresModel.particle_fields,
                                    "log_energy": ((np.float64, LOG_DEPTH), 0.0),
                                    "log_count": (np.int64, 0)}
        self.stress_rows = []  # drained StressEvents not yet taken
        self.log_pending = np.zeros(1, dtype=np.int64)  # a particle's log is nearly full
        self.materials = {}
        for name, (gamma, e_min) in dict(materials).items():
            self.materials[name] = (check_range(f"breakage[{name}].gamma", gamma, 0.0, lo_open=True),
                                    check_range(f"breakage[{name}].e_min", e_min, 0.0))

    def attach(self, sim):
        if sim.law.elastic != "hertz":
            raise ValueError("breakage: the Tavares model (Tavares et al. 2021) needs a Hertzian "
                             f"contact law (its damage is the Hertz strain energy); {sim.law.name!r} "
                             "is not")
        super().attach(sim)
        table = np.zeros((len(sim.table.materials), 3))
        for k, m in enumerate(sim.table.materials):
            table[k, K] = m.youngs_modulus / (1.0 - m.poisson_ratio**2)
        for name, (gamma, e_min) in self.materials.items():
            k = sim.material_index(name)
            table[k, GAMMA], table[k, E_MIN] = gamma, e_min
        self.table = table

    def params(self):
        return self.table

    def bundle(self, fields):
        if self.stress_log:
            return TavaresLogBundle(self.table, fields.e_acc, fields.e_frac, fields.break_at_end,
                                    fields.broke, fields.stress_dir, fields.log_energy,
                                    fields.log_count, self.log_pending)
        return TavaresBundle(self.table, fields.e_acc, fields.e_frac, fields.break_at_end,
                             fields.broke, fields.stress_dir)

    def records(self, rows):
        if self.stress_log:  # the log's rows are kept (by particle id) for take_stress_log
            stress = rows[:, 6] == ROW_STRESS
            ids = self.sim.particle_ids
            self.stress_rows += [StressEvent(int(ids[int(r[0])]), float(r[1]), int(r[2]),
                                             bool(r[3])) for r in rows[stress]]
            rows = rows[~stress]
        out = []
        for r in rows:
            d = r[3:6]
            norm = np.linalg.norm(d)
            out.append(BreakageDecision(int(r[0]), float(r[1]), int(r[2]),
                                        d / norm if norm > 0 else np.array([0.0, 0.0, 1.0])))
        return out

    def reset_events(self):
        self.e_acc[:] = 0.0

    def take_stress_log(self):
        """The ended stressing events since the last call (``stress_log``), in the order they
        were drained (a particle's in the order they ended): those the loop handed over at its
        stops (``Simulation.pop_events``, which the on_events handler calls, moves them here),
        then those still held per particle."""
        if not self.stress_log:
            raise ValueError("take_stress_log: the model was made without stress_log")
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

    def reference_overlap(self, state):
        """Creation overlap of progeny pairs (0 for ordinary pairs), from contact-state rows."""
        return state[:, REF]

    def mark_creation_overlaps(self, indices):
        """Particles just created (progeny) may reach into their neighbours and walls: in every
        contact they have now, only overlap beyond the present one will count (Tavares et al. 2021,
        section 2.3), the reference shrinking as the pair parts."""
        sim = self.sim
        c, p, base = sim.contacts, sim.particles, sim.layout.spring
        indices = np.atleast_1d(indices)
        slots = np.concatenate([np.arange(c.start[i], c.start[i + 1]) for i in indices] +
                               [c.rev_slot[c.rev_start[i]:c.rev_start[i + 1]] for i in indices])
        if len(slots):
            owner = np.searchsorted(c.start, slots, side="right") - 1
            d = sim.separation(owner, c.nbr[slots])
            overlap = p.radius[owner] + p.radius[c.nbr[slots]] - np.linalg.norm(d, axis=1)
            col = base + REF
            c.state[slots, col] = np.maximum(c.state[slots, col], np.maximum(overlap, 0.0))
        for iw, wall in enumerate(sim.walls):
            if wall[W_KIND] == MESH:  # below, triangle by triangle
                continue
            for i in indices:
                xi = wall_contact_bounded(wall, p.x[i, 0], p.x[i, 1], p.x[i, 2], p.radius[i])[0]
                if xi > 0:
                    sim.wall_hist[i, iw, base + REF] = xi
        who, slot, xi = sim.open_mesh_contacts(indices)
        if len(who):
            sim.mesh_hist[who, slot, base + REF] = xi
