"""Accuracy of method="exact" against the independent slicing reference (docs/exact_accuracy.md).

Run:  .venv/bin/python tests/exact_accuracy.py
(as a script: Python puts tests/ on sys.path, where the reference lives; clumpprops is the installed
package, the repository's own in the editable install ``make setup`` makes).  Prints, for three kinds of clump, the relative errors of exact vs the reference
(tests/reference_slicing.py: exact cross-sections by Green's theorem, quad over z):
volume |dV|/V, centre of mass |dcom|/L (L = clump extent), inertia max|dI_ij|/max|I_ij|,
plus the reference's own quad error estimate (relative, max over the 10 moments).
"""
from __future__ import annotations

import math
import time

import numpy as np
import reference_slicing as rs

from clumpprops import mass_properties


def triple10():
    rng = np.random.default_rng(2024)
    return rng.uniform(-0.6, 0.6, (10, 3)), rng.uniform(0.35, 0.7, 10)


def near_degenerate():
    """Tangent pair, internally tangent pair, near-duplicate (1e-12), 4 surfaces through a point, 1e-14 overlap."""
    rng = np.random.default_rng(7)
    p = np.array([0.1, -0.2, 0.05])
    c4 = p + 0.5 * rng.normal(size=(4, 3))
    r4 = np.linalg.norm(c4 - p, axis=1)
    c = np.vstack([
        c4,
        c4[0] + [r4[0] + 0.4, 0, 0],            # tangent to sphere 0
        c4[1] + [0, r4[1] - 0.25, 0],           # internally tangent to sphere 1
        c4[2] + 1e-12,                          # near-duplicate of sphere 2
        c4[3] + [0, 0, (r4[3] + 0.3) * (1 - 1e-14)],  # 1e-14 overlap with sphere 3
    ])
    r = np.concatenate([r4, [0.4, 0.25, r4[2], 0.3]])
    return c, r


def big100():
    """100 spheres along a branching random walk: every sphere overlaps ~3-6 others."""
    rng = np.random.default_rng(99)
    c = [np.zeros(3)]
    r = [0.5]
    while len(c) < 100:
        k = rng.integers(max(0, len(c) - 8), len(c))
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        rn = rng.uniform(0.3, 0.6)
        c.append(c[k] + 0.75 * (r[k] + rn) * u)
        r.append(rn)
    return np.array(c), np.array(r)


def square_rotated():
    """Regression (wrong by 4e-10 before exact.py 9b15457): 4 spheres r = sqrt(1/2) on a unit square, rotated 1 rad about y."""
    import itertools
    from scipy.spatial.transform import Rotation

    c = np.array(list(itertools.product([0, 1], [0, 1], [0])), float)
    return c @ Rotation.from_rotvec([0.0, 1.0, 0.0]).as_matrix().T, np.full(4, math.sqrt(0.5))


def errors(c, r):
    t0 = time.perf_counter()
    e = mass_properties(c, r, 1.0, method="exact")
    t1 = time.perf_counter()
    m = rs.union_mass_properties(c, r, 1.0)
    t2 = time.perf_counter()
    L = float(np.ptp(c, axis=0).max() + 2 * r.max())
    info = m["info"]
    V_l, S_l, Q_l, _, _ = info["local"]
    scale = np.array([V_l] + [abs(V_l)] * 9)
    qerr = float(np.max(info["quad_error"] / np.maximum(np.abs(scale), 1e-300)))
    return dict(
        volume=abs(e.volume / m["volume"] - 1),
        com=float(np.max(np.abs(e.center_of_mass - m["com"])) / L),
        inertia=float(np.max(np.abs(e.inertia - m["inertia"])) / np.max(np.abs(m["inertia"]))),
        quad=qerr,
        pieces=info["pieces"],
        t_exact=t1 - t0,
        t_ref=t2 - t1,
    )


def main():
    rows = [("10 spheres, triple overlaps", *triple10()), ("near-degenerate (8 spheres)", *near_degenerate()), ("100 spheres", *big100()),
            ("square r=sqrt(1/2), rotated 1 rad", *square_rotated())]
    print(f"{'clump':32s} {'volume':>9s} {'com':>9s} {'inertia':>9s} {'ref quad':>9s} {'pieces':>7s} {'t_exact':>8s} {'t_ref':>7s}")
    for name, c, r in rows:
        d = errors(c, r)
        print(
            f"{name:32s} {d['volume']:9.1e} {d['com']:9.1e} {d['inertia']:9.1e} {d['quad']:9.1e} "
            f"{d['pieces']:7d} {d['t_exact']*1e3:6.1f}ms {d['t_ref']:6.1f}s"
        )


if __name__ == "__main__":
    main()
