"""Scene ``stirred_mill``: wet horizontal stirred media mill with pairwise lubrication
(the LabStar LS1 paper).

A horizontal cylindrical chamber (axis x, gravity -z) with a perforated-disk agitator: disks made
of rigid spheres on one kinematic ``rotate`` body plus a rotating analytic shaft. The liquid enters
only as pairwise Jeffrey-Onishi lubrication (``engine/lubrication.py``) between beads, bead-disk
and bead-wall pairs; with ``eta = 0`` the scene is dry and no lubrication code is compiled.
Contacts: linear spring-dashpot with history and Coulomb friction (eqs 2-4 of the LS1 paper); the
stiffness comes from E and nu through the LIGGGHTS ``hooke`` formula at a characteristic velocity.

Geometry (LabStar LS1 drawings are not public; every dimension is an approximation chosen so that
the void volume is the LS1 paper's Table 2 value, 0.910 l): the chamber length follows from the void
volume and the other dimensions (``docs/stirred_mill.md`` gives the arithmetic). ``slice`` runs one
disk in an axially periodic slice of length chamber_length / disks; ``scale`` shrinks the chamber
and agitator (not the beads) for quick studies. Outputs: agitator torque and power vs time, steady
state (MSER-5), mean net power with a block-mean confidence interval, the energy balance, the
contact-typology split, collision frequency in 9 regions and coarse-grained velocities on a slab.
"""

import math

import numpy as np
from scipy.spatial import cKDTree

from ..engine import Guards, PhysicsSpec, Simulation
from ..models import Interaction, Lubrication, Material, MaterialTable
from ..models.lubrication import AUTO_STEP_RATIO, SCHEMES, TOLERANCE, check_lubrication_params
from ..util.memory import RECORD_VALUE_BYTES, check_memory
from ..util.stats import block_mean_ci, mser5
from .base import (
    TIME_STEP_PARAMS,
    DriveMark,
    Param,
    Scene,
    check_particle_memory,
    register,
    step_policy,
)
from .config_walls import scene_walls
from .driver import Case, Output, Series
from .stirred_observables import (
    AUDIT,
    CG_FIELDS,
    Sampler,
    drive_state,
    energy_balance,
    energy_state,
    typology,
)

G = 9.81
AXIS = np.array([1.0, 0.0, 0.0])
SHAFT_WALL = 1  # index of the shaft in build()'s walls
TYPOLOGY = ("impact", "torsion", "shearing", "rolling")
REGIONS = tuple(f"{r}{a}" for r in "123" for a in "FCB")

