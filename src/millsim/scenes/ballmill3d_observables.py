"""What a ``ballmill3d`` run measures (plain numpy): the charge's toe and shoulder, the selection
function per size class, the size classes and sieves, the drive's loads and the energy balance.

Angles are about the drum axis (+y), measured from the vertical below the axis (0 = bottom,
gravity -z), positive in the direction of rotation: a point at angle theta lies at
(-R sin theta, ., -R cos theta), where the shell turning at omega > 0 about +y carries it.
"""

import math

import numpy as np

from ..engine.kinematics import (
    CYLINDER_INNER,
    MESH,
    PLANE,
    W_AXIS,
    W_KIND,
    W_MATERIAL,
    W_POINT,
    W_RADIUS,
)
from ..models.contact import hertz_mindlin as law
from ..util.stats import block_mean_interval
from .ballmill3d_charge import END_BACK, END_FRONT, SHELL

# Toe and shoulder: the outer band of the charge is BAND_WIDTH largest-ball diameters deep inside
# the shell, cut into ANGLE_BINS sectors; a sector belongs to the charge's contact arc where its
# time-mean solid fraction reaches PROFILE_THRESHOLD of the densest sector's.
ANGLE_BINS, BAND_WIDTH, PROFILE_THRESHOLD = 72, 1.0, 0.5


def charge_angle(x):
    """Angle [rad] in (-pi, pi] of points ``x`` (n, 3) about the y axis (module text)."""
    return np.arctan2(-x[:, 0], -x[:, 2])


def band_profile(x, radius, shell_radius, band, bins=ANGLE_BINS):
    """Solid volume [m3] of the particles whose centres lie in the outer band (shell_radius -
    band, shell_radius], per angular sector on [-pi, pi)."""
    rho = np.hypot(x[:, 0], x[:, 2])
    inside = rho > shell_radius - band
    k = np.floor((charge_angle(x[inside]) + math.pi) / (2 * math.pi) * bins).astype(int) % bins
    return np.bincount(k, weights=4.0 / 3.0 * math.pi * radius[inside] ** 3, minlength=bins)


def toe_shoulder(profile, threshold=PROFILE_THRESHOLD):
    """(toe, shoulder) [rad] from a sector profile on [-pi, pi) (band_profile, any units): the
    contiguous circular run of sectors at or above ``threshold`` x its largest value that holds
    the largest one is the charge's arc on the shell; the toe is its edge against the rotation
    (the lower angle), the shoulder its edge in the direction of rotation. NaN for an empty or
    uniform profile (a centrifuged charge covers the whole shell)."""
    p = np.asarray(profile, dtype=float)
    bins = len(p)
    if not p.max() > 0:
        return math.nan, math.nan
    full = p >= threshold * p.max()
    if full.all():
        return math.nan, math.nan
    top = int(np.argmax(p))
    lo = top
    while full[(lo - 1) % bins]:
        lo -= 1
    hi = top
    while full[(hi + 1) % bins]:
        hi += 1
    width = 2 * math.pi / bins
    toe, shoulder = -math.pi + lo * width, -math.pi + (hi + 1) * width
    # the arc is reported around the bottom: angles in (-pi, pi] where the run allows it
    shift = 2 * math.pi * math.floor((0.5 * (toe + shoulder) + math.pi) / (2 * math.pi))
    return toe - shift, shoulder - shift


def size_classes(d_max, d_min):
    """Lower edges [m] of the sqrt(2) ore size classes, descending from d_max (the top class is
    [d_max / sqrt 2, d_max]) down to the last class whose lower edge is at least d_min."""
    k = int(math.floor(2 * math.log2(d_max / d_min) + 1e-9))
    return d_max * 2.0 ** (-0.5 * np.arange(1, max(k, 1) + 1))


def sieves(d_max, d_min, below=4):
    """The sqrt(2) sieve series [m] from sqrt(2) d_max (the whole feed passes the top sieve) down
    to ``below`` classes under d_min (where the unresolved fines lie, eq 11)."""
    k = int(math.floor(2 * math.log2(d_max / d_min) + 1e-9)) + below
    return d_max * 2.0 ** (-0.5 * np.arange(-1, k + 1))


