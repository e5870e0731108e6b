"""Small builders shared by the tests."""

import json
import math
from types import SimpleNamespace

import numpy as np

from millsim.engine import PhysicsSpec, Simulation, StepPolicy
from millsim.models import Interaction, Material, MaterialTable


def random_gas(n, box, radius_range, rng, dim=3):
    """Non-overlapping random spheres (or disks with dim = 2) in a periodic box, by rejection."""
    x, r = [], []
    while len(x) < n:
        ri = rng.uniform(*radius_range)
        xi = rng.uniform(0, box, 3)
        if dim == 2:
            xi[2] = 0.0
        d = np.array(x).reshape(-1, 3) - xi
        d -= box * np.round(d / box)
        if len(x) and (np.linalg.norm(d, axis=1) < np.array(r) + ri).any():
            continue
        x.append(xi)
        r.append(ri)
    return np.array(x), np.array(r)


def clipped_linear_restitution(zeta):
    """Head-on restitution of a linear spring-dashpot of damping ratio zeta < 1 whose force is
    clipped at zero (Schwager & Poeschel 2007): in units of w0, x = e^{-zeta t} sin(w t) / w; the
    force x + 2 zeta x' vanishes first at w t_c = pi - atan2(2 zeta w, w^2 - zeta^2), where
    x' = -e^{-zeta t_c}: e = exp(-zeta t_c)."""
    import math

    w = math.sqrt(1.0 - zeta * zeta)
    return math.exp(-zeta * (math.pi - math.atan2(2.0 * zeta * w, w * w - zeta * zeta)) / w)


def clipped_damping_ratio(e):
    """The damping ratio of the linear laws for restitution e in the engine's default (clipped)
    convention, inverted here from the closed form above (valid for e > exp(-2) = 0.135)."""
    from scipy.optimize import brentq

    if e >= 1.0:
        return 0.0
    return brentq(lambda z: clipped_linear_restitution(z) - e, 0.0, 1.0 - 1e-12, xtol=1e-15)


def dense_bed(n, seed=4, force_sum="records"):
    """Spheres dropped in a box: contacts, walls and list rebuilds all active."""
    rng = np.random.default_rng(seed)
    side = int(math.ceil(n ** (1 / 3)))
    g = np.stack(np.meshgrid(*[np.arange(side)] * 3, indexing="ij"), -1).reshape(-1, 3)[:n]
    x = (g + 0.5) * 2.1e-3 + rng.uniform(-1e-4, 1e-4, (n, 3))
    w = side * 2.1e-3
    walls = [dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="m")]
    walls += [dict(kind="plane", point=p, normal=nv, material="m") for p, nv in
              [((0, 0, 0), (1, 0, 0)), ((w, 0, 0), (-1, 0, 0)), ((0, 0, 0), (0, 1, 0)),
               ((0, w, 0), (0, -1, 0))]]
    table = MaterialTable([Material("m", 2500.0, 5e6, 0.3)],
                          {"*": Interaction(restitution=0.5, friction=0.3)}, "hertz_mindlin")
    return Simulation(PhysicsSpec(dim=3, walls=True, force_sum=force_sum), table, x=x,
                      radius=np.full(n, 1e-3), material="m", v=rng.normal(0, 0.05, (n, 3)),
                      walls=walls, step=StepPolicy(dt=2e-5))


class PourCharge:
    """What ``Pour.fill`` reads of a Simulation: the time, the particles, no walls, no meshes (a
    stand-in: building a Simulation would compile the neighbour list for nothing)."""

    def __init__(self, x, radius, time):
        self.particles = SimpleNamespace(x=np.asarray(x, float).reshape(-1, 3),
                                         radius=np.asarray(radius, float))
        self.time, self.walls, self.mesh_clearance = time, [], None

    def add_particles(self, x, r, material, v=None, tags=None):
        p = self.particles
        first = len(p.radius)
        p.x, p.radius = np.vstack([p.x, x]), np.append(p.radius, r)
        return np.arange(first, len(p.radius))


def calibration_files(tmp_path, source, friction_interval, eta_interval, speeds=(1000.0,),
                      residual_2000=-1.0):
    """The stage files of a stirred-mill calibration, written by hand: friction 0.3 from
    ``speeds``, one fluid A (eta_exp 0.05, eta_sim 0.04), a two-point prediction with residuals
    0.2 W at 1000 rpm and ``residual_2000`` W at 2000 rpm (references 10 and 20 W)."""
    friction = tmp_path / "friction.json"
    friction.write_text(json.dumps(dict(friction=0.3, friction_refined=0.31, speeds=list(speeds),
                                        friction_interval=friction_interval)))
    viscosity = tmp_path / "viscosity.json"
    viscosity.write_text(json.dumps(dict(rpm=2000.0, fluids={"A": dict(
        eta_sim=0.04, eta_sim_refined=0.045, eta_exp=0.05, eta_sim_interval=eta_interval)})))
    prediction = tmp_path / "prediction.csv"
    prediction.write_text(f"rpm,residual,reference\n1000,0.2,10\n2000,{residual_2000},20\n")
    reference = tmp_path / "reference.csv"
    reference.write_text("rpm,fluid,eta_exp,net_power,source\n"
                         f"1000,dry,0,10,{source}\n2000,A,0.05,20,{source}\n")
    return friction, viscosity, prediction, reference


def progress_of(monkeypatch, scene_name, overrides):
    """[(fraction, note)] a run of ``scene_name`` with ``overrides`` hands its progress line,
    one per chunk (scenes/driver.py's Progress.update, wrapped)."""
    from millsim.scenes import driver, load_all
    from millsim.scenes.base import RunContext, get_scene

    seen, update = [], driver.Progress.update

    def record(self, fraction, note, *args):
        seen.append((fraction, note))
        return update(self, fraction, note, *args)

    monkeypatch.setattr(driver.Progress, "update", record)
    load_all()
    scene = get_scene(scene_name)
    scene.run(scene.resolve(overrides), RunContext(progress=True))
    return seen

