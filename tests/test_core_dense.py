"""Dense clumps in the compiled core: spheres with more caps than ``kCoveredCapsAbove`` (read from
clumpprops/core/clumpprops.hpp) are computed on the subset of their caps that reaches the exposed
region.  Checked against the numpy oracle (``tests/_exact_numpy.py``, every cap in the
arrangement) and against exact geometric facts of the union."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import clumpprops as cp
import clumpprops.core  # noqa: F401  (cp.core)
from clumpprops import _input
from clumpprops._properties import finish

import _exact_numpy

HPP = Path(cp.core.__file__).resolve().parent / "clumpprops.hpp"
CAPS_ABOVE = int(re.search(r"kCoveredCapsAbove = (\d+);", HPP.read_text()).group(1))


def numpy_exact(c, r):
    sph = _input.normalize(c, r)
    V, S, Q = _exact_numpy.exact_moments(sph)
    return finish(V, S, Q, sph.origin, 1.0, "exact", sph.batched)


def most_caps(c, r):
    D = np.linalg.norm(c[:, None] - c[None], axis=-1)
    return int(((D < r[:, None] + r[None]) & ~np.eye(len(r), dtype=bool)).sum(axis=1).max())


def shell(n, radius, seed):
    """n spheres centred on the unit sphere: every pair overlaps, every sphere is partly exposed."""
    u = np.random.default_rng(seed).normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1)[:, None], np.full(n, radius)


def blob(n, seed):
    """n spheres of mixed radii in a small ball: most are buried in the union of the others."""
    rng = np.random.default_rng(seed)
    return rng.normal(size=(n, 3)) * 0.3, rng.uniform(0.4, 1.0, n)


CLUMPS = [("shell60", *shell(60, 1.2, 3)), ("blob70", *blob(70, 5))]


@pytest.mark.parametrize("name,c,r", CLUMPS, ids=[x[0] for x in CLUMPS])
def test_dense_clump_matches_numpy_oracle(name, c, r):
    assert most_caps(c, r) > CAPS_ABOVE  # the subset route is taken
    mp = cp.mass_properties(c, r)
    ref = numpy_exact(c, r)
    L = float(np.ptp(c, axis=0).max() + 2 * r.max())
    assert abs(mp.mass / ref.mass - 1) < 1e-13
    assert np.max(np.abs(mp.center_of_mass - ref.center_of_mass)) < 1e-13 * L
    assert np.max(np.abs(mp.inertia - ref.inertia)) < 1e-13 * np.max(np.abs(ref.inertia))


def test_sphere_covered_by_the_others_but_inside_none_adds_nothing():
    # a ball of radius 0.3 at the centre of a dense shell: every point of it lies in some shell
    # sphere (at distance < 1.2 from a centre), none of which holds it whole (D + 0.3 > 1.2);
    # all its caps go to the subset route and the union is the shell's
    c, r = shell(100, 1.2, 6)
    c2, r2 = np.vstack([[0.0, 0.0, 0.0], c]), np.r_[0.3, r]
    assert int((np.linalg.norm(c, axis=1) < 1.2 + 0.3).sum()) > CAPS_ABOVE
    assert np.all(np.linalg.norm(c, axis=1) + 0.3 > 1.2)  # inside no single sphere
    a = cp.mass_properties(c, r)
    b = cp.mass_properties(c2, r2)
    assert abs(b.mass / a.mass - 1) < 1e-14
    assert np.max(np.abs(b.center_of_mass - a.center_of_mass)) < 1e-14
    assert np.max(np.abs(b.inertia - a.inertia)) < 1e-14 * np.max(np.abs(a.inertia))


def test_dense_shell_is_invariant_under_rotation_and_relabelling():
    c, r = shell(300, 1.2, 4)
    R = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))[0]
    perm = np.random.default_rng(2).permutation(len(r))
    a = cp.mass_properties(c, r)
    b = cp.mass_properties(c[perm] @ R.T, r[perm])
    assert abs(b.mass / a.mass - 1) < 1e-13
    assert np.max(np.abs(b.center_of_mass - R @ a.center_of_mass)) < 1e-13
    assert np.max(np.abs(b.inertia - R @ a.inertia @ R.T)) < 1e-13 * np.max(np.abs(a.inertia))
