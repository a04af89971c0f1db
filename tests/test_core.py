"""The compiled core (clumpprops/core/clumpprops.hpp) against independent routes.

* the numpy implementation of the exact method (``tests/_exact_numpy.py``, the test
  oracle: same mathematics, vectorised, per-arc sign tests instead of the core's coverage
  depth) on thousands of random and near-degenerate clumps (``_core_cases``): 2,200 here,
  ``CLUMPPROPS_CORE_CASES=10000`` (``make test-core``) for the long run;
* the slicing reference (tests/reference_slicing.py, no clumpprops code) on clumps with
  20 and more caps per sphere, where the coverage-depth classification does real work;
* the numpy pairwise implementation (``pairwise.pairwise_moments``) and its triple check.
"""
from __future__ import annotations

import os

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import clumpprops as cp
from clumpprops import _input
from clumpprops._properties import finish
from clumpprops.pairwise import pairwise_moments

import _exact_numpy
import reference_slicing as rs
from _core_cases import KINDS, cases

N_CASES = int(os.environ.get("CLUMPPROPS_CORE_CASES", "2200"))
LONG = os.environ.get("CLUMPPROPS_CORE_LONG") == "1"


def numpy_exact(c, r, rho=1.0):
    sph = _input.normalize(c, r)
    V, S, Q = _exact_numpy.exact_moments(sph)
    return finish(V, S, Q, sph.origin, rho, "exact", sph.batched)


def errors(a, b, L):
    return (abs(a.mass / b.mass - 1), float(np.max(np.abs(a.center_of_mass - b.center_of_mass))) / L,
            float(np.max(np.abs(a.inertia - b.inertia)) / np.max(np.abs(b.inertia))))


def test_core_matches_numpy_oracle_on_random_and_near_degenerate_clumps():
    worst = dict.fromkeys(KINDS, 0.0)
    seen = dict.fromkeys(KINDS, 0)
    items = list(cases(N_CASES, seed=2026))
    batch = cp.mass_properties([c for _, c, _ in items], [r for _, _, r in items])  # one core call
    for m, (kind, c, r) in enumerate(items):
        ref = numpy_exact(c, r)
        one = batch[m]
        L = float(np.ptp(c, axis=0).max() + 2 * r.max())
        e = max(errors(one, ref, L))
        worst[kind] = max(worst[kind], e)
        seen[kind] += 1
        assert e < 1e-13, (kind, m, c.tolist(), r.tolist(), errors(one, ref, L))
    assert all(seen[k] > 0 for k in KINDS), seen


def belt(K=20, seed=0):
    """A unit sphere with K spheres around its equator (K caps on it, each crossing two others)."""
    rng = np.random.default_rng(seed)
    a = 2 * np.pi * np.arange(K) / K + rng.uniform(-0.05, 0.05, K)
    u = np.c_[np.cos(a), np.sin(a), rng.uniform(-0.25, 0.25, K)]
    u /= np.linalg.norm(u, axis=1)[:, None]
    c = np.vstack([[0, 0, 0], u * 1.05])
    r = np.r_[1.0, rng.uniform(0.3, 0.4, K)]
    return c @ Rotation.from_rotvec([0.3, -0.7, 0.4]).as_matrix().T, r


def shell(K=22, seed=0):
    """A unit sphere with K random spheres crossing its surface: K caps, many triple points."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(K, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    return np.vstack([[0, 0, 0], u * rng.uniform(0.9, 1.1, (K, 1))]), np.r_[1.0, rng.uniform(0.35, 0.6, K)]


def n_caps(c, r):
    D = np.linalg.norm(c[:, None] - c[None], axis=-1)
    return ((D < r[:, None] + r[None]) & ~np.eye(len(r), dtype=bool)).sum(axis=1)


CLUMPS = [("belt20", *belt(20))] + ([("shell22", *shell(22)), ("belt30", *belt(30, seed=1))] if LONG else [])


@pytest.mark.parametrize("name,c,r", CLUMPS, ids=[x[0] for x in CLUMPS])
def test_core_matches_slicing_reference_with_20_or_more_caps(name, c, r):
    assert n_caps(c, r).max() >= 20
    mp = cp.mass_properties(c, r, 1000.0)
    ref = rs.union_mass_properties(c, r, 1000.0)
    L = float(np.ptp(c, axis=0).max() + 2 * r.max())
    assert abs(mp.mass / ref["mass"] - 1) < 1e-13
    assert np.max(np.abs(mp.center_of_mass - ref["com"])) < 1e-13 * L
    assert np.max(np.abs(mp.inertia - ref["inertia"])) < 1e-13 * np.max(np.abs(ref["inertia"]))
    # and the summed spheres are far off: the test sees the overlaps
    assert cp.mass_properties(c, r, 1000.0, method="sum").mass > 1.05 * mp.mass


def test_pairwise_core_matches_numpy_pairwise():
    rng = np.random.default_rng(7)
    cs, rs_ = [], []
    while len(cs) < 300:
        n = int(rng.integers(2, 7))
        c = rng.normal(size=(n, 3)) * 2.0
        r = rng.uniform(0.5, 1.2, n)
        sph = _input.normalize(c, r)
        try:
            pairwise_moments(sph)  # numpy: raises where three spheres share a region
        except cp.ClumpGeometryError:
            with pytest.raises(cp.ClumpGeometryError):
                cp.mass_properties(c, r, method="pairwise")
            continue
        cs.append(c)
        rs_.append(r)
    mp = cp.mass_properties(cs, rs_, 3.0, method="pairwise")
    for m, (c, r) in enumerate(zip(cs, rs_)):
        sph = _input.normalize(c, r)
        V, S, Q = pairwise_moments(sph)
        ref = finish(V, S, Q, sph.origin, 3.0, "pairwise", False)
        L = float(np.ptp(c, axis=0).max() + 2 * r.max())
        assert max(errors(mp[m], ref, L)) < 1e-13


def test_core_principal_axes_diagonalise_the_inertia():
    rng = np.random.default_rng(3)
    c = rng.normal(size=(500, 6, 3))
    r = rng.uniform(0.5, 1.0, (500, 6))
    mp = cp.mass_properties(c, r)
    J, w = mp.principal_axes, mp.principal_moments
    np.testing.assert_allclose(np.einsum("mij,mkj->mik", J, J), np.broadcast_to(np.eye(3), J.shape), atol=1e-14)
    assert np.all(np.linalg.det(J) > 0)
    assert np.all(np.diff(w, axis=1) >= 0)
    recon = np.einsum("mij,mj,mkj->mik", J, w, J)
    assert np.max(np.abs(recon - mp.inertia) / np.abs(mp.inertia).max(axis=(1, 2))[:, None, None]) < 1e-14
    np.testing.assert_allclose(w, np.linalg.eigvalsh(mp.inertia), rtol=1e-13, atol=0)
