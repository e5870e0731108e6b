"""The stirred mill's perforated disks, built of spheres (scenes/stirred_mill.py): layers inside
the disk's thickness, the in-plane spacing that keeps beads out, no gap in a disk but its holes,
one layer for a thin disk; each from the centres alone (scipy's k-d tree)."""

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from millsim.scenes import load_all
from millsim.scenes import stirred_mill as sm
from millsim.scenes.base import REGISTRY

load_all()
SCENE = REGISTRY["stirred_mill"]


def _disks(**over):
    values = SCENE.resolve(over)
    g = sm.geometry(values)
    x, rp = sm._disk_particles(values, g)
    return values, g, x, rp


def _layers(x, g):
    """The layers of the first disk: its centres grouped by their x."""
    first = x[np.abs(x[:, 0] - g["disk_x"][0]) < g["disk_thickness"]]
    levels = np.unique(np.round(first[:, 0], 12))
    return levels, [first[np.isclose(first[:, 0], lv, rtol=0, atol=1e-12)][:, 1:] for lv in levels]


def test_the_layers_fill_the_thickness_face_to_face():
    """round(t / 2 rp) layers, evenly spaced, the outer ones touching the disk's faces
    (their centres rp inside), for every disk."""
    values, g, x, rp = _disks()
    t = g["disk_thickness"]
    n = round(t / (2 * rp))
    assert n > 1
    for x0 in g["disk_x"]:
        levels = np.unique(np.round(x[np.abs(x[:, 0] - x0) < t][:, 0] - x0, 12))
        np.testing.assert_allclose(levels, np.linspace(-0.5 * t + rp, 0.5 * t - rp, n), atol=1e-12)


def test_spheres_of_a_layer_stand_1_3_radii_apart_on_a_hexagonal_lattice():
    """In-plane spacing a = 1.3 rp (a bead of 0.9 mm or more cannot pass between them); every
    sphere of a layer away from its edges has six neighbours at a."""
    values, g, x, rp = _disks()
    a = 1.3 * rp
    _, layers = _layers(x, g)
    for yz in layers:
        d, _ = cKDTree(yz).query(yz, k=7)
        assert d[:, 1].min() == pytest.approx(a, rel=1e-9)
        rho = np.hypot(yz[:, 0], yz[:, 1])
        inner = (rho > g["shaft_radius"] + 3 * a) & (rho < g["disk_radius"] - 3 * a)
        far_from_holes = np.ones(len(yz), bool)
        for h in range(values["holes"]):
            phi = 2 * math.pi * h / values["holes"]
            c = g["hole_pitch_radius"] * np.array([math.cos(phi), math.sin(phi)])
            far_from_holes &= np.hypot(*(yz - c).T) > g["hole_radius"] + 3 * a
        six = np.abs(d[inner & far_from_holes, 1:] - a) < 1e-9 * a
        assert six.all()


def test_a_disk_has_no_gap_but_its_holes():
    """Every point of the disk's annulus (shaft + rp / 2 to R - rp), away from the drilled
    holes, lies within a = 1.3 rp of a sphere centre of each layer: no row is missing at the
    rim (the full-scale disk, 29 spacings in radius)."""
    values, g, x, rp = _disks()
    a = 1.3 * rp
    rng = np.random.default_rng(0)
    n = 100_000
    theta = rng.uniform(0, 2 * math.pi, n)
    rho = np.sqrt(rng.uniform((g["shaft_radius"] + 0.5 * rp) ** 2, (g["disk_radius"] - rp) ** 2, n))
    pts = np.column_stack([rho * np.cos(theta), rho * np.sin(theta)])
    keep = np.ones(n, bool)
    for h in range(values["holes"]):
        phi = 2 * math.pi * h / values["holes"]
        c = g["hole_pitch_radius"] * np.array([math.cos(phi), math.sin(phi)])
        keep &= np.hypot(*(pts - c).T) >= g["hole_radius"] + a
    _, layers = _layers(x, g)
    for yz in layers:
        d, _ = cKDTree(yz).query(pts[keep])
        assert d.max() < a


def test_a_thin_disk_is_one_layer_of_distinct_spheres():
    """A disk two sphere radii thick is one layer at its mid-plane, no sphere twice."""
    values, g, x, rp = _disks(disk_thickness=2 * 0.9e-3)
    levels, layers = _layers(x, g)
    assert levels == pytest.approx([g["disk_x"][0]], abs=1e-12)
    d, _ = cKDTree(x).query(x, k=2)
    assert d[:, 1].min() == pytest.approx(1.3 * rp, rel=1e-9)
