"""The cost of the exact surface area: mass properties alone against mass properties with the area.

Run:  OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_shape [--quick]

Side by side in one run, on a 10-sphere clump with triple overlaps (benchmarks/harness.py's
grain_clumps, ~4 overlapping neighbours per sphere):

 1. one Python call (median of many calls): ``mass_properties`` against the same pass with the
    surface area (the core's ``run_area``), and the full ``shape_descriptors`` (which adds the
    extents and the bounding sphere, in Python);
 2. a batch of 10-sphere clumps in one core call: clumps/s without and with the area.

Prints each time and the ratio; the target is a ratio <= 2 for the area with the mass properties.
Times: wall clock and CPU time of this process (benchmarks/harness.py).
"""
from __future__ import annotations

import os
import sys

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import clumpprops as cp  # noqa: E402
from clumpprops import api  # noqa: E402

from .harness import best_of, grain_clumps, machine, mean_caps, per_call, section  # noqa: E402


def one_clump(c, r, calls):
    """1. one clump, one Python call each: the three routes, median CPU seconds."""
    section(f"1. one 10-sphere clump ({mean_caps(c, r):.1f} caps per sphere), one Python call, median of {calls}")
    routes = {
        "mass_properties": lambda: cp.mass_properties(c, r),
        "mass_properties + area": lambda: api._compiled(c, r, 1.0, "exact", with_area=True),
        "shape_descriptors": lambda: cp.shape_descriptors(c, r),
    }
    times = {}
    for _ in range(2):  # alternate, so that a change of load hits every route alike
        for name, f in routes.items():
            times.setdefault(name, []).append(per_call(f, calls)[1])
    base = min(times["mass_properties"])
    for name, t in times.items():
        print(f"  {name:<24} {min(t) * 1e6:9.2f} us   ratio {min(t) / base:5.2f}")
    return min(times["mass_properties + area"]) / base


def batch(c, r):
    """2. a batch in one core call: clumps/s without and with the area."""
    M = len(r)
    section(f"2. a batch of {M} 10-sphere clumps, one core call")
    rates = {}
    for name, with_area in (("mass properties", False), ("mass properties + area", True)):
        cpu = best_of(lambda: api._compiled(c, r, 1.0, "exact", with_area=with_area), 3)[1]
        rates[name] = M / cpu
        print(f"  {name:<24} {M / cpu:12.0f} clumps/s")
    ratio = rates["mass properties"] / rates["mass properties + area"]
    print(f"  ratio of times {ratio:.3f}")
    return ratio


def main(argv=None):
    """Run the benchmark; ``--quick`` uses fewer calls and a smaller batch."""
    quick = "--quick" in (sys.argv[1:] if argv is None else argv)
    rng = np.random.default_rng(2024)
    print(machine())
    c, r = grain_clumps(1, 10, rng, 4.0)
    single = one_clump(c[0], r[0], 200 if quick else 2000)
    cb, rb = grain_clumps(2000 if quick else 20000, 10, rng, 4.0)
    in_batch = batch(cb, rb)
    worst = max(single, in_batch)
    print(f"\narea with the mass properties: {worst:.2f}x the mass properties alone (target <= 2x): "
          + ("met" if worst <= 2.0 else "NOT met"))


if __name__ == "__main__":
    main()
