"""Rays from a drum's axis to its liner (a mesh around the y axis from y = 0 to the drum's
length): the distances the scenes with a liner check the liner by, and the refusals of a liner
that does not enclose the axis or holds it inside its solid."""

import math

import numpy as np

from ..engine.mesh_io import first_hits


def axis_rays(liner, vertices, faces, length, rays, heights, span):
    """Distances [m] (heights, rays) from the axis (x = z = 0) to the liner's first surface, along
    ``rays`` directions at equal angles in the x-z plane at ``heights`` equally spaced heights;
    refuses (naming ``liner``, with ``span`` saying where the mesh lies) a liner that some ray
    leaves without meeting, or one whose solid the axis lies in."""
    angle = 2 * math.pi * (np.arange(rays) + 0.5) / rays
    levels = length * (np.arange(heights) + 0.5) / heights
    n = angle.size * levels.size
    origins = np.column_stack([np.zeros(n), np.repeat(levels, angle.size), np.zeros(n)])
    directions = np.tile(np.column_stack([np.cos(angle), np.zeros_like(angle), np.sin(angle)]),
                         (levels.size, 1))
    dist, inside = first_hits(vertices, faces, origins, directions)
    if not np.isfinite(dist).all():
        raise ValueError(f"liner: {liner}: does not enclose the drum's axis (x = z = 0): "
                         f"{int((~np.isfinite(dist)).sum())} of {n} rays from it meet no "
                         f"wall, the charge would fall out; {span}")
    if inside.any():
        raise ValueError(f"liner: {liner}: the drum's axis (x = z = 0) lies inside the liner's "
                         f"solid, not in its hollow; {span}")
    return dist.reshape(heights, rays)
