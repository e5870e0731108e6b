"""A scene of one's own, outside the package: spheres dropped onto a floor until they rest.

Registered from this file, without editing millsim:

    millsim scenes --scene-module examples/my_scene.py            # lists my_drop with the others
    millsim scenes my_drop --scene-module examples/my_scene.py    # its parameters
    millsim run my_drop --scene-module examples/my_scene.py --set n=4 --out drop.nc
    millsim info drop.nc

``--scene-module`` also takes an importable module name (``mypackage.scenes``). To have the scene
everywhere (``millsim run``, ``millsim scenes`` and the workflow, with no option), make it part of
an installed package that names the module in the entry-point group ``millsim.scenes``, in that
package's pyproject.toml:

    [project.entry-points."millsim.scenes"]
    my_drop = "my_scene"

A scene is its parameters (``Param``: default, unit, allowed range, checked before the run), a
``Case`` (builds the Simulation; what it records, when it is done, its summaries) and
``register(Scene(...))``; the driver does the rest: progress, checkpoints, the case file with its
provenance. What the case file holds is declared once, in the Case's tables: ``series`` (recorded
as the run goes) and ``outputs`` (the summaries, with dims, units and long names); ``finish``
returns only the values of the outputs, and the driver refuses one that is missing or undeclared.
The built-in scenes in src/millsim/scenes/ are written the same way (collision.py is the
smallest); examples/simulation_by_hand.py builds the same Simulation without a scene.
"""

import math

import numpy as np

from millsim.engine import PhysicsSpec, Simulation
from millsim.models import Interaction, Material, MaterialTable
from millsim.scenes.base import TIME_STEP_PARAMS, Param, Scene, register, step_policy
from millsim.scenes.driver import Case, Output, Series

G = 9.81  # [m s-2]

PARAMS = (
    Param("n", 3, "spheres, side by side in a row", "1", 1, 1000),
    Param("radius", 1e-3, "sphere radius", "m", 0.0, lo_open=True),
    Param("density", 2500.0, "sphere density", "kg m-3", 0.0, lo_open=True),
    Param("normal_stiffness", 2e3, "linear normal spring constant", "N m-1", 0.0, lo_open=True),
    Param("restitution", 0.5, "coefficient of restitution", "1", 0.0, 1.0, lo_open=True),
    Param("height", 0.008, "initial height of the centres above the floor", "m", 0.0,
          lo_open=True),
    Param("record_interval", 0.01, "time between records", "s", 0.0, lo_open=True),
    Param("rest_speed", 1e-3, "at rest once every sphere is slower than this", "m s-1", 0.0,
          lo_open=True),
    Param("max_time", 2.0, "the run ends here if the spheres never come to rest", "s", 0.0,
          lo_open=True),
    *TIME_STEP_PARAMS,
    Param("seed", 0, "random seed (unused: the drop is deterministic)", "1", 0),
)


def _check(values):
    # checked before anything is built: a case that cannot work ends with one line, exit code 2
    if values["height"] <= values["radius"]:
        raise ValueError(f"height: {values['height']:g} m puts the spheres into the floor; allowed "
                         f"({values['radius']:g}, inf) m (above one radius)")


class DropCase(Case):
    """Drop, bounce, rest: records the mean height and the largest speed every record_interval;
    done once every sphere is slower than rest_speed (after the first bounce) or at max_time."""

    series = (Series("mean_height", "m", "mean height of the sphere centres above the floor"),
              Series("max_speed", "m s-1", "largest sphere speed"))
    outputs = (Output("rest_height", (), "m", "mean height of the centres at the end"),
               Output("rest_height_expected", (), "m", "radius less the overlap m g / k_n of a "
                      "sphere resting on the floor"),
               Output("settle_time", (), "s", "time to rest"))

    def __init__(self, values):
        super().__init__()
        self.v = v = values
        table = MaterialTable([Material("glass", v["density"])],
                              {"*": Interaction(restitution=v["restitution"],
                                                normal_stiffness=v["normal_stiffness"])},
                              "linear_history")
        x = [[4 * v["radius"] * k, 0.0, v["height"]] for k in range(v["n"])]
        floor = dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="glass")
        impact = math.sqrt(2 * G * v["height"])
        self.sim = Simulation(PhysicsSpec(dim=3, walls=True), table, x=x,
                              radius=[v["radius"]] * v["n"], material="glass", walls=[floor],
                              gravity=(0.0, 0.0, -G), step=step_policy(v, impact_speed=impact))
        self.steps = max(1, round(v["record_interval"] / self.sim.dt))
        self.bounced = False
        self.after_chunk()

    def chunk(self):
        return self.steps

    def after_chunk(self):
        p = self.sim.particles
        speed = float(np.linalg.norm(p.v, axis=1).max())
        self.bounced |= bool((p.v[:, 2] > 0).any())
        self.record(self.sim.time, mean_height=float(p.x[:, 2].mean()), max_speed=speed)

    def done(self):
        at_rest = self.bounced and self.recorded("max_speed")[-1] < self.v["rest_speed"]
        return at_rest or self.sim.time >= self.v["max_time"]

    def progress(self):
        # the end is an event (rest), not a known time: no fraction to give (the progress line
        # then shows elapsed and simulated time)
        return None, f"largest speed {self.recorded('max_speed')[-1]:.3g} m/s"

    def finish(self):
        v = self.v
        mass = v["density"] * 4.0 / 3.0 * math.pi * v["radius"] ** 3
        return {"rest_height": float(self.sim.particles.x[:, 2].mean()),
                "rest_height_expected": v["radius"] - mass * G / v["normal_stiffness"],
                "settle_time": self.sim.time}


register(Scene("my_drop", "spheres dropped onto a floor until they rest (examples/my_scene.py)",
               PARAMS, DropCase, (_check,)))