PARAMS = (
    # operation
    Param("rpm", 2500.0, "agitator speed", "min-1", 0.0, lo_open=True),
    Param("eta", 0.0, "simulation viscosity eta_f,sim of the pairwise lubrication; 0 = dry "
          "(no lubrication code compiled)", "Pa s", 0.0),
    Param("h_min", 0.001, "lubrication inner cutoff, fraction of the smaller diameter of a pair",
          "1", 0.0, lo_open=True),
    Param("h_max", 0.05, "lubrication outer cutoff, fraction of the smaller diameter of a pair",
          "1", 0.0, 0.5, True, True),
    Param("lubrication_scheme", "explicit", "integration of the lubrication: explicit (the "
          "automatic step resolves the squeeze relaxation time at h_min), implicit (backward-"
          "Euler impulses solved each step; the contacts set the step) or auto (implicit where "
          f"the explicit step would be over {AUTO_STEP_RATIO:g}x below the dry one, where it is "
          "the cheaper; the case file says which ran; docs/lubrication.md)",
          choices=SCHEMES),
    Param("lubrication_tolerance", TOLERANCE, "implicit scheme: relative residual at which the "
          "solve of each step stops", "1", 0.0, 1.0, True, True),
    Param("filling", 0.432, "bead solid volume / void volume (Table 2: 0.393 l / 0.910 l)", "1",
          0.0, 0.74, True, True),
    Param("n_beads", 0, "number of beads; 0 = from filling", "1", 0),
    # beads (Table 2)
    Param("bead_diameter_min", 1.8e-3, "smallest bead diameter (diameters uniform in [min, max])",
          "m", 0.0, lo_open=True),
    Param("bead_diameter_max", 2.0e-3, "largest bead diameter", "m", 0.0, lo_open=True),
    Param("density", 6000.0, "bead density", "kg m-3", 0.0, lo_open=True),
    Param("youngs_modulus", 5e6, "Young's modulus (reduced 1e3 as in the LS1 paper)", "Pa", 0.0,
          lo_open=True),
    Param("poisson_ratio", 0.45, "Poisson ratio", "1", 0.0, 0.5, False, True),
    Param("restitution", 0.5, "coefficient of restitution (sets the damping ratio)", "1", 0.0, 1.0,
          lo_open=True),
    Param("friction", 0.3, "Coulomb friction coefficient mu_c (calibrated; every pair)", "1", 0.0),
    Param("tangential_stiffness_ratio", 2.0 / 7.0, "k_t / k_n", "1", 0.0, lo_open=True),
    Param("characteristic_velocity", 5.0, "v_c of the LIGGGHTS hooke stiffness "
          "k_n = 16/15 sqrt(R*) Y* (15 m* v_c^2 / (16 sqrt(R*) Y*))^(1/5)", "m s-1", 0.0,
          lo_open=True),
    # geometry (approximations of the LS1, full scale; see docs/stirred_mill.md)
    Param("void_volume", 0.910e-3, "chamber volume minus agitator at scale 1 (Table 2)", "m3", 0.0,
          lo_open=True),
    Param("chamber_radius", 0.042, "inner radius of the chamber (approximation)", "m", 0.0,
          lo_open=True),
    Param("shaft_radius", 0.012, "agitator shaft radius (approximation)", "m", 0.0, lo_open=True),
    Param("disks", 4, "perforated disks on the shaft (approximation)", "1", 1),
    Param("disk_radius", 0.034, "disk outer radius (approximation)", "m", 0.0, lo_open=True),
    Param("disk_thickness", 0.008, "disk thickness (approximation)", "m", 0.0, lo_open=True),
    Param("holes", 4, "holes per disk (approximation)", "1", 0),
    Param("hole_radius", 0.008, "hole radius (approximation)", "m", 0.0),
    Param("hole_pitch_radius", 0.022, "radius of the circle through the hole centres", "m", 0.0),
    Param("agitator_particle_radius", 0.9e-3, "radius of the spheres the disks are built of "
          "(capped at half the scaled disk thickness)", "m", 0.0, lo_open=True),
    Param("scale", 1.0, "geometric scale of chamber and agitator (beads unchanged)", "1", 0.0, 1.0,
          lo_open=True),
    Param("slice", False, "periodic axial slice around one disk (length chamber_length / disks)"),
    # run
    Param("revolutions", 8.0, "simulated agitator revolutions", "1", 0.0, lo_open=True),
    Param("transient_revolutions", 3.0, "revolutions always excluded from steady-state "
          "statistics (the detected steady state may start later)", "1", 0.0),
    Param("ramp_revolutions", 0.0, "start-up: the agitator accelerates from rest to rpm at a "
          "constant rate over the time of this many revolutions at full speed (0: full speed from "
          "the start; a lattice start at 2500 rpm and above needs one); within the transient",
          "1", 0.0),
    Param("records_per_revolution", 40, "torque/power records per revolution", "1", 4),
    Param("initial_swirl", 0.1, "initial bead velocity as a fraction of rigid rotation", "1", 0.0,
          1.0),
    *TIME_STEP_PARAMS,
    Param("contact_samples_per_contact", 3, "contact samples per bead-bead contact time "
          "(collision detection)", "1", 1),
    Param("ci_blocks", 8, "blocks of the net-power confidence interval", "1", 2),
    Param("cg_cells", 16, "cells per side of the coarse-grained velocity grid", "1", 2),
    Param("skin", 0.5e-3, "Verlet list skin (agitator spheres move fast: a list rebuild costs "
          "several steps)", "m", 0.0, lo_open=True),
    Param("max_overlap", 0.75, "guard: overlap / smaller radius that stops the run (soft 5 MPa "
          "beads: the disk spheres' first hits at ~6 m/s reach 0.5)", "1", 0.0, 1.0, True, False),
    Param("seed", 1, "random seed", "1", 0),
)


