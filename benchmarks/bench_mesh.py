"""The STL union mesh: time and achieved error for a 50-sphere clump, beside the exact mass properties.

Run:  OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_mesh [--quick]

Side by side in one run, on 50-sphere clumps with triple overlaps (benchmarks/harness.py's
grain_clumps, ~4 overlapping neighbours per sphere), for tolerances 1e-2, 1e-3 and 1e-4:
the wall and CPU time of :func:`clumpprops.mesh.union_mesh` (manifold3d's boolean union,
with its check against the exact volume and area), the segments per sphere, the triangles,
and the achieved relative volume and area errors against :func:`clumpprops.shape_descriptors`;
and the time of the exact ``mass_properties`` of the same clump.  The target is the 1e-3 mesh
in <= 1 s.  Times: wall clock and CPU time of this process (benchmarks/harness.py).
"""
from __future__ import annotations

import os
import sys

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import clumpprops as cp  # noqa: E402
from clumpprops.mesh import union_mesh  # noqa: E402

from .harness import best_of, grain_clumps, machine, mean_caps, per_call, section  # noqa: E402


def mesh_row(c, r, tol, exact):
    """Time one union mesh at `tol`; print and return (wall s, volume error, area error)."""
    wall, cpu, m = best_of(lambda: union_mesh(c, r, tol), 3)
    dv, da = m.volume / exact.volume - 1.0, m.area / exact.surface_area - 1.0
    print(f"  tol {tol:7.0e}   {wall:7.3f} s wall {cpu:7.3f} s cpu   {m.segments:4d} segments "
          f"{len(m.faces):8d} triangles   volume error {dv:+.2e}   area error {da:+.2e}")
    return wall, dv, da


def main(argv=None):
    """Run the benchmark; ``--quick`` measures one clump instead of three."""
    quick = "--quick" in (sys.argv[1:] if argv is None else argv)
    rng = np.random.default_rng(2024)
    print(machine())
    cs, rs = grain_clumps(1 if quick else 3, 50, rng, 4.0)
    worst = 0.0
    for k, (c, r) in enumerate(zip(cs, rs)):
        section(f"clump {k}: 50 spheres, {mean_caps(c, r):.1f} caps per sphere")
        exact = cp.shape_descriptors(c, r)
        t_exact = per_call(lambda: cp.mass_properties(c, r), 20)[0]
        print(f"  exact mass_properties   {t_exact * 1e3:8.3f} ms")
        for tol in (1e-2, 1e-3, 1e-4):
            wall, dv, da = mesh_row(c, r, tol, exact)
            if tol == 1e-3:
                worst = max(worst, wall)
                assert max(abs(dv), abs(da)) <= tol
    print(f"\nSTL of a 50-sphere union at 1e-3: {worst:.3f} s (target <= 1 s): " + ("met" if worst <= 1.0 else "NOT met"))


if __name__ == "__main__":
    main()
