"""Animation of a case from its particle snapshots (HDF5 of ``millsim run --snapshots``) to a
GIF."""

import os

import numpy as np
from matplotlib.animation import PillowWriter
from matplotlib.cm import ScalarMappable
from matplotlib.collections import EllipseCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from ..io import open_snapshots
from .style import label


def _frame(group):
    """Positions (N x 2), radii, speeds and the wall mask of one snapshot frame."""
    radius = group["radius"][:]
    wall = (group["kinematic"][:].astype(bool) if "kinematic" in group
            else np.zeros(len(radius), bool))
    speed = np.linalg.norm(group["velocity"][:, :2], axis=1)
    return group["position"][:, :2], radius, speed, wall


def animation(snapshots: str | os.PathLike[str], out: str, fps: int = 10) -> None:
    """GIF of an HDF5 snapshot file: grains coloured by speed, wall particles grey."""
    with open_snapshots(snapshots) as group:
        frames = [group[name] for name in sorted(group)]
        if not frames:
            raise ValueError(f"{snapshots}: no frames")
        position, radius, _, _ = _frame(frames[0])
        reach = np.abs(position).max() + radius.max()
        vmax = max(speed[~wall].max(initial=0.0) for *_, speed, wall in map(_frame, frames))
        colour = ScalarMappable(Normalize(0.0, vmax or 1.0), "viridis")
        fig = Figure(figsize=(5.5, 5), layout="constrained")
        ax = fig.add_subplot()
        ax.set(xlim=(-reach, reach), ylim=(-reach, reach), aspect="equal", xlabel=label("x", "m"),
               ylabel=label("y", "m"))
        ax.grid(False)
        fig.colorbar(colour, ax=ax, label=label("grain speed", "m s-1"))
        writer = PillowWriter(fps=fps)
        with writer.saving(fig, out, dpi=100):
            for group in frames:
                position, radius, speed, wall = _frame(group)
                colours = colour.to_rgba(speed)
                colours[wall] = (0.6, 0.6, 0.6, 1.0)
                for old in list(ax.collections):
                    old.remove()
                ax.add_collection(EllipseCollection(
                    2 * radius, 2 * radius, 0.0, units="xy", offsets=position,
                    offset_transform=ax.transData, facecolors=colours, edgecolors="none"))
                ax.set_title(f"t = {group.attrs['time']:.3f} s")
                writer.grab_frame()
