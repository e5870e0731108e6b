"""The drum and the charge of scene ``ballmill3d`` (plain numpy, no run): the liner probed by rays,
the critical speed, the charge from filling and ball-to-ore ratio, the walls and the material
table, and the checks of the scene's input (each refusal one line naming the key or file).

The drum's axis is y, from y = 0 to ``drum_length`` (the shipped liner's frame); gravity is -z.
"""

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..engine.mesh_io import read_mesh
from ..models import Interaction, Material, MaterialTable
from ..models.breakage import tavares_materials
from .liner_rays import axis_rays

G = 9.81
# Bulk solid fraction of the charge (balls and ore together) that ``filling`` is counted at: a
# poured, settled bed of spheres lies between random loose (0.56-0.60) and random close (0.64)
# packing; 0.6 is the usual figure of mill charges (Napier-Munn et al. 1996, ch. 11).
CHARGE_PACKING = 0.6
# The liner is probed by rays from the axis at LINER_HEIGHTS heights, LINER_RAYS each; its shell
# (the farthest first hit) must lie within LINER_MATCH of drum_diameter / 2 (as packing's drum).
LINER_RAYS, LINER_HEIGHTS, LINER_MATCH = 720, 3, 0.05
REPO = Path(__file__).resolve().parents[3]


def resolve_liner(path):
    """A relative liner path that is not found from the working directory is read from the
    repository (the shipped examples/meshes/ballmill_liner.stl from anywhere)."""
    p = Path(path)
    if not p.is_absolute() and not p.exists() and (REPO / p).exists():
        return REPO / p
    return p


class LinerProbe(NamedTuple):
    shell_radius: float  # farthest first hit from the axis [m]
    tip_radius: float  # nearest first hit (lifter tips) [m]
    lifter_gap: float  # smallest free chord between lifters at half their height [m] (inf: none)
    free_area: float  # area of the hollow cross-section (inside the first hits) [m2]


def lifter_gap(dist, shell, tip):
    """Smallest free chord between lifters from one ring of ray distances ``dist`` (equal angles
    around the axis): a ray that meets the liner inside the circle halfway up the lifters crosses
    a lifter there; each circular run of the others is a gap, its chord taken on that circle.
    inf where the liner has no lifters (no ray nearer than 1e-3 of the shell)."""
    if shell - tip <= 1e-3 * shell:
        return math.inf
    half = shell - 0.5 * (shell - tip)
    blocked = dist < half
    if blocked.all():
        return 0.0
    step = 2 * math.pi / len(dist)
    # runs of free rays, circularly: rotate so that the ring starts at a blocked ray
    ring = np.roll(~blocked, -int(np.argmax(blocked)))
    padded = np.concatenate([[False], ring, [False]]).astype(int)
    edges = np.flatnonzero(np.diff(padded))
    runs = edges[1::2] - edges[0::2]
    if not len(runs):
        return 0.0
    return float(2 * half * math.sin(0.5 * runs.min() * step))


def probe_liner(values):
    """Read the liner (read_mesh refuses an open or inverted mesh, naming the file) and probe it
    by rays from the axis; refuse one that does not enclose the axis along the drum or whose
    shell is not at drum_diameter / 2."""
    liner = values["liner"]
    vertices, faces = read_mesh(resolve_liner(liner), values["liner_scale"])
    radius, length = 0.5 * values["drum_diameter"], values["drum_length"]
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    span = ("it spans " + ", ".join(f"{axis} [{a:.4g}, {b:.4g}]" for axis, a, b in zip("xyz", lo, hi))
            + f" m at liner_scale {values['liner_scale']:g}")
    if lo[1] > 1e-3 * length or hi[1] < length * (1 - 1e-3):
        raise ValueError(f"liner: {liner}: does not run along the drum's axis y from 0 to "
                         f"drum_length = {length:g} m; {span}")
    rings = axis_rays(liner, vertices, faces, length, LINER_RAYS, LINER_HEIGHTS, span)
    shell, tip = float(rings.max()), float(rings.min())
    if abs(radius - shell) > LINER_MATCH * shell:
        raise ValueError(f"liner: {liner}: its shell lies {shell:.4g} m from the axis but "
                         f"drum_diameter / 2 is {radius:g} m (set drum_diameter within "
                         f"{LINER_MATCH:.0%} of {2 * shell:.4g} m, or liner_scale); {span}")
    gap = min(lifter_gap(ring, shell, tip) for ring in rings)
    area = float(np.mean([0.5 * (ring**2).sum() * 2 * math.pi / LINER_RAYS for ring in rings]))
    return LinerProbe(shell, tip, gap, area)