def _check(values):
    if values["bead_diameter_min"] > values["bead_diameter_max"]:
        raise ValueError("bead_diameter_min: must not exceed bead_diameter_max")
    if values["transient_revolutions"] >= values["revolutions"]:
        raise ValueError("transient_revolutions: must be smaller than revolutions")
    if values["ramp_revolutions"] > values["transient_revolutions"]:
        raise ValueError("ramp_revolutions: the start-up must lie within transient_revolutions "
                         f"({values['transient_revolutions']:g})")
    if values["shaft_radius"] >= values["disk_radius"] or values["disk_radius"] >= values["chamber_radius"]:
        raise ValueError("disk_radius: need shaft_radius < disk_radius < chamber_radius")
    if values["holes"] and not (values["shaft_radius"] < values["hole_pitch_radius"] - values["hole_radius"]
                                and values["hole_pitch_radius"] + values["hole_radius"] < values["disk_radius"]):
        raise ValueError("hole_radius: holes must lie between shaft and disk rim")
    # eta < 0, h_min >= h_max, h_max >= d/2: the engine's own check, before any job runs
    check_lubrication_params(values["eta"], values["h_min"], values["h_max"])
    check_particle_memory("n_beads" if values["n_beads"] else "filling (n_beads from it)",
                          geometry(values)["n_beads"])
    # upper bounds from the memory of what the case keeps (util.memory), before anything is built:
    # the coarse-grained fields (5 sums, their quotients and the written copies) and the records
    check_memory("cg_cells", values["cg_cells"], lambda n: 14 * 8 * n**2, "cells per side",
                 "about 14 grids of cg_cells^2 values, 8 B each")
    per_record = (len(StirredMillCase.series) + 1) * RECORD_VALUE_BYTES
    check_memory("records_per_revolution", values["records_per_revolution"],
                 lambda n: math.ceil(n * values["revolutions"]) * per_record,
                 "records per revolution",
                 f"{values['revolutions']:g} revolutions of records, {per_record} B each")


def geometry(values):
    """Scaled dimensions [m], chamber length from the void volume, and the bead count."""
    s = values["scale"]
    g = {k: values[k] * s for k in ("chamber_radius", "shaft_radius", "disk_radius",
                                    "disk_thickness", "hole_radius", "hole_pitch_radius")}
    disk_area = math.pi * (g["disk_radius"] ** 2 - g["shaft_radius"] ** 2) \
        - values["holes"] * math.pi * g["hole_radius"] ** 2
    g["disk_volume"] = disk_area * g["disk_thickness"]
    void = values["void_volume"] * s**3
    annulus = math.pi * (g["chamber_radius"] ** 2 - g["shaft_radius"] ** 2)
    g["chamber_length"] = (void + values["disks"] * g["disk_volume"]) / annulus
    g["pitch"] = g["chamber_length"] / values["disks"]
    if values["slice"]:
        g["void_volume"] = void / values["disks"]
        g["x_lo"], g["length"] = -0.5 * g["pitch"], g["pitch"]
        g["disk_x"] = np.array([0.0])
    else:
        g["void_volume"] = void
        g["x_lo"], g["length"] = 0.0, g["chamber_length"]
        g["disk_x"] = (np.arange(values["disks"]) + 0.5) * g["pitch"]
    d0, d1 = values["bead_diameter_min"], values["bead_diameter_max"]
    mean_d3 = d0**3 if d1 == d0 else (d1**4 - d0**4) / (4 * (d1 - d0))
    g["bead_volume"] = math.pi / 6 * mean_d3
    g["n_beads"] = values["n_beads"] or int(round(values["filling"] * g["void_volume"] / g["bead_volume"]))
    g["omega"] = values["rpm"] * 2 * math.pi / 60
    g["tip_speed"] = g["omega"] * g["disk_radius"]
    g["ramp"] = values["ramp_revolutions"] * 60.0 / values["rpm"]  # start-up time [s]
    return g