def class_counts(diameters, lower_edges):
    """Particles per size class (lower edges descending, the top class open above)."""
    k = np.searchsorted(-np.asarray(lower_edges), -np.asarray(diameters), side="right")
    return np.bincount(k, minlength=len(lower_edges) + 1)[:len(lower_edges)]


def selection_function(event_times, event_diameters, lower_edges, t0, t1, record_times,
                       record_counts, blocks=5):
    """Breakage rate [s-1] per size class over [t0, t1] (the selection function of the population
    balance; Austin, Klimpel & Luckie 1984): breakage events of parents in the class per second
    over the mean number of particles in the class (record_counts, records x classes, at
    record_times), with the 95 % half-width from ``blocks`` block rates (util.stats). NaN where
    the class held no particle."""
    t = np.asarray(event_times, dtype=float)
    d = np.asarray(event_diameters, dtype=float)
    rt = np.asarray(record_times, dtype=float)
    counts = np.asarray(record_counts, dtype=float).reshape(len(rt), len(lower_edges))
    use = (rt >= t0) & (rt <= t1)
    mean_n = counts[use].mean(axis=0) if use.any() else np.full(len(lower_edges), np.nan)
    inside = (t >= t0) & (t < t1)
    cls = np.searchsorted(-np.asarray(lower_edges), -d[inside], side="right")
    edges = np.linspace(t0, t1, blocks + 1)
    rate, half = np.full(len(lower_edges), np.nan), np.full(len(lower_edges), np.nan)
    for c in range(len(lower_edges)):
        if not mean_n[c] > 0:
            continue
        per_block = np.histogram(t[inside][cls == c], bins=edges)[0] / np.diff(edges)
        rate[c] = np.count_nonzero(cls == c) / (t1 - t0) / mean_n[c]
        half[c] = block_mean_interval(per_block)[1] / mean_n[c]
    return rate, half


# ---- drive and energy --------------------------------------------------------------------------
DRIVE_WALLS = (SHELL, END_FRONT, END_BACK)


def drive_state(sim):
    """(angular impulse about +y the drive has supplied [N m s], work it has done [J]) since the
    start: shell and end walls. A wall's angular impulse is the charge's on it; the drive supplies
    the opposite."""
    impulse = -sum(float(sim.angular_impulse(wall=k)[1]) for k in DRIVE_WALLS)
    return impulse, sum(float(sim.work(wall=k)) for k in DRIVE_WALLS)


def _reference(sim, state):
    """The creation overlap of progeny (only overlap beyond it stores energy); 0 without
    breakage."""
    if sim.breakage is None:
        return np.zeros(len(state))
    return sim.breakage.reference_overlap(state[:, sim.layout.spring:])


def elastic_energy(sim):
    """Normal elastic energy [J] of the Hertz contacts, 8/15 E* sqrt(R*) xi^5/2, of the pairs,
    the planes and cylinders, and the mesh (its nearest surface). The tangential springs' energy
    is inside the audit's tangential terms (they integrate the tangential force's whole power)."""
    p, pp = sim.particles, sim.pair_params
    i, j, overlap, slot = sim.contact_pairs(with_slots=True)
    xi = np.maximum(overlap - _reference(sim, sim.contacts.state[slot]), 0.0)
    r_eff = p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j])
    e = float((8 / 15 * pp[p.material[i], p.material[j], law.P_E_STAR] * np.sqrt(r_eff)
               * xi**2.5).sum())
    free = np.flatnonzero(sim.free)
    x, r = p.x[free], p.radius[free]
    for k, wall in enumerate(sim.walls):
        kind = int(wall[W_KIND])
        if kind == MESH:
            xw = r - sim.mesh_clearance(x)
        else:
            d = x - wall[W_POINT]
            if kind == PLANE:
                xw = r - d @ wall[W_AXIS]
            else:
                assert kind == CYLINDER_INNER
                rho = np.linalg.norm(d - np.outer(d @ wall[W_AXIS], wall[W_AXIS]), axis=1)
                xw = rho + r - wall[W_RADIUS]
            xw = xw - _reference(sim, sim.wall_hist[free, k, :])
        touch = xw > 0
        e_star = pp[p.material[free[touch]], int(wall[W_MATERIAL]), law.P_E_STAR]
        e += float((8 / 15 * e_star * np.sqrt(r[touch]) * xw[touch] ** 2.5).sum())
    return e


