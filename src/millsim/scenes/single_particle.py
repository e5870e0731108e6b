"""Scene ``single_particle``: single-particle breakage tests of the Tavares model
(Tavares et al. 2021, 4.1).

N particles of one material and size are stressed at one set specific energy, all in one
simulation: they sit on a square grid, far enough apart never to touch, above one steel plate.

Modes:

- ``single``: each particle flies at the plate with v = sqrt(2 Ek/m) (one contact).
- ``drop_weight``: each particle rests on the steel anvil (the plate) and a steel striker (a sphere
  ``striker_ratio`` times the particle diameter) hits it from above with 1/2 M v^2 = Ek; the
  absorbed energy of the striker-particle and particle-anvil contacts is summed (eq 14). This is
  the "double impact" (DWT) of Tavares et al. 2021.
- ``repeated``: ``impacts`` successive single impacts at the same energy; between impacts the
  unbroken (damaged) particles are put back above the plate with the impact velocity. The
  cumulative fraction broken after each impact is recorded (Fig. 11 of Tavares et al. 2021). With
  impacts = 2 this is also "two successive impacts, the second on the damaged survivors".

**The set specific energy is the stressing (input) energy** Ek/m: 1/2 v^2 (or 1/2 M v^2/m), the
x-axis of Figs 8-11 and 16 of Tavares et al. 2021 and the basis of Table 4's E_inf. The particle
absorbs e = k_s/(k_p + k_s) of it (eq 4); the analytic model
(millsim.models.breakage.tavares_predictions) is eq 1 at e Ek/m with the absorbed median, identical
to eq 1 at Ek/m with median E_inf[1+(d0/d)^phi]. Give it in J/kg (``specific_energy``) or as
a multiple of that stressing-basis median (``energy_ratio``, used when specific_energy = 0: the same
ratios give comparable probabilities for every material).

Gravity is off: flight before and after an impact takes microseconds and gravity would add
~g d/v^2 (< 1e-3) to the energy. Time step: the engine's recommended step (0.1 Rayleigh time of
the smallest particle present, and >= 50 steps per Hertz contact at the impact speed), times
``dt_factor``; it follows the fragments as they appear. Contacts: Tavares et al. 2021, Table 6
restitution and sliding friction; rolling friction is left out (it plays no part in a head-on
loading).

Broken particles are either replaced by progeny families (``replacement``, default for single
and drop_weight: progeny size distribution, secondary breakage, t10) with the dummy class kept as
fines mass (its size distribution below x_min follows eq 11 with the event's t10'), or just
counted and removed (``replacement = false``, and always in ``repeated``): breakage probability
only, much cheaper. The breakage decision of an original particle is the same either way.

Every particle's fracture energy is drawn from the counter-based generator with a key derived
from (seed, mode, material, diameter, energy, N, gamma, truncation), so the points of a sweep are
independent samples.

Per particle the case records whether it broke (and at which impact), its initial and final
fracture energy, the absorbed specific energy of its (first) stressing event, the t10' of its
primary breakage, its product's t10 and the number of progeny; per breakage event (including
secondary ones) time, generation, energies, t10', family and fines; the broken fraction with its
95 % Clopper-Pearson interval and the analytic value; and with replacement the cumulative size
distribution of the broken particles' product on the 2^(1/4) series down to 2^-10 of the size,
fines included, with the model's.
"""

import dataclasses
import math
import zlib
from typing import NamedTuple

import numpy as np

from ..engine import BYTES_PER_PARTICLE, Guards, PhysicsSpec, Simulation
from ..models import Interaction, Material, MaterialTable, TavaresModel
from ..models.breakage import progeny_families, tavares, tavares_materials
from ..models.breakage import tavares_predictions as tv
from ..models.breakage.replacement import BREAKAGE_AT, TavaresReplacement, product_passing
from ..util.memory import check_memory
from ..util.stats import binomial_interval, bootstrap_interval
from .base import TIME_STEP_PARAMS, Param, Scene, check_particle_memory, register, step_policy
from .config_walls import scene_walls
from .driver import Case, Output

SPEC = PhysicsSpec(dim=3, walls=True, gravity=False)
MODES = ("single", "drop_weight", "repeated")
SIEVES = tavares.SIEVE_RATIO ** -np.arange(0.0, 41.0)  # x/d0 from 1 to 2^-10
GAP = 0.01  # initial gap to the plate / striker, in particle radii

