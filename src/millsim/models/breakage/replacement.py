"""Particle replacement for the Tavares model: between chunks, broken particles become progeny.

The compiled loop decides *when* a particle breaks (absorbed energy of a stressing event reaches
its damaged fracture energy) and stops the chunk there; :class:`TavaresReplacement` is the
``on_fracture`` handler that does the rest in Python:

- draws the progeny family
  (:func:`~millsim.models.breakage.progeny_placement.break_particle`) with counter-based
  uniforms, so a run is reproducible whatever happens elsewhere;
- replaces the parent by its progeny, placed inside it, moving with the parent's rigid motion
  (linear and angular momentum of the parent are kept);
- registers every contact the progeny are created with (each other, the parent's neighbours, the
  walls), so that only overlap beyond the creation state produces force
  (``TavaresModel.mark_creation_overlaps``);
- gives breakable progeny a fresh fracture energy for their size (eqs 1-3), dummy spheres and
  unbreakable materials an infinite one;
- resolved-unbreakable particles (below the global minimum size for a family, Tavares et al. 2021,
  section 2.3) get a fracture energy too; the engine reports the first stressing event that reaches
  it, at the event's end with its whole energy (the particle stays whole, so all of it is its own),
  and the handler records its t10' (eq 8) in ``particles.t10_recorded`` instead of replacing the
  particle; eq 13 turns that into a size distribution after the run (:func:`product_passing`);
- ``breakage_at`` chooses when a breakable particle breaks (reference section 6 leaves it open):
  ``"first_reach"``, as soon as the event's absorbed energy reaches E (t10' ~ t10_min, eq 9), or
  ``"end_of_loading"``, when the event ends, with t10' from its whole energy (eq 8);
- keeps the books: unresolved fines mass, one record per breakage event and per recorded event;
- gives the progeny the Simulation's per-particle tags: each inherits its parent's, except
  ``generation`` (the parent's + 1), ``dummy`` (True for dummy spheres) and ``event_t10`` (the
  t10' of the event that made it), when the simulation keeps tags of those names; and the
  parent's id as their ``parent_ids`` (``Simulation.particle_ids``).
"""

from dataclasses import dataclass, field

import numpy as np

from ...engine.rng import hash_uniform
from ...engine.state import disk_or_sphere_mass
from . import progeny_families, progeny_placement, tavares

BREAKAGE_AT = ("first_reach", "end_of_loading")
# Streams of the counter-based generator (second key), so that draws never collide.
STREAM_FAMILY, STREAM_SPIN, STREAM_ENERGY = 1, 2, 3


@dataclass
class BreakageEvent:
    time: float
    position: np.ndarray
    parent_diameter: float
    parent_material: str
    specific_energy: float  # absorbed Ek'/m of the breaking event [J/kg]
    fracture_energy: float  # the (damaged) fracture energy it exceeded [J/kg]
    t10: float  # t10' of the event [%]
    family: int
    progeny: int  # resolved spheres (dummy spheres included)
    fines_mass: float  # unresolved fines [kg]


@dataclass
class UnbreakableRecord:
    """First breaking event of a resolved-unbreakable particle (Tavares et al. 2021,
    section 2.3)."""

    time: float
    position: np.ndarray
    diameter: float
    material: str
    specific_energy: float  # absorbed Ek'/m of the whole event [J/kg]
    fracture_energy: float  # the (damaged) fracture energy it reached [J/kg]
    t10: float  # eq 8 [%]


