"""Physics of method="pairwise" (the paper's eqs. 1-7) against independent routes.

References come from ``_clump_reference`` (slice-by-slice integration with
scipy.integrate.quad, closed-form lens volume, inclusion-exclusion), never from
clumpprops itself.  Geometry-only checks (containment, duplicates, tangency,
batches, principal axes) also run for method="exact" once it is importable.
"""
from __future__ import annotations

import math
import re
from fractions import Fraction

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import clumpprops
from clumpprops import ClumpGeometryError, mass_properties

import _clump_reference as ref



EXACT = "exact"
UNION_METHODS = ["pairwise", EXACT]


def rel_err(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def assert_matches_body(mp, body, rho, tol=1e-12, length=1.0):
    V, com, Qc = body
    assert mp.mass == pytest.approx(rho * V, rel=tol, abs=0)
    assert mp.volume == pytest.approx(V, rel=tol, abs=0)
    np.testing.assert_allclose(mp.center_of_mass, com, rtol=0, atol=tol * length)
    assert rel_err(mp.inertia, ref.inertia(Qc, rho)) <= tol


# --------------------------------------------------------------- two spheres
LENS_CASES = [
    # R1, R2, D
    (1.0, 1.0, 1.0),
    (1.0, 0.5, 1.2),
    (0.3, 1.0, 0.75),  # small sphere first; centre of the small one outside the big one
    (1.0, 0.4, 0.7),  # centre of the small sphere inside the big one, not contained
    (2.0, 1.9, 3.899),  # shallow overlap
    (1.0, 1.0, 1e-3),  # nearly coincident
]


@pytest.mark.parametrize("R1,R2,D", LENS_CASES)
@pytest.mark.parametrize("method", UNION_METHODS)
def test_two_sphere_volume_matches_closed_form_lens(R1, R2, D, method):
    lens = ref.lens_volume_closed_form(R1, R2, D)
    expected = 4.0 / 3.0 * math.pi * (R1**3 + R2**3) - lens
    mp = mass_properties([[0.1, -0.2, 0.3], [0.1, -0.2 + D, 0.3]], [R1, R2], density=2.5, method=method)
    assert mp.volume == pytest.approx(expected, rel=1e-13, abs=0)
    assert mp.mass == pytest.approx(2.5 * expected, rel=1e-13, abs=0)


@pytest.mark.parametrize("R1,R2,D", LENS_CASES)
def test_quad_lens_reference_agrees_with_closed_form(R1, R2, D):
    # guards the reference itself: the quad intersection is the closed-form lens
    V = ref.axisym_moments_quad(R1, R2, D, "intersection")[0]
    assert V == pytest.approx(ref.lens_volume_closed_form(R1, R2, D), rel=1e-12)


@pytest.mark.parametrize("R1,R2,D", LENS_CASES)
@pytest.mark.parametrize("method", UNION_METHODS)
def test_tilted_unequal_dimer_matches_disc_integration(R1, R2, D, method):
    rho = 1140.0
    rot = Rotation.from_euler("zyx", [0.4, -1.1, 0.7])
    e = rot.apply([0.0, 0.0, 1.0])
    c1 = np.array([0.25, -1.5, 0.8])
    c2 = c1 + D * e
    mp = mass_properties([c1, c2], [R1, R2], density=rho, method=method)
    body = ref.body_from_axisym(*ref.axisym_moments_quad(R1, R2, D, "union"), c1, e)
    assert_matches_body(mp, body, rho, tol=1e-12, length=max(R1, R2))
    # and the tensor is not accidentally diagonal in the input axes
    assert abs(mp.inertia[0, 1]) > 1e-6 * np.abs(mp.inertia).max()


def test_paper_dimer_sum_overestimates_mass_and_inertia():
    """d = 0.1333 m, D = d/2, rho = 1140 kg/m^3: sum vs pairwise."""
    d, rho = 0.1333, 1140.0
    c, r = [[0, 0, -d / 4], [0, 0, d / 4]], [d / 2, d / 2]
    pw = mass_properties(c, r, density=rho, method="pairwise")
    sm = mass_properties(c, r, density=rho, method="sum")
    # exact ratios with R = d/2 and caps of height R/2 (Fraction arithmetic, in units of pi R^n):
    # mass: sum 8/3, union 8/3 - 2 * (1/3)(3/4 - 1/8) = 9/4  ->  32/27
    # axial: sum 16/15, union 16/15 - 2 * (1/2)(1/6 - 1/16 + 1/160)  ->  512/459
    mass_ratio = Fraction(8, 3) / (Fraction(8, 3) - 2 * Fraction(1, 3) * (Fraction(3, 4) - Fraction(1, 8)))
    cap_axial = Fraction(1, 2) * (Fraction(4, 3) / 8 - Fraction(1, 16) + Fraction(1, 5) / 32)
    axial_ratio = Fraction(16, 15) / (Fraction(16, 15) - 2 * cap_axial)
    assert mass_ratio == Fraction(32, 27) and axial_ratio == Fraction(512, 459)
    # perpendicular moment from the disc integration
    body = ref.body_from_axisym(*ref.axisym_moments_quad(d / 2, d / 2, d / 2, "union"), [0, 0, -d / 4], [0, 0, 1])
    I_ref = ref.inertia(body[2], rho)
    perp_ratio = sm.inertia[0, 0] / I_ref[0, 0]

    assert sm.mass / pw.mass == pytest.approx(float(mass_ratio), rel=1e-13)
    assert sm.inertia[2, 2] / pw.inertia[2, 2] == pytest.approx(float(axial_ratio), rel=1e-13)
    assert sm.inertia[0, 0] / pw.inertia[0, 0] == pytest.approx(perp_ratio, rel=1e-12)
    # the percentages quoted for this dimer (one decimal): +18.5 %, +11.5 % (11.547; not 11.6), +4.5 %
    assert round(100 * (sm.mass / pw.mass - 1), 1) == 18.5
    assert round(100 * (sm.inertia[2, 2] / pw.inertia[2, 2] - 1), 1) == 11.5
    assert round(100 * (sm.inertia[0, 0] / pw.inertia[0, 0] - 1), 1) == 4.5
    assert pw.mass == pytest.approx(2.38582, abs=5e-6)  # 9/4 pi R^3 rho


# --------------------------------------------------------------- degenerate pairs
@pytest.mark.parametrize("method", UNION_METHODS)
@pytest.mark.parametrize(
    "small_center,small_r",
    [([0.3, -0.2, 0.1], 0.5), ([1.4, 0.0, 0.0], 0.6), ([0.0, 0.0, 0.0], 2.0 - 1e-9), ([0, 0, 0], 1e-3)],
    ids=["inside", "internally-tangent", "concentric-almost-equal", "tiny-at-centre"],
)
def test_contained_sphere_changes_nothing(method, small_center, small_r):
    big_c, big_r = [0.0, 0.0, 0.0], 2.0
    for order in ((0, 1), (1, 0)):
        cs = [big_c, small_center]
        rs = [big_r, small_r]
        mp = mass_properties([cs[i] for i in order], [rs[i] for i in order], density=7.0, method=method)
        assert_matches_body(mp, ref.sphere_body(big_c, big_r), 7.0, tol=1e-13, length=big_r)


@pytest.mark.parametrize("method", UNION_METHODS)
def test_two_separate_spheres_inside_a_big_one(method):
    cs = [[0, 0, 0], [0.8, 0, 0], [-0.8, 0, 0]]
    mp = mass_properties(cs, [2.0, 0.5, 0.5], density=1.0, method=method)
    assert_matches_body(mp, ref.sphere_body([0, 0, 0], 2.0), 1.0, tol=1e-13, length=2.0)


def test_overlapping_spheres_inside_a_big_one_are_a_triple_overlap():
    # the two small spheres overlap each other inside the big one: three spheres share a region
    with pytest.raises(ClumpGeometryError):
        mass_properties([[0, 0, 0], [0.3, 0, 0], [-0.3, 0, 0]], [2.0, 0.5, 0.5], method="pairwise")


@pytest.mark.parametrize("method", UNION_METHODS)
def test_duplicate_spheres_count_once(method):
    c = [0.5, -1.0, 2.0]
    mp = mass_properties([c, c], [0.7, 0.7], density=3.0, method=method)
    assert_matches_body(mp, ref.sphere_body(c, 0.7), 3.0, tol=1e-13, length=0.7)


def test_duplicate_of_an_overlapping_sphere_is_a_triple_overlap_for_pairwise():
    c1, c2 = [0.0, 0.0, 0.0], [0.0, 0.9, 0.0]
    with pytest.raises(ClumpGeometryError):
        mass_properties([c1, c2, c2], [0.6, 0.5, 0.5], method="pairwise")


@pytest.mark.parametrize("method", [EXACT])
def test_duplicate_inside_longer_clump_exact(method):
    c1, c2 = [0.0, 0.0, 0.0], [0.0, 0.9, 0.0]
    a = mass_properties([c1, c2, c2], [0.6, 0.5, 0.5], density=3.0, method=method)
    b = ref.pair_body(c1, 0.6, c2, 0.5)
    assert_matches_body(a, b, 3.0, tol=1e-12, length=0.6)


@pytest.mark.parametrize("method", UNION_METHODS)
def test_tangent_spheres_equal_the_sum(method):
    R1, R2 = 0.75, 0.25  # exact binary fractions: D = R1 + R2 exactly
    cs = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]
    a = mass_properties(cs, [R1, R2], density=2.0, method=method)
    s = mass_properties(cs, [R1, R2], density=2.0, method="sum")
    body = ref.combine([ref.sphere_body(cs[0], R1), ref.sphere_body(cs[1], R2)])
    assert_matches_body(a, body, 2.0, tol=1e-14, length=1.0)
    assert a.mass == s.mass


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("method", UNION_METHODS)
def test_non_overlapping_spheres_equal_the_sum(seed, method):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 12))
    cs = np.c_[np.arange(n) * 3.0, rng.normal(size=(n, 2))]  # 3 m apart along x
    rs = rng.uniform(0.1, 1.0, n)
    a = mass_properties(cs, rs, density=1.5, method=method)
    body = ref.combine([ref.sphere_body(c, r) for c, r in zip(cs, rs)])
    assert_matches_body(a, body, 1.5, tol=1e-13, length=3.0 * n)
    s = mass_properties(cs, rs, density=1.5, method="sum")
    assert a.mass == pytest.approx(s.mass, rel=1e-15)
    assert rel_err(a.inertia, s.inertia) <= 1e-14


