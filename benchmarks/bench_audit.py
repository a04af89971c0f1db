"""The time of ``clumpprops audit`` on a 50-sphere clump: every method, tolerances 1 % and 0.1 %.

Run:  OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_audit [--repeat R]

Prints, side by side in one run, the wall-clock and CPU time of the exact mass properties alone
and of a whole audit (exact, summed spheres, YADE voxel at discretization 5, LIGGGHTS Monte Carlo
at ntry = 10^6 with and without the 3.8.0 Iyz defect, Halton QMC at 2^16 points, and the
recommended settings for 1 % and 0.1 %, voxel grids and QMC scrambles included), and the part
each step takes.  Target: the audit within 2 s.
"""
from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from clumpprops import mass_properties  # noqa: E402
from clumpprops.audit import audit_clump  # noqa: E402

TARGET_S = 2.0


def clump50(seed=1):
    """A 50-sphere clump with heavy (also multiple) overlaps, in m."""
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.0, 1.0, (50, 3)), rng.uniform(0.3, 0.6, 50)


def timed(fn):
    w, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - w, time.process_time() - c


def main(argv=None):
    """Print the audit's time beside the exact values' time.

    Parameters
    ----------
    argv : sequence of str, optional
        ``--repeat R`` (default 3): audits timed; the median is reported.
    """
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    c, r = clump50()
    runs_exact = [timed(lambda: mass_properties(c, r, density=1000.0))[1:] for _ in range(20)]
    runs = [timed(lambda s=s: audit_clump(c, r, 1000.0, (0.01, 0.001), seed=s)) for s in range(args.repeat)]
    ew, ec = np.median(runs_exact, axis=0)
    aw, ac = np.median([x[1:] for x in runs], axis=0)
    print(f"50-sphere clump, tolerances 1 % and 0.1 %, {args.repeat} audits (median), {len(runs_exact)} exact calls")
    print(f"{'exact mass properties alone':<34} wall {ew * 1e3:9.2f} ms   cpu {ec * 1e3:9.2f} ms")
    print(f"{'audit, every method':<34} wall {aw:9.3f} s    cpu {ac:9.3f} s    target <= {TARGET_S:g} s: "
          f"{'met' if aw <= TARGET_S else 'NOT met'}")
    rep = runs[len(runs) // 2][0]
    for m in rep["methods"]:
        print(f"  {m['method']:<34} {m['setting'] or '':<20} {m['seconds']:8.3f} s")
    spent = sum(m["seconds"] for m in rep["methods"])
    print(f"  {'advice (voxel grids, QMC scrambles)':<55} {rep['seconds']['audit'] - spent:8.3f} s")


if __name__ == "__main__":
    main()
