"""Overlapping sphere pairs inside each clump (vectorised over clumps).

Small clumps (N <= 64) enumerate all pairs with array arithmetic grouped by sphere
count; large clumps use a k-d tree (scipy.spatial.cKDTree), so the cost stays near
O(N log N) when each sphere overlaps a bounded number of others.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ._input import Spheres

_DENSE_MAX = 64


def candidate_pairs(sph: Spheres):
    """Global sphere indices (a, b), a < b, of pairs in the same clump whose balls may overlap."""
    out_a, out_b = [], []
    counts = sph.counts
    for n in np.unique(counts):
        n = int(n)
        if n < 2:
            continue
        ms = np.flatnonzero(counts == n)
        if n <= _DENSE_MAX:
            iu, ju = np.triu_indices(n, 1)
            base = sph.starts[ms][:, None]
            out_a.append((base + iu).ravel())
            out_b.append((base + ju).ravel())
        else:
            for m in ms:
                s0 = int(sph.starts[m])
                c = sph.centers[s0 : s0 + n]
                r = sph.radii[s0 : s0 + n]
                tree = cKDTree(c)
                # every overlapping pair has D < r_i + r_j <= r_i + r_max
                pairs = tree.query_pairs(2.0 * float(r.max()), output_type="ndarray")
                if len(pairs):
                    out_a.append(s0 + pairs[:, 0])
                    out_b.append(s0 + pairs[:, 1])
    if not out_a:
        e = np.zeros(0, dtype=np.int64)
        return e, e
    a = np.concatenate(out_a) if len(out_a) > 1 else out_a[0]
    b = np.concatenate(out_b) if len(out_b) > 1 else out_b[0]
    return a.astype(np.int64, copy=False), b.astype(np.int64, copy=False)


def overlapping_pairs(sph: Spheres):
    """Pairs (a, b) with centre distance D < r_a + r_b, their D (m), and the unit vector e = (c_b - c_a)/D.

    Returns a, b (P,), D (P,), e (P, 3); e is (0, 0, 1) where D == 0 (concentric spheres).
    """
    a, b = candidate_pairs(sph)
    D, e = distance_and_axis(sph.centers[b] - sph.centers[a])
    keep = D < sph.radii[a] + sph.radii[b]
    return a[keep], b[keep], D[keep], e[keep]


def distance_and_axis(dv):
    """|dv| (P,) and the unit vector dv/|dv| (P,3); (0, 0, 1) where dv == 0 (concentric spheres)."""
    D = np.sqrt(np.einsum("ij,ij->i", dv, dv))
    e = dv / np.where(D > 0, D, 1.0)[:, None]
    e[D == 0] = (0.0, 0.0, 1.0)
    return D, e