# --------------------------------------------------------------- three spheres
def _ring(radii, rho_circ, tilt):
    ang = np.array([0.0, 2.1, 4.3])
    cs = np.c_[rho_circ * np.cos(ang), rho_circ * np.sin(ang), np.zeros(3)]
    cs = Rotation.from_rotvec(tilt).apply(cs) + np.array([1.0, -2.0, 0.5])
    return cs, np.asarray(radii, float)


@pytest.mark.parametrize(
    "radii,rho_circ", [((1.0, 1.0, 1.0), 1.1), ((1.0, 0.95, 1.1), 1.08)], ids=["equal", "unequal"]
)
def test_ring_of_three_around_a_hole(radii, rho_circ):
    cs, rs = _ring(radii, rho_circ, [0.3, -0.5, 0.2])
    # premise (independent of the library): every pair overlaps, no point is in all three
    # (the Chebyshev centre of three balls here is near the ring centre, > r from each)
    for i, j in ((0, 1), (0, 2), (1, 2)):
        assert np.linalg.norm(cs[i] - cs[j]) < rs[i] + rs[j]
    grid = _triple_overlap_probe(cs, rs)
    assert not grid, "test premise: the three spheres must not share a point"
    mp = mass_properties(cs, rs, density=2.0, method="pairwise")
    # inclusion-exclusion: union = spheres - pair lenses (lenses by quad)
    bodies = [ref.sphere_body(c, r) for c, r in zip(cs, rs)]
    lenses = [ref.pair_body(cs[i], rs[i], cs[j], rs[j], "intersection") for i, j in ((0, 1), (0, 2), (1, 2))]
    body = ref.combine(bodies + lenses, [1, 1, 1, -1, -1, -1])
    lens_v = sum(ref.lens_volume_closed_form(rs[i], rs[j], np.linalg.norm(cs[i] - cs[j])) for i, j in ((0, 1), (0, 2), (1, 2)))
    assert mp.volume == pytest.approx(4 / 3 * math.pi * np.sum(rs**3) - lens_v, rel=1e-13)
    assert_matches_body(mp, body, 2.0, tol=1e-12, length=3.0)


