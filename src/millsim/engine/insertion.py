"""Insertion region: particles poured into a box at a rate (a charge poured instead of a lattice
start), the counterpart of LIGGGHTS ``fix insert/rate/region`` and EDEM's dynamic factories.

Between chunks, :meth:`Pour.fill` adds the particles due by the simulation's time
(``rate x elapsed``, at most ``count``), each with a size drawn from the asked distribution at a
random place in the region where it overlaps no particle and no wall (random sequential addition,
up to ``attempts`` places per particle). What does not fit now (a congested region) is carried
over to the next call and reported by :attr:`Pour.backlog`. The draws come from the pour's own
seeded generator and the calls from the chunk loop, so a poured charge is the same on any
number of threads.
"""

from dataclasses import dataclass, field

import numpy as np

from ..util.validation import check_range
from .kinematics import MESH, W_ACTIVE, W_KIND
from .walls import wall_contact_bounded


@dataclass
class Pour:
    """Pour ``count`` particles of ``material`` into the box [lo, hi] at ``rate`` per second.

    Sizes: ``radii`` with number ``fractions`` (default equal), or ``radius_range`` (uniform by
    number between its bounds) [m]. ``velocity``: initial velocity [m/s]. ``gap``: least free
    distance to other particles and walls at insertion [m]. ``tags``: a value per tag the
    simulation keeps, for every poured particle.
    """

    lo: tuple
    hi: tuple
    count: int
    rate: float
    material: str
    radii: tuple = None
    fractions: tuple = None
    radius_range: tuple = None
    velocity: tuple = (0.0, 0.0, 0.0)
    gap: float = 0.0
    attempts: int = 50
    seed: int = 0
    tags: dict = field(default_factory=dict)
    inserted: int = 0
    start: float = None

    def __post_init__(self):
        self.lo = np.asarray(self.lo, dtype=float).reshape(3)
        self.hi = np.asarray(self.hi, dtype=float).reshape(3)
        if not (self.hi > self.lo).all():
            raise ValueError(f"pour.hi: must exceed lo on every axis, got lo {self.lo.tolist()}, "
                             f"hi {self.hi.tolist()}")
        check_range("pour.count", self.count, 1)
        check_range("pour.rate", self.rate, 0.0, lo_open=True)
        check_range("pour.gap", self.gap, 0.0)
        check_range("pour.attempts", self.attempts, 1)
        if (self.radii is None) == (self.radius_range is None):
            raise ValueError("pour: give radii (with fractions) or radius_range, not both")
        if self.radius_range is not None:
            rmin, rmax = self.radius_range
            if not 0.0 < rmin <= rmax:
                raise ValueError(f"pour.radius_range: need 0 < min <= max, got {self.radius_range}")
            largest = rmax
        else:
            self.radii = np.asarray(self.radii, dtype=float).reshape(-1)
            f = np.full(len(self.radii), 1.0) if self.fractions is None else np.asarray(
                self.fractions, dtype=float).reshape(-1)
            if f.shape != self.radii.shape or (f < 0).any() or f.sum() <= 0:
                raise ValueError(f"pour.fractions: one fraction >= 0 per radius, not all 0, got "
                                 f"{self.fractions}")
            if (self.radii <= 0).any():
                raise ValueError(f"pour.radii: must be > 0, got {self.radii.tolist()}")
            self.fractions = f / f.sum()
            largest = self.radii.max()
        if (self.hi - self.lo < 2 * largest).any():
            raise ValueError(f"pour: the region {self.lo.tolist()} - {self.hi.tolist()} m is "
                             f"narrower than the largest particle (radius {largest:g} m)")
        self.velocity = np.asarray(self.velocity, dtype=float).reshape(3)
        self._rng = np.random.default_rng(self.seed)
        self._pending_radius = None
        self.backlog = 0  # particles due at the last fill that did not fit

    @property
    def done(self):
        return self.inserted == self.count

    def due(self, time):
        """Particles due by ``time``: the k-th at start + k / rate (the pour starts at its first
        fill). A time on a due instant counts it as due: the step's time k dt lands a rounding
        either side of k / rate, so 1e-9 of a particle is forgiven."""
        start = time if self.start is None else self.start
        return min(self.count, int(self.rate * (time - start) + 1e-9) + 1)

    def _draw_radius(self):
        if self.radius_range is not None:
            return float(self._rng.uniform(*self.radius_range))
        return float(self.radii[self._rng.choice(len(self.radii), p=self.fractions)])

    def first(self):
        """Position and radius of the first particle, for the Simulation the pour starts (an
        engine run holds at least one particle). The region must then lie inside the container:
        no wall is known yet to keep it clear of."""
        if self.inserted:
            raise ValueError("pour.first: the pour has started already")
        x, r = self._place(1, np.empty((0, 3)), np.empty(0), [], None)
        self.inserted = 1
        return x, r

    def fill(self, sim):
        """Insert what is due by ``sim.time``; returns the indices of the new particles."""
        if self.start is None:
            self.start = sim.time
        want = self.due(sim.time) - self.inserted
        if want <= 0:
            self.backlog = 0
            return np.arange(0)
        p = sim.particles
        reach = 2.0 * self._largest_radius(p) + self.gap
        near = np.all((p.x > self.lo - reach) & (p.x < self.hi + reach), axis=1)
        walls = [w for w in sim.walls if w[W_ACTIVE] != 0.0 and w[W_KIND] != MESH]
        new_x, new_r = self._place(want, p.x[near], p.radius[near], walls, sim.mesh_clearance)
        self.backlog = want - len(new_r)
        if not len(new_r):
            return np.arange(0)
        self.inserted += len(new_r)
        v = np.tile(self.velocity, (len(new_r), 1))
        tags = {name: np.full(len(new_r), value) for name, value in self.tags.items()}
        return sim.add_particles(new_x, new_r, self.material, v=v, tags=tags)

    def _place(self, want, xs, rs, walls, mesh_clearance):
        """Up to ``want`` new (positions, radii), clear of the particles (xs, rs), of each other,
        of the analytic wall rows and of the mesh walls (``mesh_clearance(points)``: signed
        distances; None: no meshes)."""
        first_new = len(rs)
        for _ in range(want):
            # a drawn size is kept until it is placed, so that congestion does not bias the sizes
            r = self._pending_radius if self._pending_radius is not None else self._draw_radius()
            placed = None
            for _ in range(self.attempts):
                x = self._rng.uniform(self.lo + r, self.hi - r)
                if len(rs) and (np.linalg.norm(xs - x, axis=1) - rs - r).min() < self.gap:
                    continue
                if any(wall_contact_bounded(w, x[0], x[1], x[2], r + self.gap)[0] > 0.0 for w in walls):
                    continue
                if mesh_clearance is not None and mesh_clearance(x[None, :])[0] < r + self.gap:
                    continue
                placed = x
                break
            if placed is None:
                self._pending_radius = r
                break
            self._pending_radius = None
            xs = np.vstack([xs, placed])
            rs = np.append(rs, r)
        return xs[first_new:], rs[first_new:]

    def _largest_radius(self, p):
        biggest = self.radius_range[1] if self.radius_range is not None else self.radii.max()
        return max(biggest, float(p.radius.max(initial=0.0)))