def contact_stiffness(values):
    """LIGGGHTS hooke k_n for the mean bead pair: Y* = E / (2 (1 - nu^2)), R* = r/2, m* = m/2."""
    r = 0.25 * (values["bead_diameter_min"] + values["bead_diameter_max"])
    m = values["density"] * 4 / 3 * math.pi * r**3
    y_star = values["youngs_modulus"] / (2 * (1 - values["poisson_ratio"] ** 2))
    r_star, m_star, vc = 0.5 * r, 0.5 * m, values["characteristic_velocity"]
    sq = math.sqrt(r_star)
    return 16 / 15 * sq * y_star * (15 * m_star * vc**2 / (16 * sq * y_star)) ** 0.2


def _disk_particles(values, g):
    """Centres and radius of the spheres forming the perforated disks (staggered hex layers)."""
    t = g["disk_thickness"]
    rp = min(values["agitator_particle_radius"], 0.5 * t)
    a = 1.3 * rp  # in-plane spacing: a bead (>= 0.9 mm) cannot pass between the spheres
    layers = max(1, int(round(t / (2 * rp))))
    xs = np.linspace(-0.5 * t + rp, 0.5 * t - rp, layers) if layers > 1 else np.zeros(1)
    R = g["disk_radius"]
    n = int(math.ceil(R / a)) + 2
    iy, iz = np.meshgrid(np.arange(-n, n + 1), np.arange(-n, n + 1), indexing="ij")
    pts = []
    for k, x in enumerate(xs):
        y = (iy + 0.5 * (iz % 2) + 0.5 * (k % 2)) * a
        z = iz * a * math.sqrt(3) / 2 + (k % 2) * a / (2 * math.sqrt(3))
        y, z = y.ravel(), z.ravel()
        rho = np.hypot(y, z)
        keep = (rho <= R - rp) & (rho >= g["shaft_radius"] + 0.5 * rp)
        for h in range(values["holes"]):
            phi = 2 * math.pi * h / values["holes"]
            cy, cz = g["hole_pitch_radius"] * math.cos(phi), g["hole_pitch_radius"] * math.sin(phi)
            keep &= np.hypot(y - cy, z - cz) >= g["hole_radius"]
        pts.append(np.column_stack([np.full(keep.sum(), x), y[keep], z[keep]]))
    one = np.vstack(pts)
    return np.vstack([one + [x0, 0, 0] for x0 in g["disk_x"]]), rp


def _place_beads(values, g, disk_x, disk_r, rng):
    """Random choice of FCC lattice sites in the free volume (homogeneous start, no overlaps).

    Sites are d_max (+0.1 %) apart; of a few random lattice offsets the one with most free sites
    is used.
    """
    r_max = 0.5 * values["bead_diameter_max"]
    nn = 2 * r_max * 1.001
    a = nn * math.sqrt(2)
    R = g["chamber_radius"]
    clear = 1.001 * r_max
    lo_x = g["x_lo"] + (0.5 * nn if values["slice"] else clear)
    hi_x = g["x_lo"] + g["length"] - (0.5 * nn if values["slice"] else clear)
    cells = np.arange(-math.ceil(R / a) - 1, math.ceil(R / a) + 2)
    cx = np.arange(0, math.ceil((hi_x - lo_x) / a) + 1)
    base = np.array([[0, 0, 0], [0, 0.5, 0.5], [0.5, 0, 0.5], [0.5, 0.5, 0]])
    ci, cj, ck = np.meshgrid(cx, cells, cells, indexing="ij")
    corner = np.column_stack([ci.ravel(), cj.ravel(), ck.ravel()]).astype(float)
    lattice = ((corner[:, None, :] + base[None]) * a).reshape(-1, 3)
    tree = cKDTree(disk_x) if len(disk_x) else None
    best = None
    for trial in range(6):
        shift = np.array([0.0, *rng.uniform(0, a, 2)]) if trial else np.zeros(3)
        sites = lattice + shift
        sites[:, 0] += lo_x
        rho = np.hypot(sites[:, 1], sites[:, 2])
        ok = (sites[:, 0] <= hi_x) & (rho <= R - clear) & (rho >= g["shaft_radius"] + clear)
        sites = sites[ok]
        if tree is not None:
            d, _ = tree.query(sites)
            sites = sites[d >= disk_r + clear]
        if best is None or len(sites) > len(best):
            best = sites
    n = g["n_beads"]
    if n > len(best):
        raise ValueError(f"filling: {n} beads do not fit the start lattice ({len(best)} free sites); "
                         f"lower filling or n_beads")
    x = best[rng.choice(len(best), n, replace=False)]
    d = rng.uniform(values["bead_diameter_min"], values["bead_diameter_max"], n)
    return x, 0.5 * d


