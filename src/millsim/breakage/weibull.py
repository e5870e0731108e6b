"""Seed 000 fracture of disks: Weibull probability per contact event, split into two disks.

- Probability that a disk of radius R breaks under a contact whose largest normal force over the
  contact event was F: P = 1 - exp(-c R^-3 F^4) (seed 000 eq 11 with z = 2 in 2D). It is evaluated
  once per contact event, when the contact ends, so the breakage rate does not depend on dt.
- Fragment sizes: one fragment from the Rosin-Rammler law with k = R, beta = 1, truncated at 3R/4
  (inverse transform R_f = -R ln(1 - u (1 - e^-3/4))), the other from area conservation
  R_2 = sqrt(R^2 - R_f^2) (ballmill.md section 6). Both are placed inside the parent along the
  direction perpendicular to the force, so the split opens across the load.
"""

import math

import numpy as np
from numba import njit

RR_TRUNCATION = 0.75  # largest Rosin-Rammler fragment, in parent radii
_Q_MAX = 1.0 - math.exp(-RR_TRUNCATION)


@njit(inline="always", cache=True)
def fracture_probability(c, radius, force):
    """P = 1 - exp(-c R^-3 F^4) [c in m^3 N^-4, R in m, F in N]."""
    return 1.0 - math.exp(-c * force**4 / radius**3)


def force_at_half_probability(c, radius):
    """F with P = 1/2: (ln 2 R^3 / c)^(1/4)."""
    return (math.log(2.0) * np.asarray(radius) ** 3 / c) ** 0.25


def rosin_rammler_radius(parent, u):
    """Inverse-transform sample of the truncated Rosin-Rammler fragment radius."""
    return -parent * np.log1p(-np.asarray(u) * _Q_MAX)


def rosin_rammler_cdf(r, parent):
    """Truncated, renormalised Rosin-Rammler CDF of the drawn fragment's radius."""
    r = np.clip(np.asarray(r, dtype=float), 0.0, RR_TRUNCATION * parent)
    return (1.0 - np.exp(-r / parent)) / _Q_MAX


def split_disk(center, parent, force_dir, u):
    """Two fragments (centres, radii) filling the parent disk, opened across the force.

    Args:
        center: parent centre (3,), z = 0 in 2D.
        parent: parent radius.
        force_dir: unit vector of the breaking force in the plane.
        u: uniform number for the Rosin-Rammler draw.
    """
    r1 = float(rosin_rammler_radius(parent, u))
    r2 = math.sqrt(parent * parent - r1 * r1)  # area conservation, exact to round-off
    across = np.array([-force_dir[1], force_dir[0], 0.0])
    norm = np.linalg.norm(across)
    across = across / norm if norm > 0 else np.array([1.0, 0.0, 0.0])
    centers = np.array([center + (parent - r1) * across, center - (parent - r2) * across])
    return centers, np.array([r1, r2])