def critical_speed(drum_diameter, ball_diameter):
    """omega_c [rad/s] = sqrt(2 g / (D - d)): the speed at which a ball of diameter d touching
    the shell of diameter D is held at the top (its centre on the circle of radius (D - d)/2;
    Napier-Munn et al. 1996; Wills & Napier-Munn 2006, ch. 7)."""
    return math.sqrt(2 * G / (drum_diameter - ball_diameter))


def mean_cube(lo, hi):
    """E[d^3] of diameters uniform by number on [lo, hi]."""
    if hi - lo <= 1e-12 * hi:
        return lo**3
    return (hi**4 - lo**4) / (4 * (hi - lo))


class Charge(NamedTuple):
    balls: int
    ore: int
    ball_volume: float  # solid volume of the balls [m3]
    ore_volume: float


def charge_counts(values, ore_density, steel_density):
    """Balls and ore particles of the charge: bulk volume filling x drum volume (pi D^2 L / 4) at
    CHARGE_PACKING, split by the mass ratio ball_ore_ratio, counted by the mean particle volume of
    each size distribution (uniform by number between min and max diameter)."""
    drum = math.pi * 0.25 * values["drum_diameter"] ** 2 * values["drum_length"]
    solid = values["filling"] * drum * CHARGE_PACKING
    ore_volume = solid / (1 + values["ball_ore_ratio"] * ore_density / steel_density)
    ball_volume = solid - ore_volume
    each_ball = math.pi / 6 * mean_cube(values["ball_diameter_min"], values["ball_diameter_max"])
    each_ore = math.pi / 6 * mean_cube(values["ore_diameter_min"], values["ore_diameter_max"])
    return Charge(int(round(ball_volume / each_ball)), int(round(ore_volume / each_ore)),
                  ball_volume, ore_volume)