def _triple_overlap_probe(cs, rs, n=41):
    """Brute-force search for a point inside all three balls (grid + local refinement)."""
    lo = (cs - rs[:, None]).min(axis=0)
    hi = (cs + rs[:, None]).max(axis=0)
    g = np.stack(np.meshgrid(*[np.linspace(lo[k], hi[k], n) for k in range(3)], indexing="ij"), -1).reshape(-1, 3)
    excess = np.max(np.linalg.norm(g[:, None, :] - cs[None], axis=2) - rs[None], axis=1)
    from scipy.optimize import minimize

    x0 = g[np.argmin(excess)]
    f = lambda x: np.max(np.linalg.norm(x[None] - cs, axis=1) - rs)
    res = minimize(f, x0, method="Nelder-Mead", options=dict(xatol=1e-10, fatol=1e-12, maxiter=4000))
    return min(res.fun, excess.min()) < 0


@pytest.mark.parametrize("batch", [False, True])
def test_true_triple_overlap_raises_naming_the_spheres(batch):
    cs, rs = _ring((1.0, 1.0, 1.0), 0.9, [0.1, 0.2, 0.3])  # ring radius < r: common centre region
    assert _triple_overlap_probe(cs, rs)
    far = np.array([[50.0, 0, 0], [60.0, 0, 0]])
    # spheres 2, 3, 4 of a 5-sphere clump share a region; 0 and 1 are far away
    clump_c = np.vstack([far, cs])
    clump_r = np.r_[0.5, 0.5, rs]
    if batch:
        ok_c = clump_c.copy()
        ok_c[2:] += np.array([[0, 0, 0], [0, 0, 10], [0, 0, 20]])  # separated: a valid clump
        with pytest.raises(ClumpGeometryError) as info:
            mass_properties([ok_c, clump_c], [clump_r, clump_r], method="pairwise")
        assert re.search(r"clump\s*#?\s*1\b", str(info.value)), str(info.value)
    else:
        with pytest.raises(ClumpGeometryError) as info:
            mass_properties(clump_c, clump_r, method="pairwise")
    msg = str(info.value)
    assert re.search(r"\b2\D{1,4}3\D{1,4}4\b", msg), msg
    assert isinstance(info.value, ValueError)