def build(values):
    """The Simulation of one case, and the geometry it was built from."""
    rng = np.random.default_rng(values["seed"])
    g = geometry(values)
    disk_x, disk_r = _disk_particles(values, g)
    bead_x, bead_r = _place_beads(values, g, disk_x, disk_r, rng)
    omega = g["omega"]
    # initial swirl about the axis: wet beds co-rotate at about 0.1 of rigid, so 0.1 shortens
    # their start-up; dry full-chamber beds at 0.02-0.03, and above 2000 rpm 0.1 holds them at
    # the wall for revolutions (docs/results/stirred_mill.md, "The dry bed sinks")
    v = values["initial_swirl"] * omega * np.cross(AXIS, bead_x * [0, 1, 1])
    nb, nd = len(bead_r), len(disk_x)
    x = np.vstack([bead_x, disk_x])
    radius = np.concatenate([bead_r, np.full(nd, disk_r)])
    vel = np.vstack([v, np.zeros((nd, 3))])
    # agitator spheres spin with the body: their surfaces move rigidly (contact and lubrication)
    w = np.vstack([np.zeros((nb, 3)), np.tile(omega * AXIS, (nd, 1))])
    body = np.concatenate([np.full(nb, -1), np.zeros(nd)]).astype(np.int32)
    material = ["bead"] * nb + ["agitator"] * nd
    k_n = contact_stiffness(values)
    inter = Interaction(restitution=values["restitution"], friction=values["friction"],
                        normal_stiffness=k_n,
                        tangential_stiffness_ratio=values["tangential_stiffness_ratio"])
    table = MaterialTable([Material("bead", values["density"]), Material("agitator", 3800.0),
                           Material("wall", 7800.0)], {"*": inter}, "linear_history")
    wet = values["eta"] > 0
    spec = physics_spec(values["slice"])
    walls = [dict(kind="cylinder_inner", point=(0, 0, 0), axis=AXIS, radius=g["chamber_radius"],
                  material="wall"),
             dict(kind="cylinder_outer", point=(0, 0, 0), axis=AXIS, radius=g["shaft_radius"],
                  omega=0.0 if g["ramp"] else omega, material="agitator")]
    if not values["slice"]:
        walls += [dict(kind="plane", point=(0, 0, 0), normal=(1, 0, 0), material="wall"),
                  dict(kind="plane", point=(g["length"], 0, 0), normal=(-1, 0, 0), material="wall")]
    spec, walls = scene_walls(values, spec, walls)
    periodic = dict(box=((g["x_lo"], 0, 0), (g["length"], 0, 0))) if values["slice"] else {}
    r_min = 0.5 * values["bead_diameter_min"]
    sim = Simulation(spec, table, x=x, radius=radius, material=material, v=vel, w=w, body=body,
                     walls=walls, bodies=[dict(kind="rotate", center=(0, 0, 0), axis=AXIS, rate=omega,
                                               ramp=g["ramp"])],
                     gravity=(0.0, 0.0, -G), skin=values["skin"],
                     step=step_policy(values, impact_speed=max(1.0, g["tip_speed"])),
                     guards=Guards(max_overlap=values["max_overlap"],
                                   v_max=max(50.0, 5 * g["tip_speed"])),
                     fluid=Lubrication(values["eta"], values["h_min"], values["h_max"],
                                       values["lubrication_scheme"],
                                       values["lubrication_tolerance"]) if wet else None,
                     **periodic)
    m_min = values["density"] * 4 / 3 * math.pi * r_min**3
    bead = table.index["bead"]  # the contact time of the step bounds, of two of the smallest beads
    t_c = float(table.law.contact_time(sim.pair_params[bead, bead], 0.5 * m_min, 0.5 * r_min,
                                       max(1.0, g["tip_speed"])))
    g.update(k_n=k_n, t_c=t_c, n_agitator_particles=nd, agitator_particle_radius=disk_r)
    return sim, g


