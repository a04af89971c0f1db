"""Make ``ellipsoid20.txt``: a 20-sphere clump filling a prolate spheroid of aspect ratio 2.

The grain is CLUMP's Euclidean-distance-transform clump (Angelidakis, Nadimi, Otsubo & Utili;
PyPI ``clump-python``, ``GenerateClump_Euclidean_3D``) of the spheroid with semi-axes
2 x 1 x 1 that CLUMP ships as an example (``Ellipsoid_R_2.0_1.0_1.0.stl``): N = 20 spheres,
overlap 0.6, 50 voxels along the shortest edge.  It is scaled by 0.05 (the grain is 0.2 m long
and 0.1 m wide, the size of the paper's dimer, 0.2 m x 0.1333 m) and written in YADE's
textClumps format with 17 significant digits.  Its 20 spheres overlap so much that the summed
mass is 64 % too large (``results/grains/ellipsoid20.json`` holds the exact and summed mass
properties, written by ``python -m studies.grains``).

Needs ``pip install clump-python`` (GPL-3.0; only run to make the file, never imported by
clumpprops).  Run from the repository root::

    python studies/grains/make_ellipsoid20.py
"""
import os

import numpy as np

N_SPHERES, OVERLAP, DIVISIONS, SCALE = 20, 0.6, 50, 0.05
OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "ellipsoid20.txt")


def main():
    import CLUMP
    from CLUMP import GenerateClump_Euclidean_3D

    stl = os.path.join(os.path.dirname(CLUMP.__file__), "examples", "ParticleGeometries",
                       "Ellipsoid_R_2.0_1.0_1.0.stl")
    _, clump = GenerateClump_Euclidean_3D(inputGeom=stl, N=N_SPHERES, rMin=0, div=DIVISIONS,
                                          overlap=OVERLAP, visualise=False)
    centers = np.asarray(clump.positions, float).reshape(-1, 3) * SCALE
    radii = np.asarray(clump.radii, float).ravel() * SCALE
    with open(OUT, "w") as f:
        f.write("#format x_y_z_r_clumpId\n")
        f.write(f"# {len(radii)} spheres: CLUMP Euclidean 3-D (N = {N_SPHERES}, overlap = {OVERLAP}, "
                f"div = {DIVISIONS}) of a 2:1:1 spheroid, scaled by {SCALE} (m); "
                "made by studies/grains/make_ellipsoid20.py\n")
        for (x, y, z), r in zip(centers, radii):
            f.write(f"{x:.17g} {y:.17g} {z:.17g} {r:.17g} 0\n")
    print(f"wrote {OUT}: {len(radii)} spheres")


if __name__ == "__main__":
    main()