PARAMS = (
    Param("mode", "single", "single impact on a plate, drop-weight test (striker + anvil, two "
          "contacts summed), or repeated impacts", choices=MODES),
    Param("material", "copper_ore", "particle material: any breakable one of materials_file"),
    Param("materials_file", tavares_materials.MATERIALS_FILE, "Tavares materials (docs/materials.md)"),
    Param("diameter", 5.5e-3, "particle diameter", "m", 0.0, lo_open=True),
    Param("specific_energy", 0.0, "set input (stressing) specific energy Ek/m; 0 = energy_ratio "
          "x the stressing-basis median E_inf[1+(d0/d)^phi]", "J kg-1", 0.0),
    Param("energy_ratio", 1.0, "Ek/m as a multiple of the stressing-basis median (when "
          "specific_energy = 0)", "1", 0.0, lo_open=True),
    Param("n_particles", 250, "particles stressed", "1", 1),
    Param("impacts", 20, "successive impacts (mode repeated)", "1", 1, 1000),
    Param("gamma", 0.0, "damage coefficient of eq 6; 0 = the material's (Table 4)", "1", 0.0),
    Param("truncation", "single_particle", "Emax/E50 of materials_file: single_particle "
          "(4, Tavares et al. 2021 verification) or bed (100)", choices=tavares_materials.TRUNCATIONS),
    Param("breakage_at", "first_reach", "when a particle breaks: first_reach (absorbed energy of the "
          "event reaches E) or end_of_loading (when the event ends, t10' from its whole energy)",
          choices=BREAKAGE_AT),
    Param("replacement", True, "replace broken particles by progeny families (single and "
          "drop_weight); false: count and remove them"),
    Param("restitution", 0.39, "particle-steel restitution (Table 6)", "1", 0.0, 1.0, lo_open=True),
    Param("restitution_pp", 0.48, "particle-particle restitution (Table 6; fragments)", "1", 0.0, 1.0,
          lo_open=True),
    Param("friction", 0.5, "particle-steel sliding friction (Table 6)", "1", 0.0),
    Param("friction_pp", 0.49, "particle-particle sliding friction (Table 6)", "1", 0.0),
    Param("striker_ratio", 4.0, "drop-weight striker diameter / particle diameter", "1", 1.0),
    Param("spacing", 3.0, "grid pitch / diameter of the largest body", "1", 1.5),
    # the accuracy study's choice: absorbed energy within 0.9 % (docs/results/accuracy.md)
    dataclasses.replace(TIME_STEP_PARAMS[0], default=0.5),
    TIME_STEP_PARAMS[1],
    Param("contact_times", 25.0, "cap on the simulated time of one impact, in Hertz contact times",
          "1", 2.0),
    Param("max_overlap", 0.95, "guard: overlap / smaller radius that stops the run (small "
          "unbreakable fragments squeezed by large ones at high energy reach ~0.5)", "1", 0.0, 1.0,
          lo_open=True),
    Param("seed", 1, "random seed (fracture energies, families)", "1", 0),
)


def _check(values):
    if values["mode"] == "repeated" and values["replacement"] and values["impacts"] < 1:
        raise ValueError("impacts: at least 1")
    # a bad materials file or material is refused before any job runs
    tavares_materials.check_material(values["materials_file"], values["material"])
    # a drop-weight test has a striker per particle
    # the line names the count as given and the largest allowed in the same terms
    if values["mode"] == "drop_weight":
        check_memory("n_particles", values["n_particles"], lambda n: 2 * n * BYTES_PER_PARTICLE,
                     "particles", f"{BYTES_PER_PARTICLE} B each and as much for its striker")
    else:
        check_particle_memory("n_particles", values["n_particles"])


@dataclasses.dataclass
class Setup:
    values: dict
    mat: tavares.TavaresMaterial
    steel: tavares.TavaresMaterial
    share: float
    specific_energy: float
    speed: float
    mass: float
    sim: Simulation
    home: np.ndarray  # (N, 3) start position of each original
    t_contact: float
    case_seed: int

    @property
    def ids(self):
        """Original particle of every simulated particle (striker of k: -2 - k); a tag."""
        return self.sim.tags["original"]

    @property
    def gen(self):
        """Generation of every simulated particle (0: original, -1: retired stand-in); a tag."""
        return self.sim.tags["generation"]


