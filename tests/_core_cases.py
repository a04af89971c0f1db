"""Random and near-degenerate clumps for the core-vs-numpy comparison (test helper, not collected).

``cases(n, seed)`` yields (kind, centers (N,3), radii (N,)) covering: random overlapping
clumps (2-14 spheres, ~2-8 neighbours each), exactly tangent pairs (dyadic numbers so
D == r1 + r2 in floating point), near-tangent pairs (1e-15 .. 1e-9), internally tangent
spheres, duplicates, near-duplicates offset by 1e-300 .. 1e-6 of the radius, four sphere
surfaces through one point, a sphere through a triple point of three others, tiny
overlaps, and clumps far from the origin (1e6 m).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

KINDS = ("random", "dense", "tangent", "near_tangent", "internal_tangent", "duplicate", "near_duplicate",
         "four_through_point", "through_triple_point", "tiny_overlap", "far")


def _random(rng, n, spread):
    c = rng.normal(size=(n, 3)) * spread
    r = rng.uniform(0.5, 1.2, n)
    return c, r


def _four_through_point(rng):
    # four spheres whose surfaces all pass through p: centres p + r_i u_i
    p = rng.normal(size=3) * 0.1
    u = rng.normal(size=(4, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    r = rng.uniform(0.6, 1.0, 4)
    return p + r[:, None] * u, r


def _through_triple_point(rng):
    c = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.8, 0.0]])
    r = np.array([0.8, 0.8, 0.8])
    # triple point of the three spheres: x = 0.5 (spheres 0, 1); spheres 0 and 2 give
    # 0.25 + 1.6 y - 0.64 = 0; then z from sphere 0
    x = 0.5
    y = (0.64 - 0.25) / 1.6
    z2 = 0.64 - x * x - y * y
    p = np.array([x, y, np.sqrt(max(z2, 0.0))])
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)
    r4 = rng.uniform(0.4, 0.9)
    c = np.vstack([c, p + r4 * u])
    r = np.r_[r, r4]
    R = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
    return c @ R.T, r


def case(rng, kind):
    if kind == "random":
        return _random(rng, int(rng.integers(2, 15)), rng.uniform(0.3, 1.5))
    if kind == "dense":
        return _random(rng, int(rng.integers(8, 15)), rng.uniform(0.2, 0.5))
    if kind == "tangent":
        c, r = _random(rng, int(rng.integers(2, 8)), 0.8)
        r1, r2 = 0.625, 0.375 + 0.125 * int(rng.integers(0, 4))
        c = np.vstack([c, [[4.0, 0.0, 0.0], [4.0 + r1 + r2, 0.0, 0.0]]])
        c[:-2] = c[:-2] * 0.25 + [4.0, 0.0, 0.0]
        return c, np.r_[r, r1, r2]
    if kind == "near_tangent":
        c, r = _random(rng, int(rng.integers(1, 6)), 0.8)
        e = rng.normal(size=3)
        e /= np.linalg.norm(e)
        j = int(rng.integers(len(r)))
        r2 = rng.uniform(0.4, 1.0)
        eps = 10.0 ** rng.uniform(-15, -9) * rng.choice([-1, 1])
        return np.vstack([c, c[j] + e * (r[j] + r2) * (1 + eps)]), np.r_[r, r2]
    if kind == "internal_tangent":
        c, r = _random(rng, int(rng.integers(1, 6)), 0.8)
        j = int(rng.integers(len(r)))
        e = rng.normal(size=3)
        e /= np.linalg.norm(e)
        r2 = r[j] * rng.uniform(0.2, 0.9)
        eps = rng.choice([0.0, 1e-15, -1e-15, 1e-12])
        return np.vstack([c, c[j] + e * (r[j] - r2) * (1 + eps)]), np.r_[r, r2]
    if kind == "duplicate":
        c, r = _random(rng, int(rng.integers(2, 8)), 0.7)
        j = int(rng.integers(len(r)))
        return np.vstack([c, c[j]]), np.r_[r, r[j]]
    if kind == "near_duplicate":
        c, r = _random(rng, int(rng.integers(1, 8)), 0.7)
        j = int(rng.integers(len(r)))
        e = rng.normal(size=3)
        e /= np.linalg.norm(e)
        off = 10.0 ** rng.uniform(-300, -6)
        dr = rng.choice([0.0, off])
        return np.vstack([c, c[j] + e * off * r[j]]), np.r_[r, r[j] * (1 + dr)]
    if kind == "four_through_point":
        c, r = _four_through_point(rng)
        if rng.random() < 0.5:
            c2, r2 = _random(rng, int(rng.integers(1, 4)), 0.6)
            c, r = np.vstack([c, c2]), np.r_[r, r2]
        return c, r
    if kind == "through_triple_point":
        return _through_triple_point(rng)
    if kind == "tiny_overlap":
        c, r = _random(rng, int(rng.integers(1, 6)), 0.8)
        j = int(rng.integers(len(r)))
        e = rng.normal(size=3)
        e /= np.linalg.norm(e)
        r2 = rng.uniform(0.4, 1.0)
        return np.vstack([c, c[j] + e * (r[j] + r2) * (1 - 10.0 ** rng.uniform(-8, -3))]), np.r_[r, r2]
    if kind == "far":
        c, r = _random(rng, int(rng.integers(2, 12)), rng.uniform(0.3, 1.0))
        return c + rng.uniform(-1e6, 1e6, 3), r
    raise ValueError(kind)


def cases(n, seed=0):
    rng = np.random.default_rng(seed)
    for k in range(n):
        kind = KINDS[k % len(KINDS)]
        c, r = case(rng, kind)
        yield kind, np.asarray(c, float), np.asarray(r, float)
