"""Particle replacement for the Tavares model: between chunks, broken particles become progeny.

The compiled loop decides *when* a particle breaks (absorbed energy of a stressing event reaches
its damaged fracture energy) and stops the chunk there; :class:`TavaresReplacement` is the
``on_fracture`` handler that does the rest in Python:

- draws the progeny family (:func:`~millsim.breakage.tavares.break_particle`) with counter-based
  uniforms, so a run is reproducible whatever happens elsewhere;
- replaces the parent by its progeny, placed inside it, moving with the parent's rigid motion
  (linear and angular momentum of the parent are kept);
- registers every contact the progeny are created with (each other, the parent's neighbours, the
  walls), so that only overlap beyond the creation state produces force
  (``Simulation.mark_creation_overlaps``);
- gives breakable progeny a fresh fracture energy for their size (eqs 1-3) and unbreakable ones
  (resolved-unbreakable, dummy class, unbreakable materials) an infinite one;
- keeps the books: unresolved fines mass, one record per breakage event.
"""

from dataclasses import dataclass, field

import numpy as np

from ..engine.rng import hash_uniform
from ..engine.state import disk_or_sphere_mass
from . import tavares

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
class TavaresReplacement:
    """``on_fracture`` handler replacing broken particles by progeny families.

    Args:
        materials: {name: :class:`~millsim.breakage.tavares.TavaresMaterial`} for the breakable
            materials of the simulation (others never break).
        d_min: global minimum resolved size [m] (seed 002: 1/20 of the top size).
        seed: seed of the family, arrangement and fracture-energy draws.
        policy, dummy_as: see :func:`~millsim.breakage.tavares.break_particle`.
    """

    materials: dict
    d_min: float
    seed: int = 0
    policy: str = "standard"
    dummy_as: str = "spheres"
    events: list = field(default_factory=list)
    fines_mass: float = 0.0
    _draws: int = 0

    def _uniform(self, stream, key):
        return float(hash_uniform(self.seed, stream, key, 0))

    def _next_key(self):
        self._draws += 1
        return self._draws

    def assign_fracture_energies(self, sim, indices):
        """Fresh fracture energies [J/kg] for the given particles (inf where they cannot break)."""
        p = sim.particles
        names = [m.name for m in sim.table.materials]
        for i in np.atleast_1d(indices):
            name = names[p.material[i]]
            d = 2.0 * p.radius[i]
            mat = self.materials.get(name)
            if mat is None or not mat.breakable or not tavares.is_breakable(mat, d, self.d_min,
                                                                           self.policy):
                p.e_frac[i] = np.inf
                continue
            u = self._uniform(STREAM_ENERGY, self._next_key())
            p.e_frac[i] = float(tavares.sample_fracture_energy(mat, d, np.array([u]))[0])

    def __call__(self, sim):
        rows = sim.pop_fractures()
        if not rows:
            return
        p = sim.particles
        names = [m.name for m in sim.table.materials]
        broken = np.zeros(sim.n_particles, dtype=bool)
        new_x, new_r, new_mat, new_v, new_w, new_breakable = [], [], [], [], [], []
        for i, specific, _step, direction in rows:
            name = names[p.material[i]]
            mat = self.materials[name]
            d = 2.0 * p.radius[i]
            key = self._next_key()
            progeny = tavares.break_particle(
                mat, d, specific, float(p.e_frac[i]), direction,
                self._uniform(STREAM_FAMILY, key), self._uniform(STREAM_SPIN, key),
                d_min=self.d_min, policy=self.policy, dummy_as=self.dummy_as)
            broken[i] = True
            k = len(progeny.radii)
            # rigid motion of the parent: v + w x r for each piece, same spin
            new_x.append(p.x[i] + progeny.offsets)
            new_v.append(p.v[i] + np.cross(p.w[i], progeny.offsets))
            new_w.append(np.repeat(p.w[i][None, :], k, axis=0))
            new_r.append(progeny.radii)
            new_mat += [name] * k
            new_breakable.append(progeny.breakable)
            self.fines_mass += progeny.fines_mass
            self.events.append(BreakageEvent(
                sim.time, p.x[i].copy(), d, name, specific, float(p.e_frac[i]), progeny.t10,
                progeny.family, k, progeny.fines_mass))
        # add before removing, so that a system of one breaking particle is never empty
        first = sim.add_particles(np.concatenate(new_x), np.concatenate(new_r), new_mat,
                                  v=np.concatenate(new_v), w=np.concatenate(new_w))[0]
        sim.remove_particles(np.concatenate([broken, np.zeros(sim.n_particles - len(broken), bool)]))
        first -= int(broken.sum())
        breakable = np.concatenate(new_breakable)
        new = np.arange(first, first + len(breakable))
        sim.mark_creation_overlaps(new)
        self.assign_fracture_energies(sim, new[breakable])
        sim.particles.e_frac[new[~breakable]] = np.inf

    def resolved_mass(self, sim):
        """Mass of the resolved particles of the breakable materials [kg]; plus ``fines_mass`` it
        is the charge, conserved by every replacement."""
        p = sim.particles
        names = [m.name for m in sim.table.materials]
        mine = np.array([names[m] in self.materials for m in p.material]) & (p.body < 0)
        density = np.array([m.density for m in sim.table.materials])[p.material[mine]]
        return float(disk_or_sphere_mass(p.radius[mine], density, 3, 1.0).sum())