def physics_spec(periodic):
    """The compiled engine options (a dry case, eta = 0, hands the Simulation no fluid, so no
    lubrication code is compiled)."""
    return PhysicsSpec(dim=3, gravity=True, walls=True, bodies=True, periodic=periodic,
                       energy_audit=True)


class StirredMillCase(Case):
    """Transient revolutions recorded every record interval; then the statistics window, sampled
    every few contact times (collisions, coarse-grained fields) and recorded as before; power,
    energy balance and typology over the window."""

    series = (Series("agitator_torque", "N m", "torque the agitator (disks + shaft) supplies, "
                     "record-interval mean"),
              Series("agitator_power", "W", "net power the agitator supplies, record-interval mean"),
              Series("kinetic_energy", "J", "kinetic energy of the beads"))
    time_long_name = "simulated time (end of the record interval)"
    attrs = {"typology_definition": (
        "impact = contact normal damping + lubrication normal; shearing = tangential force x centre "
        "slip + lubrication tangential; rolling = tangential force x rotational slip; torsion = 0 "
        "(no twisting torque in the model)")}
    outputs = (
        Output("typology", ("typology",), "1", "contact typology", coord=True),
        Output("audit_term", ("audit_term",), "1", "dissipation term of the engine audit", coord=True),
        Output("region", ("region",), "1", "region: radial ring 1 (inner) - 3 (outer) x "
               "F(ront)/C(entre)/B(ack) along x", coord=True),
        # CF axes: y horizontal, z vertical (gravity along -z)
        Output("gy", ("gy",), "m", "coarse-graining cell centre y", coord=True, cf={"axis": "Y"}),
        Output("gz", ("gz",), "m", "coarse-graining cell centre z", coord=True,
               cf={"axis": "Z", "positive": "up"}),
        Output("net_power", (), "W", "steady-state mean net power",
               "mean of the recorded power over the averaging window (statistics_start on)"),
        Output("net_power_ci", (), "W", "95% half-width of the net power (block means)",
               "Student t over ci_blocks block means"),
        Output("mean_torque", (), "N m", "steady-state mean agitator torque"),
        Output("mean_torque_ci", (), "N m", "95% half-width of the torque (block means)"),
        Output("steady_state_start", (), "s", "start of the steady state (MSER-5 on the power)"),
        Output("statistics_start", (), "s",
               "start of the averaging window: max(transient, steady-state start)"),
        Output("steady_state_detected", (), "1",
               "1 if the detected steady state starts before the transient ends"),
        Output("energy_in", (), "J", "work of agitator + shaft over the window"),
        Output("delta_kinetic", (), "J", "change of bead kinetic energy over the window"),
        Output("delta_potential", (), "J", "change of potential energy over the window"),
        Output("delta_elastic_normal", (), "J", "change of normal spring energy"),
        Output("delta_elastic_tangential", (), "J",
               "change of tangential spring energy (inside the audit terms)"),
        Output("dissipation", ("audit_term",), "J", "energy dissipated over the window, by audit term"),
        Output("dissipation_power", ("audit_term",), "W",
               "mean dissipated power over the window, by audit term"),
        Output("energy_balance_residual", (), "J", "energy in - (changes + dissipation), window"),
        Output("energy_balance_error", (), "1", "residual / energy in, steady window"),
        Output("energy_balance_error_run", (), "1", "residual / energy in, whole run"),
        Output("typology_energy", ("typology",), "J", "dissipated energy by contact typology, window",
               "the audit terms summed by typology (typology_definition)"),
        Output("typology_fraction", ("typology",), "1",
               "fraction of the dissipated energy by contact typology"),
        Output("collision_rate", ("region",), "s-1", "new bead-bead contacts per second by region",
               "bead pairs in contact at a sample and not at the one before, over the sampled time"),
        Output("collision_frequency_relative", ("region",), "%",
               "relative collision frequency by region"),
        Output("cg_speed", ("gz", "gy"), "m s-1", "coarse-grained translational speed |v| on the slab",
               "mean over the samples of the beads in the slab between the middle disk and the "
               "middle of the next gap"),
        Output("cg_spin", ("gz", "gy"), "rad s-1", "coarse-grained rotational speed |w| on the slab"),
        Output("cg_vy", ("gz", "gy"), "m s-1", "coarse-grained velocity y on the slab"),
        Output("cg_vz", ("gz", "gy"), "m s-1", "coarse-grained velocity z on the slab"),
        Output("cg_samples", ("gz", "gy"), "1", "bead samples per coarse-graining cell"),
        Output("n_bead", (), "1", "beads"),
        Output("n_agitator_particles", (), "1", "spheres forming the disks"),
        Output("chamber_length", (), "m", "chamber length (from the void volume)"),
        Output("domain_length", (), "m", "simulated axial length (slice or chamber)"),
        Output("domain_void_volume", (), "m3", "void volume of the simulated domain"),
        Output("tip_speed", (), "m s-1", "disk tip speed"),
        Output("angular_velocity", (), "rad s-1", "agitator angular velocity"),
    )

    def __init__(self, values):
        super().__init__()
        self.v = values
        self.sim, self.g = sim, g = build(values)
        self.k_n = g["k_n"]
        self.k_t = self.k_n * values["tangential_stiffness_ratio"]
        period = 60.0 / values["rpm"]
        self.sample_steps = max(1, int(g["t_c"] / values["contact_samples_per_contact"] / sim.dt))
        self.per_record = max(1, int(round(period / values["records_per_revolution"] / sim.dt
                                           / self.sample_steps)))
        self.record_steps = self.per_record * self.sample_steps
        self.total = int(round(values["revolutions"] * period / sim.dt / self.record_steps)) \
            * self.record_steps
        self.transient = int(round(values["transient_revolutions"] * period / sim.dt
                                   / self.record_steps)) * self.record_steps
        # the statistics need records after the transient (a shorter run ended in an IndexError)
        if self.total - self.transient < 2 * self.record_steps:
            per_record = self.record_steps * sim.dt / period
            raise ValueError(
                f"revolutions: {values['revolutions']:g} leaves fewer than 2 records after the "
                f"{values['transient_revolutions']:g} transient revolutions (a record every "
                f"{per_record:.3g} revolutions); allowed revolutions >= transient_revolutions + "
                f"{2 * per_record:.3g}")
        self.smp = Sampler(values, g)
        self.attrs = dict(self.attrs, cg_slab_x=np.array(self.smp.slab))
        self.last = DriveMark(*drive_state(sim), sim.time)
        self.start = energy_state(sim, self.k_n, self.k_t)
        self.window_start = None
        self.samples = 0
        self.shaft_rate = 0.0  # the shaft's speed / full speed during the start-up
        if self.transient == 0:
            self._open_window()

    def _record(self):
        sim = self.sim
        impulse, work = drive_state(sim)
        span = sim.time - self.last.time
        self.record(sim.time, agitator_torque=(impulse - self.last.angular_impulse) / span,
                    agitator_power=(work - self.last.work) / span,
                    kinetic_energy=sim.kinetic_energy())
        self.last = DriveMark(impulse, work, sim.time)

    def _open_window(self):
        self.smp.sample(self.sim, 0.0)  # contacts at the window start (no collisions counted)
        self.smp.collisions[:] = 0
        self.smp.cg[:] = 0
        self.smp.window_time = 0.0
        self.window_start = energy_state(self.sim, self.k_n, self.k_t)

    def chunk(self):
        return self.record_steps if self.window_start is None else self.sample_steps

    def after_chunk(self):
        sim = self.sim
        ramp = self.g["ramp"]
        if ramp and self.shaft_rate < 1.0:
            # The shaft is an analytic wall with a constant surface speed: it follows the
            # agitator body's ramp chunk by chunk, at the rate of the next chunk's middle, until
            # it is at full speed (the ramp may end inside a chunk: half a chunk short of it, the
            # shaft stayed at that speed for good).
            t_mid = sim.time + 0.5 * self.chunk() * sim.dt
            self.shaft_rate = min(1.0, t_mid / ramp)
            sim.set_wall(SHAFT_WALL, omega=self.g["omega"] * self.shaft_rate)
        if self.window_start is None:
            self._record()
            if sim.step >= self.transient:
                self._open_window()
            return
        self.smp.sample(sim, self.sample_steps * sim.dt)
        self.samples += 1
        if self.samples % self.per_record == 0:
            self._record()

    def done(self):
        return self.sim.step >= self.total

    def progress(self):
        return self.sim.step / self.total, f"{self.sim.time * self.v['rpm'] / 60:.2f} rev"

    def finish(self):
        sim, values, g, smp = self.sim, self.v, self.g, self.smp
        end = energy_state(sim, self.k_n, self.k_t)
        window_start, start = self.window_start, self.start
        total, transient = self.total, self.transient
        t = self.recorded_times()
        power = self.recorded("agitator_power")
        torque = self.recorded("agitator_torque")
        k0 = mser5(power)
        t_steady = float(t[k0] - (t[1] - t[0]) if k0 > 0 else 0.0)
        use = t > max(t_steady, sim.time - (total - transient) * sim.dt) + 1e-12
        p_mean, p_ci = block_mean_ci(power[use], values["ci_blocks"])
        q_mean, q_ci = block_mean_ci(torque[use], values["ci_blocks"])
        d, residual, rel = energy_balance(window_start, end)
        _, _, rel_all = energy_balance(start, end)
        span = end["time"] - window_start["time"]
        typ = typology(d)
        dissipated = typ.sum()
        coll = smp.collisions
        cg_n = smp.cg[0]
        with np.errstate(invalid="ignore", divide="ignore"):
            cg = smp.cg[1:] / np.where(cg_n > 0, cg_n, np.nan)

        centres = 0.5 * (smp.edges[1:] + smp.edges[:-1])
        dissipation = np.array([d[k] for k in AUDIT])
        return {
            "typology": np.array(TYPOLOGY), "audit_term": np.array(AUDIT),
            "region": np.array(REGIONS), "gy": centres, "gz": centres,
            "net_power": p_mean, "net_power_ci": p_ci, "mean_torque": q_mean, "mean_torque_ci": q_ci,
            "steady_state_start": t_steady, "statistics_start": float(t[use][0] - (t[1] - t[0])),
            "steady_state_detected": int(t_steady <= window_start["time"] + 1e-12),
            "energy_in": d["work"], "delta_kinetic": d["kinetic"], "delta_potential": d["potential"],
            "delta_elastic_normal": d["elastic_normal"],
            "delta_elastic_tangential": d["elastic_tangential"],
            "dissipation": dissipation, "dissipation_power": dissipation / span,
            "energy_balance_residual": residual, "energy_balance_error": rel,
            "energy_balance_error_run": rel_all,
            "typology_energy": typ,
            "typology_fraction": typ / dissipated if dissipated > 0 else typ * np.nan,
            "collision_rate": coll / max(smp.window_time, 1e-300),
            "collision_frequency_relative": 100 * coll / max(coll.sum(), 1),
            **dict(zip(CG_FIELDS[1:], cg)), "cg_samples": cg_n,
            "n_bead": g["n_beads"], "n_agitator_particles": g["n_agitator_particles"],
            "chamber_length": g["chamber_length"], "domain_length": g["length"],
            "domain_void_volume": g["void_volume"], "tip_speed": g["tip_speed"],
            "angular_velocity": g["omega"],
        }

    def provenance(self):
        sim = self.sim
        extra = {"contact_time_s": self.g["t_c"], "normal_stiffness": self.k_n,
                 "list_rebuilds": int(sim.counters[0])}
        if sim.fluid is not None:  # the scheme that ran ("auto" picks one at the build)
            extra.update(lubrication_scheme_used=sim.fluid.scheme)
        if sim.fluid is not None and sim.fluid.implicit:  # cost of the implicit solve
            extra.update(lubrication_iterations_per_step=float(sim.counters[2]) / max(sim.step, 1),
                         lubrication_iterations_max=int(sim.counters[3]))
        return extra


register(Scene("stirred_mill", "wet horizontal stirred media mill, perforated-disk agitator, pairwise "
               "lubrication: power draw, energy balance, typology (the LabStar LS1 paper)", PARAMS,
               StirredMillCase, (_check,),
               wall_materials=lambda values: ("bead", "agitator", "wall")))