def check(values):
    """The scene's input checks beyond the parameter ranges (each refusal one line)."""
    for kind in ("ball", "ore"):
        lo, hi = values[f"{kind}_diameter_min"], values[f"{kind}_diameter_max"]
        if lo > hi:
            raise ValueError(f"{kind}_diameter_min: {lo:g} m is above {kind}_diameter_max = {hi:g} m")
    if values["revolutions"] <= values["transient_revolutions"]:
        raise ValueError(f"revolutions: {values['revolutions']:g} leaves nothing after the "
                         f"{values['transient_revolutions']:g} transient_revolutions; allowed "
                         f"(transient_revolutions, inf)")
    # an ore missing from the materials file (or one that never breaks) is refused here, under
    # this scene's key
    try:
        tavares_materials.check_material(values["materials_file"], values["ore_material"])
    except ValueError as exc:
        text = str(exc)
        raise ValueError("ore_material:" + text[len("material:"):] if text.startswith("material:")
                         else text) from None
    D, L, d_ball = values["drum_diameter"], values["drum_length"], values["ball_diameter_max"]
    if d_ball >= 0.5 * D or d_ball >= L:
        raise ValueError(f"ball_diameter_max: {d_ball:g} m does not fit in the drum; allowed "
                         f"< min(drum_diameter / 2, drum_length) = {min(0.5 * D, L):g} m")
    free = math.pi * 0.25 * D**2
    if values["liner"]:
        probe = probe_liner(values)
        if d_ball > probe.lifter_gap:
            raise ValueError(f"ball_diameter_max: {d_ball:g} m balls are larger than the gap "
                             f"between the lifters of liner {values['liner']} "
                             f"({probe.lifter_gap:.4g} m at half their height)")
        free = probe.free_area
    elif values["liner_scale"] != 1.0:
        raise ValueError(f"liner_scale: {values['liner_scale']:g} given without a liner")
    bulk = values["filling"] * math.pi * 0.25 * D**2 * L
    if bulk > free * L:
        raise ValueError(f"filling: {values['filling']:g} is a charge of bulk volume {bulk:.4g} m3 "
                         f"(at solid fraction {CHARGE_PACKING}), more than the drum holds "
                         f"({free * L:.4g} m3 inside the liner); allowed <= "
                         f"{free / (math.pi * 0.25 * D**2):.3g}")
    mats = tavares_materials.load_materials(values["materials_file"])
    counts = charge_counts(values, mats[values["ore_material"]].density,
                           mats[tavares_materials.DEVICE_MATERIAL].density)
    if counts.balls < 1 or counts.ore < 1:
        raise ValueError(f"filling: {values['filling']:g} with ball_ore_ratio "
                         f"{values['ball_ore_ratio']:g} makes {counts.balls} balls and "
                         f"{counts.ore} ore particles; the charge needs at least one of each")


def material_table(values, tav):
    """Hertz-Mindlin with the materials file's elastic constants (times ``stiffness_scale``, 1 =
    none) and its Table 6
    contact parameters: ore-ore particle_particle, ore-ball and ore-liner particle_steel,
    ball-ball and ball-liner steel_steel (balls and liner are the file's steel)."""
    contacts = tavares_materials.load_contacts(values["materials_file"])
    name, steel = values["ore_material"], tavares_materials.DEVICE_MATERIAL
    ore, device = tav[name], tav[steel]

    def inter(key):
        c = contacts[key]
        return Interaction(restitution=c["restitution"], friction=c["static_friction"],
                           rolling_friction=c["rolling_friction"])

    soft = values["stiffness_scale"]
    return MaterialTable([Material(name, ore.density, soft * ore.young, ore.poisson),
                          Material(steel, device.density, soft * device.young, device.poisson)],
                         {"*": inter("particle_particle"), (name, steel): inter("particle_steel"),
                          (steel, steel): inter("steel_steel")}, "hertz_mindlin")


SHELL, END_FRONT, END_BACK = 0, 1, 2  # wall indices


def walls(values):
    """The shell (liner mesh or cylinder) and the two end walls, planes across the axis that turn
    about their normals with the shell (docs/walls.md): at y = 0 (normal +y) and y = L (normal -y,
    so its omega is the opposite of the shell's to turn the same way about +y)."""
    steel = tavares_materials.DEVICE_MATERIAL
    if values["liner"]:
        shell = dict(kind="mesh", file=str(resolve_liner(values["liner"])),
                     scale=values["liner_scale"], point=(0, 0, 0), axis=(0, 1, 0), omega=0.0,
                     material=steel)
    else:
        shell = dict(kind="cylinder_inner", point=(0, 0, 0), axis=(0, 1, 0),
                     radius=0.5 * values["drum_diameter"], omega=0.0, material=steel)
    return [shell,
            dict(kind="plane", point=(0, 0, 0), normal=(0, 1, 0), omega=0.0, material=steel),
            dict(kind="plane", point=(0, values["drum_length"], 0), normal=(0, -1, 0), omega=0.0,
                 material=steel)]


def set_drum_speed(sim, omega):
    """Turn shell and end walls at omega about +y."""
    sim.set_wall(SHELL, omega=omega)
    sim.set_wall(END_FRONT, omega=omega)
    sim.set_wall(END_BACK, omega=-omega)
