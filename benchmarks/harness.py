"""The benchmarks' shared harness: timing, the machine's facts, the page of record, shared inputs.

Every benchmark in this folder times one compute, measures its competing variants side by side in
one run (so that they see the same load on a shared machine), prints its figures and ratios, and
writes its page of record, ``benchmarks/results/NAME.json``, with :func:`write`.  Run one from the
repository's root as a module::

    OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_core

Times are wall clock (``time.perf_counter``) and CPU time of this process (``time.process_time``);
the machine is shared, so CPU time is the steadier figure and both are recorded.
"""
from __future__ import annotations

import json
import os
import platform
import sys
import time

import numpy as np

RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")


def machine(**extra):
    """The facts a page of record starts with (platform, versions, date, load), plus ``extra``."""
    import clumpprops

    return {"machine": platform.platform(), "python": sys.version.split()[0], "numpy": np.__version__,
            "clumpprops": clumpprops.__version__, **extra, "date": time.strftime("%Y-%m-%d %H:%M"),
            "loadavg_start": os.getloadavg()}


def _timed(f):
    t0, p0 = time.perf_counter(), time.process_time()
    out = f()
    return time.perf_counter() - t0, time.process_time() - p0, out


def per_call(f, n):
    """Median wall and median CPU seconds of ``n`` calls of ``f``."""
    w, c = zip(*(_timed(f)[:2] for _ in range(n)))
    return float(np.median(w)), float(np.median(c))


def best_of(f, repeat=3):
    """Best wall and best CPU seconds of ``repeat`` calls of ``f``, and the last call's value."""
    runs = [_timed(f) for _ in range(repeat)]
    return min(r[0] for r in runs), min(r[1] for r in runs), runs[-1][2]


def section(title):
    """Print a section's heading."""
    print(f"\n== {title}", flush=True)


def read(name):
    """The page of record ``name`` (a file name under :data:`RESULTS`), or {} if there is none."""
    path = os.path.join(RESULTS, name)
    if not os.path.exists(path):
        return {}
    with open(path) as f:
        return json.load(f)


def write(name, figures, **json_options):
    """Write ``figures`` to the page of record ``name`` under :data:`RESULTS` (atomically); its path."""
    path = os.path.join(RESULTS, name)
    os.makedirs(RESULTS, exist_ok=True)
    with open(path + ".tmp", "w") as f:
        json.dump(figures, f, indent=1, **json_options)
        f.write("\n")
    os.replace(path + ".tmp", path)
    print(f"\nwritten {os.path.relpath(path)}")
    return path


# ---- inputs shared by the benchmarks ------------------------------------------------------------
def grain_clumps(M, N, rng, overlap_neighbours=4.0):
    """M clumps of N spheres (radii 0.8-1.2) filling an elongated grain (3:1.5:1 ellipsoid) at a
    density where each sphere overlaps about ``overlap_neighbours`` others (triple overlaps included)."""
    r0 = 1.0
    # number density n so that the expected count of centres within 2 r0 is overlap_neighbours
    n = overlap_neighbours / (4.0 / 3.0 * np.pi * (2.0 * r0) ** 3)
    a = (N / n / (4.0 / 3.0 * np.pi * 3.0 * 1.5)) ** (1.0 / 3.0)
    u = rng.normal(size=(M, N, 3))
    u /= np.linalg.norm(u, axis=-1)[..., None]
    u *= rng.random((M, N, 1)) ** (1.0 / 3.0)
    return u * (np.array([3.0, 1.5, 1.0]) * a), rng.uniform(0.8, 1.2, (M, N)) * r0


def random_dimers(M, rng):
    """M random dimers: radii 0.5-1, centre distance 0.3-0.95 of the radii's sum, random axes and places."""
    c = np.zeros((M, 2, 3))
    axis = rng.normal(size=(M, 3))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    r = rng.uniform(0.5, 1.0, (M, 2))
    D = rng.uniform(0.3, 0.95, M) * (r[:, 0] + r[:, 1])
    c[:, 1] = axis * D[:, None]
    c += rng.normal(size=(M, 1, 3))
    return c, r


def mean_caps(c, r):
    """Mean number of spheres each sphere of one clump overlaps."""
    D = np.linalg.norm(c[:, None] - c[None], axis=-1)
    return float(((D < r[:, None] + r[None]) & ~np.eye(len(r), dtype=bool)).sum(axis=1).mean())