@pytest.mark.parametrize("d_circ", [0.9, 1.0 - 1e-9, 1.0 + 1e-9, 1.1547])
def test_triple_overlap_detection_near_the_threshold(d_circ):
    # three unit spheres on a circle of radius c: common point iff c < 1 (the centre);
    # pairwise overlap iff c sqrt(3) < 2
    cs, rs = _ring((1.0, 1.0, 1.0), d_circ, [0, 0, 0])
    # equal angles make the Chebyshev centre exactly the ring centre
    ang = np.array([0.0, 2 * np.pi / 3, 4 * np.pi / 3])
    cs = np.c_[d_circ * np.cos(ang), d_circ * np.sin(ang), np.zeros(3)]
    if d_circ < 1.0:
        with pytest.raises(ClumpGeometryError):
            mass_properties(cs, rs, method="pairwise")
    else:
        mp = mass_properties(cs, rs, method="pairwise")
        lens = sum(ref.lens_volume_closed_form(1, 1, np.linalg.norm(cs[i] - cs[j])) for i, j in ((0, 1), (0, 2), (1, 2)))
        assert mp.volume == pytest.approx(4 * math.pi - lens, rel=1e-13)


# --------------------------------------------------------------- principal axes, batches
def _random_valid_chains(rng, m):
    """m straight-ish chains of 2..5 spheres where only neighbours overlap (no triple overlap)."""
    out_c, out_r = [], []
    for _ in range(m):
        n = int(rng.integers(2, 6))
        r = rng.uniform(0.5, 1.0, n)
        pos = [np.zeros(3)]
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        for k in range(1, n):
            step = 0.8 * (r[k - 1] + r[k]) + 0.1
            pos.append(pos[-1] + step * d)
        out_c.append(np.array(pos) + rng.normal(size=3) * 5)
        out_r.append(r)
    return out_c, out_r