def energy_state(sim, removed):
    """Everything the balance needs at one time [J]: drive work, kinetic, potential, elastic,
    audited dissipation, and ``removed``, the energy taken out at breakage replacements (the
    parent's contact springs, the fines' and the unfilled progeny's share of its motion)."""
    return dict(time=sim.time, work=drive_state(sim)[1], kinetic=sim.kinetic_energy(),
                potential=sim.potential_energy(), elastic=elastic_energy(sim),
                dissipated=float(sum(sim.energy_audit().values())) + removed)


def energy_balance_error(a, b):
    """(drive work - dissipation - change of kinetic + potential + elastic energy) / drive work
    between the states a and b (energy_state)."""
    work = b["work"] - a["work"]
    out = sum(b[k] - a[k] for k in ("kinetic", "potential", "elastic", "dissipated"))
    return (work - out) / work if work else math.nan


# ---- collision energy spectra (engine.spectra) ---------------------------------------------------
CONTACT_TYPES = ("ball-ball", "ball-ore", "ore-ore", "ball-liner", "ore-liner")
CONTACT_TERMS = ("contact_normal_damping", "contact_tangential_translation",
                 "contact_tangential_rotation")


def spectra_state(sim):
    """The spectra so far and the audit's contact dissipation [J] (normal, tangential)."""
    audit = sim.energy_audit()
    return sim.collision_spectra(), (audit[CONTACT_TERMS[0]],
                                     audit[CONTACT_TERMS[1]] + audit[CONTACT_TERMS[2]])


def contact_type_tables(spectra, ball, ore):
    """Per contact type of CONTACT_TYPES (material indices ``ball``, ``ore``; the liner and
    end walls are walls of the balls' steel): counts (type, normal/tangential, bin incl. under-
    and overflow) and energies (type, normal/tangential) of the collisions that ended."""
    lo, hi = min(ball, ore), max(ball, ore)
    where = (("pair", ball, ball), ("pair", lo, hi), ("pair", ore, ore), ("wall", ball, ball),
             ("wall", ore, ball))
    counts = np.array([[getattr(spectra, f"{table}_{part}")[a, b]
                        for part in ("normal", "tangential")] for table, a, b in where])
    energy = np.array([getattr(spectra, f"{table}_energy")[a, b] for table, a, b in where])
    return counts, energy


def spectra_outputs(start, end, ball, ore):
    """Impacts per second per energy bin and type over [start, end] (``spectra_state`` pairs),
    and the check of the spectra against the audit: (counted + change of open - audited) /
    audited contact dissipation, normal and tangential together."""
    (s0, audit0), (s1, audit1) = start, end
    window = s1.since(s0)
    counts, energy = contact_type_tables(window, ball, ore)
    rate = counts / window.duration
    edges = window.edges
    counted = float(window.pair_energy.sum() + window.wall_energy.sum())
    opened = (s1.open_normal + s1.open_tangential) - (s0.open_normal + s0.open_tangential)
    audited = (audit1[0] - audit0[0]) + (audit1[1] - audit0[1])
    return {
        "contact_type": np.array(CONTACT_TYPES), "energy_edge": edges,
        "energy_bin": np.sqrt(edges[:-1] * edges[1:]),
        "impact_rate_normal": rate[:, 0, 1:-1], "impact_rate_tangential": rate[:, 1, 1:-1],
        "collision_rate": counts[:, 0].sum(axis=-1) / window.duration,
        "collision_rate_below_range": rate[:, 0, 0],
        "collision_energy_normal": energy[:, 0] / window.duration,
        "collision_energy_tangential": energy[:, 1] / window.duration,
        "spectra_audit_error": (counted + opened - audited) / audited if audited else math.nan,
    }