@dataclass
class TavaresReplacement:
    """``on_fracture`` handler replacing broken particles by progeny families.

    Args:
        materials: {name: :class:`~millsim.models.breakage.tavares.TavaresMaterial`} for the breakable
            materials of the simulation (others never break).
        d_min: global minimum resolved size [m] (Tavares et al. 2021: 1/20 of the top size).
        seed: seed of the family, arrangement and fracture-energy draws.
        policy, dummy_as: see :func:`~millsim.models.breakage.progeny_placement.break_particle`.
        breakage_at: ``"first_reach"`` or ``"end_of_loading"`` (see the module text).
    """

    materials: dict
    d_min: float
    seed: int = 0
    policy: str = "standard"
    dummy_as: str = "spheres"
    breakage_at: str = "first_reach"
    events: list = field(default_factory=list)
    records: list = field(default_factory=list)
    fines_mass: float = 0.0
    # particles (indices before the call) replaced by the last call, in the order of its events,
    # and their tags
    last_broken: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    last_parent_tags: dict = field(default_factory=dict)
    _draws: int = 0

    def __post_init__(self):
        if self.breakage_at not in BREAKAGE_AT:
            raise ValueError(f"breakage_at: {self.breakage_at!r} is not one of {BREAKAGE_AT}")

    def _uniform(self, stream, key):
        return float(hash_uniform(self.seed, stream, key, 0))

    def _next_key(self):
        self._draws += 1
        return self._draws

    def assign_fracture_energies(self, sim, indices):
        """Fresh fracture energies [J/kg] for the given particles (inf for materials that do not
        break; resolved-unbreakable sizes get one as well, their breakage is only recorded) and
        when their breakage is decided."""
        p, model = sim.particles, sim.breakage
        names = [m.name for m in sim.table.materials]
        for i in np.atleast_1d(indices):
            mat = self.materials.get(names[p.material[i]])
            if mat is None or not mat.breakable:
                model.e_frac[i] = np.inf
                continue
            d = 2.0 * p.radius[i]
            model.break_at_end[i] = (self.breakage_at == "end_of_loading"
                                     or not progeny_families.is_breakable(mat, d, self.d_min, self.policy))
            u = self._uniform(STREAM_ENERGY, self._next_key())
            model.e_frac[i] = float(tavares.sample_fracture_energy(mat, d, np.array([u]))[0])

    def __call__(self, sim, rows=None):
        """Replace the broken particles of ``rows`` (default: ``sim.pop_events()``)."""
        rows = sim.pop_events() if rows is None else rows
        p, model = sim.particles, sim.breakage
        names = [m.name for m in sim.table.materials]
        broken = []
        new_x, new_r, new_mat, new_v, new_w, new_dummy = [], [], [], [], [], []
        for i, specific, _step, direction in rows:
            name = names[p.material[i]]
            mat = self.materials[name]
            d = 2.0 * p.radius[i]
            if not progeny_families.is_breakable(mat, d, self.d_min, self.policy):
                t10 = float(tavares.t10_prime(mat, specific, model.e_frac[i]))
                self.records.append(UnbreakableRecord(sim.time, p.x[i].copy(), d, name, specific,
                                                      float(model.e_frac[i]), t10))
                model.t10_recorded[i] = t10
                model.e_frac[i] = np.inf  # only the first breaking event counts
                continue
            key = self._next_key()
            progeny = progeny_placement.break_particle(
                mat, d, specific, float(model.e_frac[i]), direction,
                self._uniform(STREAM_FAMILY, key), self._uniform(STREAM_SPIN, key),
                d_min=self.d_min, policy=self.policy, dummy_as=self.dummy_as)
            broken.append(i)
            k = len(progeny.radii)
            # rigid motion of the parent: v + w x r for each piece, same spin
            new_x.append(p.x[i] + progeny.offsets)
            new_v.append(p.v[i] + np.cross(p.w[i], progeny.offsets))
            new_w.append(np.repeat(p.w[i][None, :], k, axis=0))
            new_r.append(progeny.radii)
            new_mat += [name] * k
            new_dummy.append(progeny.dummy)
            self.fines_mass += progeny.fines_mass
            self.events.append(BreakageEvent(
                sim.time, p.x[i].copy(), d, name, specific, float(model.e_frac[i]), progeny.t10,
                progeny.family, k, progeny.fines_mass))
        self.last_broken = np.array(broken, dtype=np.int64)
        self.last_parent_tags = {name: values[self.last_broken] for name, values in sim.tags.items()}
        if not broken:
            return
        counts = [len(r) for r in new_r]
        tags = {}
        for name, parent in self.last_parent_tags.items():
            tags[name] = np.repeat(parent, counts) + (1 if name == "generation" else 0)
        if "dummy" in tags:
            tags["dummy"] = np.concatenate(new_dummy)
        if "event_t10" in tags:
            tags["event_t10"] = np.repeat([ev.t10 for ev in self.events[-len(broken):]], counts)
        # add before removing, so that a system of one breaking particle is never empty
        parent_ids = np.repeat(sim.particle_ids[self.last_broken], counts)
        first = sim.add_particles(np.concatenate(new_x), np.concatenate(new_r), new_mat,
                                  v=np.concatenate(new_v), w=np.concatenate(new_w), tags=tags,
                                  parent_ids=parent_ids)[0]
        gone = np.zeros(sim.n_particles, bool)
        gone[self.last_broken] = True
        sim.remove_particles(gone)
        first -= len(broken)
        dummy = np.concatenate(new_dummy)
        new = np.arange(first, first + len(dummy))
        model = sim.breakage  # (its arrays were reallocated by add/remove)
        model.mark_creation_overlaps(new)
        self.assign_fracture_energies(sim, new[~dummy])
        model.e_frac[new[dummy]] = np.inf

    def resolved_mass(self, sim):
        """Mass of the resolved particles of the breakable materials [kg]; plus ``fines_mass`` it
        is the charge, conserved by every replacement."""
        p = sim.particles
        names = [m.name for m in sim.table.materials]
        mine = np.array([names[m] in self.materials for m in p.material]) & (p.body < 0)
        density = np.array([m.density for m in sim.table.materials])[p.material[mine]]
        return float(disk_or_sphere_mass(p.radius[mine], density, 3, 1.0).sum())


UNBREAKABLE_PRODUCT = ("eq13", "keep")


def product_passing(sizes, masses, t10_recorded, mat, sieves, unbreakable="eq13"):
    """Mass [kg] of resolved spheres passing each sieve [m].

    ``unbreakable="eq13"`` replaces each resolved-unbreakable sphere that recorded a breaking
    event (finite ``t10_recorded``) by the eq 13 distribution of its own size (Fig 14
    of Tavares et al. 2021); ``"keep"`` counts every sphere at its own size (Fig 13). Dummy spheres
    and unresolved fines are the caller's (they belong to the event that made them, eq 11).
    """
    if unbreakable not in UNBREAKABLE_PRODUCT:
        raise ValueError(f"unbreakable: {unbreakable!r} is not one of {UNBREAKABLE_PRODUCT}")
    sizes, masses = np.asarray(sizes, float), np.asarray(masses, float)
    sieves = np.atleast_1d(np.asarray(sieves, float))
    recorded = np.isfinite(t10_recorded) if unbreakable == "eq13" else np.zeros(len(sizes), bool)
    whole = ~recorded
    passing = np.array([masses[whole & (sizes < s * (1 - 1e-9))].sum() for s in sieves])
    for d, m, t10 in zip(sizes[recorded], masses[recorded], np.asarray(t10_recorded)[recorded]):
        passing += m * tavares.resolved_unbreakable_passing(t10, sieves / d, mat) / 100.0
    return passing