@pytest.mark.parametrize("method", ["pairwise", "sum", EXACT])
def test_principal_axes_are_orthonormal_right_handed_and_diagonalise(method):
    rng = np.random.default_rng(42)
    cs, rs = _random_valid_chains(rng, 20)
    for c, r in zip(cs, rs):
        c = Rotation.random(random_state=rng).apply(c)
        mp = mass_properties(c, r, density=900.0, method=method)
        A, w, I = mp.principal_axes, mp.principal_moments, mp.inertia
        np.testing.assert_allclose(A.T @ A, np.eye(3), atol=1e-13)
        assert np.linalg.det(A) == pytest.approx(1.0, abs=1e-13)
        assert np.all(np.diff(w) >= 0)
        assert rel_err(A @ np.diag(w) @ A.T, I) <= 1e-13
        np.testing.assert_allclose(I, I.T, rtol=0, atol=1e-15 * np.abs(I).max())
        # triangle inequality of principal moments of any rigid body
        assert w[0] + w[1] >= w[2] * (1 - 1e-12)
        assert np.all(w > 0)


@pytest.mark.parametrize("method", ["pairwise", "sum", EXACT])
def test_batch_equals_per_clump_calls(method):
    rng = np.random.default_rng(7)
    M, N = 6, 3
    cs = np.empty((M, N, 3))
    rs = np.empty((M, N))
    for m in range(M):
        r = rng.uniform(0.5, 1.0, N)
        d = Rotation.random(random_state=rng).apply([1.0, 0, 0])
        x = np.cumsum(np.r_[0.0, 0.8 * (r[:-1] + r[1:])])
        cs[m] = x[:, None] * d + rng.normal(size=3)
        rs[m] = r
    batch = mass_properties(cs, rs, density=2.0, method=method)
    assert batch.batched and len(batch) == M
    assert batch.mass.shape == (M,) and batch.center_of_mass.shape == (M, 3)
    assert batch.inertia.shape == (M, 3, 3) and batch.principal_axes.shape == (M, 3, 3)
    for m in range(M):
        one = mass_properties(cs[m], rs[m], density=2.0, method=method)
        assert not one.batched
        assert batch.mass[m] == pytest.approx(one.mass, rel=1e-14)
        np.testing.assert_allclose(batch.center_of_mass[m], one.center_of_mass, rtol=1e-14, atol=1e-14)
        assert rel_err(batch.inertia[m], one.inertia) <= 1e-14
        assert rel_err(batch[m].principal_moments, one.principal_moments) <= 1e-14


@pytest.mark.parametrize("method", ["pairwise", "sum", EXACT])
def test_ragged_list_of_clumps(method):
    rng = np.random.default_rng(3)
    cs, rs = _random_valid_chains(rng, 7)
    cs.append(np.array([[1.0, 2.0, 3.0]]))  # a single-sphere clump
    rs.append(np.array([0.4]))
    batch = mass_properties(cs, rs, density=5.0, method=method)
    assert len(batch) == len(cs)
    for m, (c, r) in enumerate(zip(cs, rs)):
        one = mass_properties(c, r, density=5.0, method=method)
        assert batch.mass[m] == pytest.approx(one.mass, rel=1e-14)
        np.testing.assert_allclose(batch[m].center_of_mass, one.center_of_mass, rtol=1e-14, atol=1e-13)
        assert rel_err(batch[m].inertia, one.inertia) <= 1e-13
    body = ref.sphere_body([1.0, 2.0, 3.0], 0.4)
    assert_matches_body(batch[len(cs) - 1], body, 5.0, tol=1e-14, length=1.0)


def test_pairwise_default_method_is_documented_exact():
    assert clumpprops.DEFAULT_METHOD == "exact"
    assert {"exact", "pairwise", "sum", "montecarlo", "voxel"} <= set(clumpprops.METHODS)
