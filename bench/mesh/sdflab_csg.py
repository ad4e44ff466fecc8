#!/usr/bin/env python3
"""Mesh the CSG classic with fogleman's sdf (PyPI package `sdflab`, import
name `sdf`) for bench/mesh.sh.

    python3 bench/mesh/sdflab_csg.py STEP OUT.stl

Shape: sphere radius 1.35 intersected with the box of side 2 (half extent 1),
minus three infinite cylinders of radius 0.55 along x, y and z; centred at the
origin.  Sampled on the grid of spacing STEP over the cube [-1.05, 1.05]^3
(np.arange(-1.05, 1.05, STEP) along each axis), meshed by sdf's sparse
marching cubes (skimage.measure.marching_cubes on blocks of 32^3 cells, blocks
far from the surface skipped), sdf's default worker count
(multiprocessing.cpu_count() threads), and written by sdf as a binary STL
(a triangle soup).  Prints sdf's own summary (samples, triangles, seconds).
"""
import sys

from sdf import X, Y, box, cylinder, sphere  # sdflab

BOUND = 1.05


def main():
    if len(sys.argv) != 3:
        print(__doc__.strip().split("\n\n")[1], file=sys.stderr)
        return 2
    step = float(sys.argv[1])
    out = sys.argv[2]
    c = cylinder(0.55)  # along z
    f = sphere(1.35) & box(2)
    f -= c | c.orient(X) | c.orient(Y)
    f.save(out, step=step, bounds=((-BOUND,) * 3, (BOUND,) * 3), verbose=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