def _materials(values):
    mats = tavares_materials.load_materials(values["materials_file"], truncation=values["truncation"])
    mat = mats[values["material"]]
    if values["gamma"] > 0:
        mat = dataclasses.replace(mat, gamma=values["gamma"])
    return mat, mats["steel"]


def case_seed(values):
    """Seed of the fracture-energy and family draws: independent per point of a sweep."""
    key = (f"{values['seed']}|{values['mode']}|{values['material']}|{values['diameter']!r}|"
           f"{values['specific_energy']!r}|{values['energy_ratio']!r}|{values['n_particles']}|"
           f"{values['gamma']!r}|{values['truncation']}")
    return zlib.crc32(key.encode()) & 0x7FFFFFFF


def build(values):
    mat, steel = _materials(values)
    share = tv.absorbed_share(mat, steel.k)
    d = values["diameter"]
    r = 0.5 * d
    E = values["specific_energy"] or values["energy_ratio"] * tv.stressing_median(mat, d, share)
    m = mat.density * math.pi / 6.0 * d**3
    n = values["n_particles"]
    drop = values["mode"] == "drop_weight"
    rs = values["striker_ratio"] * r
    pitch = values["spacing"] * 2.0 * (rs if drop else r)
    side = math.ceil(math.sqrt(n))
    k = np.arange(n)
    xy = np.column_stack([(k % side) * pitch, (k // side) * pitch])
    if drop:
        M = steel.density * 4.0 / 3.0 * math.pi * rs**3
        speed = math.sqrt(2.0 * E * m / M)
        xp = np.column_stack([xy, np.full(n, r)])  # resting on the anvil, zero overlap
        xs = np.column_stack([xy, np.full(n, 2 * r + rs + GAP * r)])
        x = np.vstack([xp, xs])
        radius = np.concatenate([np.full(n, r), np.full(n, rs)])
        material = [mat.name] * n + ["steel"] * n
        v = np.vstack([np.zeros((n, 3)), np.tile([0.0, 0.0, -speed], (n, 1))])
        ids = np.concatenate([k, -2 - k])  # striker of particle k: -2 - k
        m_eff, r_eff = M * m / (M + m), r * rs / (r + rs)
    else:
        speed = math.sqrt(2.0 * E)
        x = np.column_stack([xy, np.full(n, r * (1 + GAP))])
        radius = np.full(n, r)
        material = mat.name
        v = np.tile([0.0, 0.0, -speed], (n, 1))
        ids = k.copy()
        m_eff, r_eff = m, r
    ore = Material(mat.name, mat.density, mat.young, mat.poisson)
    st = Material("steel", steel.density, steel.young, steel.poisson)
    table = MaterialTable([ore, st], {
        "*": Interaction(restitution=values["restitution_pp"], friction=values["friction_pp"]),
        (mat.name, "steel"): Interaction(restitution=values["restitution"], friction=values["friction"]),
        ("steel", "steel"): Interaction(restitution=0.5, friction=0.5)})
    seed = case_seed(values)
    spec, walls = scene_walls(values, SPEC, [dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1),
                                                  material="steel")])
    sim = Simulation(spec, table, x=x, radius=radius, material=material, v=v, gravity=(0, 0, 0),
                     walls=walls,
                     breakage=TavaresModel({mat.name: (mat.gamma, mat.e_min)}),
                     step=step_policy(values, impact_speed=max(speed, 0.1)),
                     # guard against numerical blow-up only: small unbreakable fragments squeezed
                     # out between large ones (or a striker) legitimately fly off fast
                     guards=Guards(max_overlap=values["max_overlap"],
                                   v_max=max(100.0, 20.0 * math.sqrt(2.0 * E))),
                     tags={"original": ids, "generation": np.zeros(len(ids), np.int64)})
    ore_on_steel = sim.pair_params[table.index[ore.name], table.index["steel"]]
    t_c = float(sim.law.contact_time(ore_on_steel, m_eff, r_eff, max(speed, 1e-3)))
    return Setup(values, mat, steel, share, E, speed, m, sim, x[:n].copy(), t_c, seed)


class ParticleEvent(NamedTuple):
    """One breakage event (written as the event_<field> variables of the case file)."""

    time: float  # [s]
    particle: int  # the original particle it comes from
    generation: int  # 0: original, 1: its progeny, ...
    parent_diameter: float  # of the breaking particle [m]
    specific_energy: float  # absorbed, at breakage [J kg-1]
    fracture_energy: float  # exceeded [J kg-1]
    t10: float  # t10' of the event (family grid value) [%]
    family: int  # drawn (-1: no replacement)
    progeny: int  # resolved progeny spheres
    fines_mass: float  # unresolved fines (dummy class) [kg]


class Books:
    """Breakage records of a run, per original particle and per event."""

    def __init__(self, s: Setup, replace: TavaresReplacement | None):
        n = s.values["n_particles"]
        self.s = s
        self.replace = replace
        self.impact = 1
        self.broken_at = np.zeros(n, np.int64)  # impact at which the original broke (0: never)
        self.absorbed = np.full(n, np.nan)  # absorbed specific energy of the breaking event
        self.e_break = np.full(n, np.nan)  # (damaged) fracture energy it exceeded
        self.t10_primary = np.full(n, np.nan)
        self.events = []  # a ParticleEvent per breakage

    def on_fracture(self, sim):
        s = self.s
        e_frac = sim.breakage.e_frac.copy()
        if self.replace is None:
            # counted only: the particle stays as an unbreakable stand-in for its fragments
            # (removing it could leave no free particle at all) and is retired from the books
            rows = sim.pop_events()
            broke = np.array([r.particle for r in rows], np.int64)
            specific = np.array([r.specific_energy for r in rows])
            t10 = tavares.t10_prime(s.mat, specific, e_frac[broke])
            parents, gens = s.ids[broke], s.gen[broke]
            sim.breakage.e_frac[broke] = np.inf
            s.gen[broke] = -1
            for pid, g, e, E, t in zip(parents, gens, specific, e_frac[broke], t10):
                self.events.append(ParticleEvent(sim.time, pid, g, s.values["diameter"], e, E, t,
                                                 -1, 0, 0.0))
        else:
            k0 = len(self.replace.events)
            self.replace(sim)
            new = self.replace.events[k0:]
            broke = self.replace.last_broken
            specific = np.array([ev.specific_energy for ev in new])
            t10 = np.array([ev.t10 for ev in new])
            # (the progeny carry their parent's tags, generation + 1)
            parents = self.replace.last_parent_tags["original"]
            gens = self.replace.last_parent_tags["generation"]
            for ev, pid, g in zip(new, parents, gens):
                self.events.append(ParticleEvent(ev.time, pid, g, ev.parent_diameter,
                                                 ev.specific_energy, ev.fracture_energy, ev.t10,
                                                 ev.family, ev.progeny, ev.fines_mass))
        for j, (pid, g) in enumerate(zip(parents, gens)):
            if g == 0 and pid >= 0 and self.broken_at[pid] == 0:
                self.broken_at[pid] = self.impact
                self.absorbed[pid] = specific[j]
                self.e_break[pid] = e_frac[broke[j]]
                self.t10_primary[pid] = t10[j]


def _quiet(sim, v_tol):
    """The impact is over: no particle is in a loading event, none approaches the plate and no pair
    approaches each other faster than ``v_tol`` (no gravity: nothing comes back). Approaches
    slower than v_tol = 10 % of the impact speed carry 1 % of the set energy, far below the
    fracture energy of any fragment (fragments squeezed out sideways keep flying slowly towards
    the plate for milliseconds)."""
    p = sim.particles
    if (sim.breakage.e_acc > 0).any() or (p.v[:, 2] < -v_tol).any():
        return False
    i, j, _ = sim.contact_pairs()
    if len(i):
        d = p.x[i] - p.x[j]
        vn = np.einsum("ij,ij->i", p.v[i] - p.v[j], d) / np.linalg.norm(d, axis=1)
        if (vn < -v_tol).any():
            return False
    return True


def _reset_survivors(s: Setup):
    """Put every unbroken original back above the plate with the impact velocity (the retired
    stand-ins of the broken ones leave)."""
    sim = s.sim
    sim.remove_particles(s.gen < 0)  # the tags follow
    p = sim.particles
    p.x[:] = s.home[s.ids]
    p.v[:] = [0.0, 0.0, -s.speed]
    p.w[:] = 0.0
    # free flight again: no force (the last impact may have ended with a contact still unloading,
    # and a leftover acceleration would be applied in the first step of the next impact)
    sim.restart_free_flight()


def absorbed_from_damage(e_before, e_after, gamma):
    """Absorbed specific energy of one unbroken event, from the damage it did (eq 6 inverted):
    r = D^(5/(2 gamma)) (2 gamma - 5 D + 5)/(2 gamma), D = 1 - E_after/E_before."""
    D = 1.0 - np.asarray(e_after, float) / np.asarray(e_before, float)
    c = 2.0 * gamma
    with np.errstate(invalid="ignore"):
        r = np.clip(D, 0.0, 1.0) ** (5.0 / c) * (c - 5.0 * D + 5.0) / c
    return r * np.asarray(e_before, float)


def _product(s: Setup, books: Books, sieves, unbreakable="eq13"):
    """Cumulative % passing ``sieves`` (x/d0) of each original's product and the worst relative
    mass balance. Fines of each event are spread below x_min by eq 11 with the event's t10';
    resolved-unbreakable spheres that recorded a breaking event by eq 13 (``unbreakable="eq13"``,
    Fig 14 of Tavares et al. 2021) or kept at their size (``"keep"``, Fig 13)."""
    sim, n, d0 = s.sim, s.values["n_particles"], s.values["diameter"]
    p = sim.particles
    m0 = s.mass
    mine = s.ids >= 0
    d = 2.0 * p.radius[mine]
    mass = s.mat.density * math.pi / 6.0 * d**3
    owner = s.ids[mine]
    t10_recorded = sim.breakage.t10_recorded[mine]
    per = np.zeros((n, len(sieves)))
    for pid in np.unique(owner):
        own = owner == pid
        per[pid] = product_passing(d[own], mass[own], t10_recorded[own], s.mat, sieves * d0,
                                   unbreakable)
    fines_total = np.zeros(n)
    for ev in books.events:
        if ev.fines_mass > 0:
            pid = int(ev.particle)
            per[pid] += ev.fines_mass * tavares.fines_passing(ev.t10, sieves * d0 / ev.parent_diameter,
                                                              s.mat)
            fines_total[pid] += ev.fines_mass
    resolved = np.bincount(owner, weights=mass, minlength=n)
    balance = float(np.max(np.abs(resolved + fines_total - m0)) / m0)
    return 100.0 * per / m0, balance


def _repeated(values):
    return values["mode"] == "repeated"


def _replacing(values):
    """Broken particles are replaced by their progeny (not in repeated impacts)."""
    return values["replacement"] and not _repeated(values)


class SingleParticleCase(Case):
    """Impacts one after another: each runs until it is over (nothing loads, approaches or falls
    back) or the time cap; between impacts the survivors are put back in free flight."""

    outputs = (
        Output("particle", ("particle",), "1", "particle index", coord=True),
        Output("impact", ("impact",), "1", "impact number", coord=True),
        Output("event", ("event",), "1", "breakage event", coord=True),
        Output("sieve", ("sieve",), "1", "sieve size / initial diameter", coord=True,
               when=_replacing),
        # per particle
        Output("particle_broken", ("particle",), "1", "broke (1) or not (0)"),
        Output("particle_broken_at_impact", ("particle",), "1", "impact at which it broke (0: never)"),
        Output("particle_fracture_energy_initial", ("particle",), "J kg-1",
               "fracture energy drawn at creation (absorbed basis)"),
        Output("particle_fracture_energy_final", ("particle",), "J kg-1",
               "damaged fracture energy at the end (NaN: broke)"),
        Output("particle_fracture_energy_at_break", ("particle",), "J kg-1",
               "(damaged) fracture energy the breaking event reached"),
        Output("particle_absorbed_energy", ("particle",), "J kg-1", "absorbed specific energy of "
               "the first event (at breakage if it broke; from its damage, eq 6 inverted, if not)"),
        Output("particle_t10_primary", ("particle",), "%", "t10' of its primary breakage event (eq 8)"),
        # the broken fraction against the analytic probability, and the inputs
        Output("n_particles", (), "1", "particles stressed"),
        Output("n_broken", (), "1", "particles broken"),
        Output("broken_fraction", (), "1", "fraction broken"),
        Output("broken_fraction_ci_lo", (), "1", "95% Clopper-Pearson lower bound"),
        Output("broken_fraction_ci_hi", (), "1", "95% Clopper-Pearson upper bound"),
        Output("specific_energy", (), "J kg-1", "set input (stressing) specific energy Ek/m"),
        Output("energy_ratio", (), "1", "Ek/m over the stressing-basis median E50"),
        Output("absorbed_share", (), "1", "absorbed share of the input energy, eq 4 vs steel"),
        Output("impact_speed", (), "m s-1",
               "speed of the particle (single, repeated) or striker (drop_weight)"),
        Output("median_fracture_energy", (), "J kg-1", "E50 (absorbed basis, eq 3)"),
        Output("gamma_used", (), "1", "damage coefficient used"),
        Output("converged", ("impact",), "1", "impact ended before the time cap"),
        Output("impact_broken_fraction", ("impact",), "1",
               "cumulative fraction broken after each impact", when=_repeated),
        Output("impact_broken_fraction_ci_lo", ("impact",), "1", "95% Clopper-Pearson lower",
               when=_repeated),
        Output("impact_broken_fraction_ci_hi", ("impact",), "1", "95% Clopper-Pearson upper",
               when=_repeated),
        Output("impact_broken_fraction_analytic", ("impact",), "1", "damage model, eqs 1-6",
               when=_repeated),
        Output("broken_fraction_analytic", (), "1",
               "analytic probability (eqs 1-3; after all impacts for repeated)"),
        # event_<field> for every field of a ParticleEvent
        Output("event_time", ("event",), "s", "time of breakage"),
        Output("event_particle", ("event",), "1", "original particle"),
        Output("event_generation", ("event",), "1", "0: original, 1: its progeny, ..."),
        Output("event_parent_diameter", ("event",), "m", "diameter of the breaking particle"),
        Output("event_specific_energy", ("event",), "J kg-1", "absorbed specific energy at breakage"),
        Output("event_fracture_energy", ("event",), "J kg-1", "fracture energy exceeded"),
        Output("event_t10", ("event",), "%", "t10' of the event (family grid value)"),
        Output("event_family", ("event",), "1", "family drawn (-1: no replacement)"),
        Output("event_progeny", ("event",), "1", "resolved progeny spheres"),
        Output("event_fines_mass", ("event",), "kg", "unresolved fines (dummy class) mass"),
        Output("t10_primary_model", (), "%", "eq 9: t10' at breakage at the fracture energy"),
        # the progeny against the model (with particle replacement)
        Output("particle_product_t10", ("particle",), "%",
               "% of its product passing d0/10 (broken only)", when=_replacing),
        Output("particle_progeny", ("particle",), "1", "resolved spheres it ended as",
               when=_replacing),
        Output("product_passing", ("sieve",), "%", "cumulative % passing of the broken particles' "
               "product (fines included, resolved-unbreakable spheres by eq 13)",
               "mean over the broken particles of their own product's passing", when=_replacing),
        Output("product_passing_spheres", ("sieve",), "%", "the same with resolved-unbreakable "
               "spheres kept at their size (Fig 13 of Tavares et al. 2021)", when=_replacing),
        Output("unbreakable_records", (), "1", "resolved-unbreakable spheres that reached their "
               "fracture energy (eq 13 applied)", when=_replacing),
        Output("product_passing_model", ("sieve",), "%",
               "model: eq 10 at the eq 7 t10, eqs 11-12 below d/75", when=_replacing),
        Output("product_t10", (), "%", "t10 of the broken particles' product", when=_replacing),
        Output("product_t10_ci_lo", (), "%", "95% bootstrap lower",
               "percentile bootstrap of the mean over the broken particles", when=_replacing),
        Output("product_t10_ci_hi", (), "%", "95% bootstrap upper", when=_replacing),
        Output("product_t10_expected", (), "%", "mean of eq 8 over the particles that break",
               when=_replacing),
        Output("product_t10_spread", (), "%", "model standard deviation of one broken particle's "
               "product t10 (fracture energy and family drawn)", when=_replacing),
        Output("product_t10_p_value", (), "1", "two-sided p-value of product_t10 against the "
               "model's distribution of the mean of the broken (Monte Carlo)", when=_replacing),
        Output("product_t10_model", (), "%", "eq 7, E50b = median of the broken", when=_replacing),
        Output("product_t10_model_all", (), "%", "eq 7, E50b = median of all", when=_replacing),
        Output("fines_mass", (), "kg", "unresolved fines mass", when=_replacing),
        Output("mass_balance_error", (), "1",
               "max over particles |resolved + fines - initial| / initial mass", when=_replacing),
    )

    def __init__(self, values):
        super().__init__()
        self.values = values
        self.s = s = build(values)
        self.sim = sim = s.sim
        n = values["n_particles"]
        self.mode = values["mode"]
        self.replacing = _replacing(values)
        self.replace = TavaresReplacement({s.mat.name: s.mat},
                                          d_min=progeny_families.global_min_size(values["diameter"]),
                                          seed=s.case_seed, dummy_as="fines",
                                          breakage_at=values["breakage_at"])
        originals = np.flatnonzero(s.ids >= 0)
        self.replace.assign_fracture_energies(sim, originals)
        self.e_initial = sim.breakage.e_frac[originals].copy()
        self.books = Books(s, self.replace if self.replacing else None)
        self.impacts = values["impacts"] if self.mode == "repeated" else 1
        self.converged, self.per_impact = [], []
        self.absorbed_first = np.full(n, np.nan)
        self.impact_done = False
        self._begin_impact(1)

    def _begin_impact(self, k):
        self.books.impact = k
        self.t_end = self.sim.time + self.values["contact_times"] * self.s.t_contact

    def on_events(self, sim):
        self.books.on_fracture(sim)

    def chunk(self):
        return max(10, int(0.25 * self.s.t_contact / self.sim.dt))

    def after_chunk(self):
        s, sim = self.s, self.sim
        quiet = _quiet(sim, 0.1 * s.speed)
        if not quiet and sim.time < self.t_end:
            return
        k = self.books.impact
        self.converged.append(quiet)
        self.per_impact.append(int((self.books.broken_at > 0).sum()))
        alive = (s.gen == 0) & (s.ids >= 0)
        if k == 1:
            # absorbed energy of the first event of the survivors, from the damage it did
            n = self.values["n_particles"]
            e_now = np.full(n, np.nan)
            e_now[s.ids[alive]] = sim.breakage.e_frac[alive]
            surv = np.isfinite(e_now)
            self.absorbed_first[surv] = absorbed_from_damage(self.e_initial[surv], e_now[surv],
                                                             s.mat.gamma)
        if k == self.impacts:
            self.impact_done = True
        elif not alive.any():
            self.per_impact += [self.per_impact[-1]] * (self.impacts - k)
            self.converged += [True] * (self.impacts - k)
            self.impact_done = True
        else:
            _reset_survivors(s)
            self._begin_impact(k + 1)

    def done(self):
        return self.impact_done

    def progress(self):
        k = self.books.impact
        within = 1.0 - max(self.t_end - self.sim.time, 0.0) / (
            self.values["contact_times"] * self.s.t_contact)
        return (k - 1 + within) / self.impacts, f"impact {k}, {int((self.books.broken_at > 0).sum())} broken"

    def finish(self):
        broken = self.books.broken_at > 0
        data = {"particle": np.arange(self.values["n_particles"]),
                "impact": np.arange(1, len(self.converged) + 1),
                "event": np.arange(len(self.books.events))}
        data.update(self._particle_outputs(broken))
        data.update(self._summary_outputs(broken))
        data.update({f"event_{name}": np.array([getattr(ev, name) for ev in self.books.events],
                                               dtype=float) for name in ParticleEvent._fields})
        data["t10_primary_model"] = tavares.t10_min(self.s.mat)
        if self.replacing:
            data.update(self._product_outputs(broken))
        return data

    def provenance(self):
        s = self.s
        return {"case_seed": s.case_seed, "contact_time_s": s.t_contact, "gravity": "off",
                "energy_basis": "input (stressing) Ek/m; absorbed = absorbed_share x Ek/m"}

    def _particle_outputs(self, broken):
        """Per particle: whether and when it broke, its fracture energies and absorbed energy."""
        s, books, absorbed_first = self.s, self.books, self.absorbed_first
        first = broken & (books.broken_at == 1)
        absorbed_first[first] = books.absorbed[first]
        e_final = np.full(self.values["n_particles"], np.nan)
        alive = (s.gen == 0) & (s.ids >= 0)
        e_final[s.ids[alive]] = self.sim.breakage.e_frac[alive]
        return {"particle_broken": broken.astype(np.int8),
                "particle_broken_at_impact": books.broken_at,
                "particle_fracture_energy_initial": self.e_initial,
                "particle_fracture_energy_final": e_final,
                "particle_fracture_energy_at_break": books.e_break,
                "particle_absorbed_energy": absorbed_first,
                "particle_t10_primary": books.t10_primary}

    def _summary_outputs(self, broken):
        """The broken fraction with its confidence interval against the analytic probability,
        per impact for repeated impacts, and the inputs it was drawn at."""
        s, n, d0 = self.s, self.values["n_particles"], self.values["diameter"]
        nb = int(broken.sum())
        lo, hi = binomial_interval(nb, n)
        data = {"n_particles": n, "n_broken": nb, "broken_fraction": nb / n,
                "broken_fraction_ci_lo": float(lo), "broken_fraction_ci_hi": float(hi),
                "specific_energy": s.specific_energy,
                "energy_ratio": s.specific_energy / tv.stressing_median(s.mat, d0, s.share),
                "absorbed_share": s.share, "impact_speed": s.speed,
                "median_fracture_energy": float(tavares.median_fracture_energy(s.mat, d0)),
                "gamma_used": s.mat.gamma, "converged": np.array(self.converged, np.int8)}
        analytic = float(tv.breakage_probability(s.mat, d0, s.specific_energy, s.share))
        if self.mode == "repeated":
            cum = np.array(self.per_impact, float)
            ilo, ihi = binomial_interval(cum, n)
            data.update(impact_broken_fraction=cum / n, impact_broken_fraction_ci_lo=ilo,
                        impact_broken_fraction_ci_hi=ihi,
                        impact_broken_fraction_analytic=tv.repeated_impact_broken(
                            s.mat, d0, s.specific_energy, s.share, self.impacts))
            analytic = float(data["impact_broken_fraction_analytic"][-1])
        data["broken_fraction_analytic"] = analytic
        return data

    def _product_outputs(self, broken):
        """The progeny of the broken particles against the model: t10 and product passing (with
        particle replacement only)."""
        values, s, sim, books, replace = self.values, self.s, self.sim, self.books, self.replace
        n, d0, nb = values["n_particles"], values["diameter"], int(broken.sum())
        per, balance = _product(s, books, np.append(SIEVES, 0.1))
        t10_each = np.where(broken, per[:, -1], np.nan)
        per = per[:, :-1]
        passing = per[broken].mean(0) if nb else np.full(len(SIEVES), np.nan)
        kept, _ = _product(s, books, SIEVES, unbreakable="keep")
        passing_kept = kept[broken].mean(0) if nb else np.full(len(SIEVES), np.nan)
        recorded = np.isfinite(sim.breakage.t10_recorded) & (s.ids >= 0)
        t10_pool = float(np.nanmean(t10_each)) if nb else math.nan
        blo, bhi = bootstrap_interval(t10_each[broken], seed=s.case_seed) if nb else (math.nan, math.nan)
        return {"sieve": SIEVES, "particle_product_t10": t10_each,
                "particle_progeny": np.bincount(s.ids[s.ids >= 0], minlength=n),
                "product_passing": passing, "product_passing_spheres": passing_kept,
                "unbreakable_records": int(recorded.sum()),
                "product_passing_model": tv.product_passing_model(s.mat, d0, s.specific_energy,
                                                                  s.share, SIEVES),
                "product_t10": t10_pool, "product_t10_ci_lo": blo, "product_t10_ci_hi": bhi,
                "product_t10_expected": tv.t10_expected(s.mat, d0, s.specific_energy, s.share),
                "product_t10_spread": tv.t10_spread(s.mat, d0, s.specific_energy, s.share),
                "product_t10_p_value": tv.t10_p_value(s.mat, d0, s.specific_energy, s.share,
                                                      t10_pool, nb, seed=s.case_seed),
                "product_t10_model": tv.t10_model(s.mat, d0, s.specific_energy, s.share),
                "product_t10_model_all": tv.t10_model(s.mat, d0, s.specific_energy, s.share, "all"),
                "fines_mass": replace.fines_mass, "mass_balance_error": balance}


register(Scene("single_particle", "single-particle impact, drop-weight and repeated-impact tests of "
               "the Tavares model against its analytic predictions "
               "(Tavares et al. 2021, section 4.1)", PARAMS, SingleParticleCase, (_check,),
               wall_materials=lambda values: (values["material"], "steel")))
