"""``method="exact"`` against the independent slicing reference (tests/reference_slicing.py).

The reference integrates exact cross-section moments (union of discs, Green's theorem)
over z with scipy's quad, split at every topology event; it shares no code or idea
with exact.py beyond "the union of spheres".  It is itself checked here against
closed forms (one sphere, a two-sphere lens) and for rotation invariance.

What the reference achieves (measured, tests/exact_accuracy.py): ~1e-15 relative
on volume, centre of mass and inertia tensor for generic clumps (quad's error estimates
~1e-15; round-off in the arc angles and the sum over pieces), so the tolerance below,
1e-12, is 1000x above the reference's own error and 100x below the 1e-10 the issue
asks for.  Errors are measured as |dV|/V, |d com|/L (L = clump extent) and
max|dI_ij| / max|I_ij|.
"""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import clumpprops
from clumpprops import mass_properties

import reference_slicing as rs

TOL = 1e-12
RHO = 1000.0


def extent(c, r):
    return float(np.ptp(c, axis=0).max() + 2 * r.max())


def errors(c, r, rho=RHO):
    c = np.asarray(c, float)
    r = np.asarray(r, float)
    e = mass_properties(c, r, rho, method="exact")
    m = rs.union_mass_properties(c, r, rho)
    return (
        abs(e.volume / m["volume"] - 1.0),
        float(np.max(np.abs(e.center_of_mass - m["com"])) / extent(c, r)),
        float(np.max(np.abs(e.inertia - m["inertia"])) / np.max(np.abs(m["inertia"]))),
    )


def assert_matches_reference(c, r, tol=TOL):
    ev, ec, ei = errors(c, r)
    assert ev <= tol and ec <= tol and ei <= tol, f"volume {ev:.2e}, com {ec:.2e}, inertia {ei:.2e} (tol {tol:.0e})"


def random_triple_clump(seed, n):
    """n spheres in a box with enough overlap that some point lies in three of them."""
    rng = np.random.default_rng(seed)
    c = rng.uniform(-0.6, 0.6, (n, 3))
    r = rng.uniform(0.35, 0.7, n)
    return c, r


# ------------------------------------------------------------------ the reference itself
def test_reference_single_sphere_closed_form():
    c = np.array([[0.3, -0.2, 1.7]])
    r = np.array([0.8])
    m = rs.union_mass_properties(c, r, RHO)
    V = 4.0 / 3.0 * math.pi * 0.8**3
    assert abs(m["volume"] / V - 1) < 1e-14
    assert np.max(np.abs(m["com"] - c[0])) < 1e-14
    assert np.max(np.abs(m["inertia"] - 0.4 * RHO * V * 0.64 * np.eye(3))) < 1e-14 * RHO * V * 0.64


@pytest.mark.parametrize("R1,R2,D", [(1.0, 1.0, 1.0), (1.0, 0.4, 1.2), (0.7, 1.3, 0.7)])
def test_reference_lens_closed_form(R1, R2, D):
    """Union of two spheres = sum - lens, lens volume pi (R1+R2-D)^2 (D^2 + 2D(R1+R2) - 3(R1-R2)^2) / (12 D)."""
    lens = math.pi * (R1 + R2 - D) ** 2 * (D * D + 2 * D * (R1 + R2) - 3 * (R1 - R2) ** 2) / (12 * D)
    V = 4.0 / 3.0 * math.pi * (R1**3 + R2**3) - lens
    e = np.array([0.3, -0.5, 0.8]) / math.sqrt(0.98)  # tilted: the slices are not symmetric
    m = rs.union_mass_properties(np.array([[0, 0, 0], D * e]), np.array([R1, R2]), 1.0)
    assert abs(m["volume"] / V - 1) < 1e-14
    # the axis of symmetry is a principal axis
    w = m["inertia"] @ e
    assert np.linalg.norm(w - (e @ w) * e) < 1e-13 * np.abs(m["inertia"]).max()


def test_reference_is_rotation_invariant_on_a_triple_overlap():
    c, r = random_triple_clump(11, 7)
    m0 = rs.union_mass_properties(c, r, 1.0)
    R = Rotation.from_rotvec([0.4, -1.1, 0.7]).as_matrix()
    m1 = rs.union_mass_properties(c @ R.T, r, 1.0)
    assert abs(m1["volume"] / m0["volume"] - 1) < 1e-13
    I0 = R @ m0["inertia"] @ R.T
    assert np.max(np.abs(m1["inertia"] - I0)) < 1e-13 * np.abs(I0).max()


# ------------------------------------------------------------------ random clumps with triple overlaps
@pytest.mark.parametrize("seed,n", [(1, 5), (2, 7), (3, 8), (4, 10)])
def test_random_triple_overlap_clumps_match_reference(seed, n):
    c, r = random_triple_clump(seed, n)
    with pytest.raises(clumpprops.ClumpGeometryError):  # the clump really has triple overlaps
        mass_properties(c, r, RHO, method="pairwise")
    assert_matches_reference(c, r)


def test_triple_overlap_clump_far_from_origin_matches_reference():
    c, r = random_triple_clump(5, 6)
    assert_matches_reference(c + np.array([1e3, -2e3, 5e2]), r, tol=1e-12)


