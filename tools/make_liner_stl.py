"""Write a ball-mill liner (engine.mesh_io.liner_mesh: a closed shell with lifters) as binary STL.

    python tools/make_liner_stl.py --radius 0.1 --length 0.05 --lifters 8 --lifter-height 0.01 \
        --lifter-width 0.01 --segments 192 --axis y --out examples/meshes/ballmill_liner.stl

Lengths in the file's units (metres for the engine). The mesh is checked as read back
(engine.mesh_io.read_mesh) before the command reports its triangle count.
"""

import argparse

import numpy as np

from millsim.engine.mesh_io import liner_mesh, read_mesh, write_stl


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--radius", type=float, required=True, help="inner radius")
    ap.add_argument("--length", type=float, required=True, help="length along the axis")
    ap.add_argument("--axis", choices=("z", "y"), default="z",
                    help="the drum's axis, from 0 to length (y: the packing scene's drum)")
    ap.add_argument("--lifters", type=int, default=0)
    ap.add_argument("--lifter-height", type=float, default=0.0, help="radial, inward")
    ap.add_argument("--lifter-width", type=float, default=0.0, help="tangential")
    ap.add_argument("--segments", type=int, default=64, help="sides of the inner polygon")
    ap.add_argument("--thickness", type=float, default=None, help="default 0.1 radius")
    ap.add_argument("--ascii", action="store_true", help="ASCII STL instead of binary")
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    vertices, faces = liner_mesh(a.radius, a.length, segments=a.segments, thickness=a.thickness,
                                 lifters=a.lifters, lifter_height=a.lifter_height,
                                 lifter_width=a.lifter_width)
    if a.axis == "y":  # a rotation taking z to y (x, y, z) -> (x, z, -y): the winding stays
        vertices = np.column_stack([vertices[:, 0], vertices[:, 2], -vertices[:, 1]])
    write_stl(a.out, vertices, faces, ascii=a.ascii)
    _, faces = read_mesh(a.out)
    print(f"{a.out}: {len(faces)} triangles")


if __name__ == "__main__":
    main()
