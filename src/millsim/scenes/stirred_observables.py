"""What a ``stirred_mill`` run measures between chunks (plain numpy): the energy stored in the
contact springs, the drive's impulse and work, the energy balance and its contact-typology split,
and the ``Sampler`` of collisions by region and coarse-grained fields on a slab.
``millsim.scenes.stirred_mill`` imports them from here."""

import math

import numpy as np

from ..engine.kinematics import (
    CYLINDER_INNER,
    CYLINDER_OUTER,
    PLANE,
    W_AXIS,
    W_KIND,
    W_POINT,
    W_RADIUS,
)

AUDIT = ("contact_normal_damping", "contact_tangential_translation", "contact_tangential_rotation",
         "lubrication_normal", "lubrication_tangential")


def elastic_energy(sim, k_n, k_t):
    """Energy stored in the contact springs [J]: (normal, tangential), pairs and walls."""
    _, _, overlap = sim.contact_pairs()
    normal = 0.5 * k_n * float((overlap**2).sum())
    tangential = 0.5 * k_t * float((sim.contacts.state[:, 0:3] ** 2).sum())
    tangential += 0.5 * k_t * float((sim.wall_hist[:, :, 0:3] ** 2).sum())
    p = sim.particles
    free = sim.free
    for wall in sim.walls:
        d = p.x[free] - wall[W_POINT]
        r = p.radius[free]
        if int(wall[W_KIND]) == PLANE:
            xi = r - d @ wall[W_AXIS]
        else:
            rho = np.linalg.norm(d - np.outer(d @ wall[W_AXIS], wall[W_AXIS]), axis=1)
            xi = rho + r - wall[W_RADIUS] if int(wall[W_KIND]) == CYLINDER_INNER else wall[W_RADIUS] + r - rho
            assert int(wall[W_KIND]) in (CYLINDER_INNER, CYLINDER_OUTER)
        xi = xi[xi > 0]
        normal += 0.5 * k_n * float((xi**2).sum())
    return normal, tangential


# The coarse-grained fields in the order Sampler sums them: the samples, then the sums of |v|, |w|,
# v_y and v_z that become their means
CG_FIELDS = ("cg_samples", "cg_speed", "cg_spin", "cg_vy", "cg_vz")


class Sampler:
    """Collision counts by region and coarse-grained fields of one run (sampled between chunks)."""

    def __init__(self, values, g):
        self.v, self.g = values, g
        self.contacts = np.zeros(0, dtype=np.int64)
        self.collisions = np.zeros(9)
        self.window_time = 0.0
        cells = values["cg_cells"]
        R = g["chamber_radius"]
        self.edges = np.linspace(-R, R, cells + 1)
        self.cg = np.zeros((len(CG_FIELDS), cells, cells))  # sums of the CG_FIELDS
        mid = len(g["disk_x"]) // 2
        face = g["disk_x"][mid] + 0.5 * g["disk_thickness"]
        self.slab = (face, face + 0.5 * (g["pitch"] - g["disk_thickness"]))

    def sample(self, sim, dt_sample):
        """Collision detection (bead-bead pairs in contact now and not at the last sample)."""
        p = sim.particles
        i, j, _ = sim.contact_pairs()
        beads = (p.body[i] < 0) & (p.body[j] < 0)
        i, j = i[beads], j[beads]
        key = i.astype(np.int64) * sim.n_particles + j
        new = ~np.isin(key, self.contacts, assume_unique=True)
        self.contacts = np.sort(key)
        if new.any():
            mid = 0.5 * (p.x[i[new]] + p.x[j[new]])
            if self.v["slice"]:  # midpoint of a pair across the periodic end
                L = self.g["length"]
                dx = p.x[i[new], 0] - p.x[j[new], 0]
                mid[:, 0] -= 0.5 * L * np.round(dx / L)
                mid[:, 0] = self.g["x_lo"] + (mid[:, 0] - self.g["x_lo"]) % L
            np.add.at(self.collisions, self.region(mid), 1)
        self.window_time += dt_sample
        free = sim.free
        x, v, w = p.x[free], p.v[free], p.w[free]
        inside = (x[:, 0] >= self.slab[0]) & (x[:, 0] < self.slab[1])
        if self.v["slice"]:  # the mirror slab on the other side of the disk
            inside |= (x[:, 0] <= -self.slab[0]) & (x[:, 0] > -self.slab[1])
        iy = np.clip(np.digitize(x[inside, 1], self.edges) - 1, 0, len(self.edges) - 2)
        iz = np.clip(np.digitize(x[inside, 2], self.edges) - 1, 0, len(self.edges) - 2)
        for q, val in enumerate((np.ones(inside.sum()), np.linalg.norm(v[inside], axis=1),
                                 np.linalg.norm(w[inside], axis=1), v[inside, 1], v[inside, 2])):
            np.add.at(self.cg[q], (iz, iy), val)

    def region(self, pts):
        """Region index 0..8 = (radial ring 1-3, inner to outer) x (front, centre, back along x)."""
        R2 = self.g["chamber_radius"] ** 2
        rho2 = pts[:, 1] ** 2 + pts[:, 2] ** 2
        ring = np.minimum((3 * rho2 / R2).astype(int), 2)  # equal-volume rings of the empty cylinder
        third = np.clip(((pts[:, 0] - self.g["x_lo"]) / self.g["length"] * 3).astype(int), 0, 2)
        return 3 * ring + third


SHAFT = 1  # wall index of the rotating shaft


def drive_state(sim):
    """Cumulative angular impulse about x and work of agitator body + shaft (what they supply)."""
    impulse = -(sim.angular_impulse(body=0)[0] + sim.angular_impulse(wall=SHAFT)[0])
    return impulse, sim.work(body=0) + sim.work(wall=SHAFT)


def energy_state(sim, k_n, k_t):
    el_n, el_t = elastic_energy(sim, k_n, k_t)
    shaft_work = sim.work(wall=SHAFT)
    return dict(time=sim.time, work=float(sim.work(body=0) + shaft_work),
                kinetic=sim.kinetic_energy(), potential=sim.potential_energy(), elastic_normal=el_n,
                elastic_tangential=el_t, **sim.energy_audit())


def energy_balance(a, b):
    """Balance terms between two energy states [J] and the relative residual.

    The audit's tangential terms are the full power of the tangential force (spring storage
    included), so the stored tangential energy is already inside them; the "true" tangential
    dissipation is audit - delta elastic_tangential (reported separately).
    """
    d = {k: b[k] - a[k] for k in a}
    inn = d["work"]
    out = d["kinetic"] + d["potential"] + d["elastic_normal"] + sum(d[k] for k in AUDIT)
    return d, inn - out, (inn - out) / inn if inn else math.nan


def typology(d):
    """Dissipation split [J] into impact, torsion, shearing, rolling (docs/stirred_mill.md)."""
    return np.array([d["contact_normal_damping"] + d["lubrication_normal"],
                     0.0,  # the contact model has no twisting torque
                     d["contact_tangential_translation"] + d["lubrication_tangential"],
                     d["contact_tangential_rotation"]])