# ------------------------------------------------------------------ near-degenerate clumps
TET = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float) / math.sqrt(3)
OCT = np.vstack([np.eye(3), -np.eye(3)])
CUBE = np.array(list(itertools.product([0, 1], [0, 1], [0, 1])), float)


def _four_through_a_point(seed):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=3)
    c = p + 0.5 * rng.normal(size=(4, 3))
    return c, np.linalg.norm(c - p, axis=1)  # every surface passes through p


def _symmetric_three_on_a_fourth():
    """Three equal spheres around the z axis; their circles meet at a point on the axis that
    lies on the surface of a fourth sphere centred on the axis."""
    ang = 2 * math.pi * np.arange(3) / 3
    c = np.stack([0.6 * np.cos(ang), 0.6 * np.sin(ang), np.zeros(3)], axis=1)
    r = np.full(3, 0.75)
    zt = math.sqrt(0.75**2 - 0.6**2)  # the triple points (0, 0, +-zt)
    c4 = np.array([[0.1, -0.05, zt + 0.5]])
    r4 = np.linalg.norm(c4[0] - [0, 0, zt])
    return np.vstack([c, c4]), np.append(r, r4)


def _tangent_pair_with_third(scale):
    c = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.6, 0.1]])
    return c, np.array([0.5, 0.5, 0.6]) * scale


def _duplicates(offset):
    rng = np.random.default_rng(5)
    c = rng.uniform(-0.5, 0.5, (5, 3))
    r = rng.uniform(0.4, 0.7, 5)
    c = np.vstack([c, c[1:3] + offset])
    return c, np.concatenate([r, r[1:3]])


DEGENERATE = {
    "tetrahedron": (TET, np.full(4, 0.9)),
    "octahedron": (OCT, np.full(6, 0.9)),
    "octahedron+centre": (np.vstack([OCT, [0, 0, 0]]), np.full(7, 0.9)),
    "cube, all 8 surfaces through the centre": (CUBE, np.full(8, math.sqrt(3) / 2)),
    "cube, overlapping": (CUBE, np.full(8, 0.75)),
    "4 surfaces through one point (a)": _four_through_a_point(0),
    "4 surfaces through one point (b)": _four_through_a_point(1),
    "3 circles meeting on a 4th sphere": _symmetric_three_on_a_fourth(),
    "tangent pair + third": _tangent_pair_with_third(1.0),
    "tangent pair + third, r*(1+1e-15)": _tangent_pair_with_third(1 + 1e-15),
    "tangent pair + third, r*(1-1e-15)": _tangent_pair_with_third(1 - 1e-15),
    "internally tangent + third": (np.array([[0, 0, 0], [0.3, 0, 0], [0.2, 0.9, 0]], float), np.array([1.0, 0.7, 0.5])),
    "internally tangent, third over the tangency": (
        np.array([[0, 0, 0], [0.3, 0, 0], [0.95, 0.2, 0]], float),
        np.array([1.0, 0.7, 0.5]),
    ),
    "duplicates": _duplicates(0.0),
    "near-duplicates 1e-12": _duplicates(1e-12),
    "small overlap 1e-14 in a triple clump": (
        np.array([[0, 0, 0], [1 - 1e-14, 0, 0], [0.5, 0.8, 0], [0.5, 0.3, 0.75]]),
        np.full(4, 0.5),
    ),
    "3x3 grid, tangent neighbours": (np.array(list(itertools.product([0, 1, 2], [0, 1, 2], [0])), float), np.full(9, 0.5)),
}


@pytest.mark.parametrize("name", list(DEGENERATE))
def test_near_degenerate_clumps_match_reference(name):
    c, r = DEGENERATE[name]
    assert_matches_reference(c, r)


# ------------------------------------------------------------------ regression: found by these tests
# Four equal spheres on the corners of a unit square with r = sqrt(1/2): diagonal
# neighbours are exactly tangent, and the tangency point (the square's centre) is also
# the point where all four sphere surfaces meet.  Found while writing these tests (with
# exact.py before commit 9b15457): axis-aligned it matched to 3e-16, but rotated by 1 rad
# about y (which only rounds the centres, a 1e-16 perturbation) it was off by 9e-11 in
# volume and 4e-10 in inertia, and a 3x3 grid of such spheres by 1.5e-9 / 9e-10 (2.3e-11
# even axis-aligned); the reference gives the same volume to 1e-15 for every rotation.
# Fixed in exact.py 9b15457 (near-tangent pairs treated as tangent); now ~5e-16.
SQUARE = np.array(list(itertools.product([0, 1], [0, 1], [0])), float)
GRID = np.array(list(itertools.product([0, 1, 2], [0, 1, 2], [0])), float)


@pytest.mark.parametrize("centres", [SQUARE, GRID], ids=["square", "3x3 grid"])
@pytest.mark.parametrize("rotvec", [(0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.4, 0.4, 0.0)])
def test_tangency_on_a_four_surface_point_matches_reference(centres, rotvec):
    R = Rotation.from_rotvec(rotvec).as_matrix()
    assert_matches_reference(centres @ R.T, np.full(len(centres), math.sqrt(0.5)))
