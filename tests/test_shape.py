"""Exact shape descriptors (clumpprops.shape): each value against an independent route."""
import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq, minimize
from scipy.spatial.transform import Rotation

import clumpprops
from clumpprops import bounding_ball, shape_descriptors


def _area(centers, radii):
    return shape_descriptors(centers, radii).surface_area


# ------------------------------------------------------------------ dimers: 1-D quadrature and closed form
def _dimer_area_quadrature(r1, r2, D):
    """Exposed area of two spheres on the z axis: 2 pi r^2 sin(theta) integrated over each exposed polar range."""
    total = 0.0
    for (r, zc), (ro, zo) in (((r1, 0.0), (r2, D)), ((r2, D), (r1, 0.0))):
        toward = 1.0 if zo > zc else -1.0

        def outside(theta):  # distance from the point at polar angle theta (from the other centre's side) minus ro
            p = np.array([r * np.sin(theta), 0.0, zc + toward * r * np.cos(theta)])
            return np.hypot(p[0], p[2] - zo) - ro

        edge = brentq(outside, 0.0, np.pi, xtol=1e-15, rtol=4 * np.finfo(float).eps)
        total += quad(lambda t: 2 * np.pi * r * r * np.sin(t), edge, np.pi, epsabs=0, epsrel=1e-13)[0]
    return total


def _dimer_area_closed(r1, r2, D):
    """Archimedes' zones: the exposed zone of sphere 1 reaches a = (D^2 + r1^2 - r2^2) / (2 D) along the axis."""
    a = (D * D + r1 * r1 - r2 * r2) / (2 * D)
    return 2 * np.pi * r1 * (r1 + a) + 2 * np.pi * r2 * (r2 + D - a)


@pytest.mark.parametrize("r1, r2, D", [(1.0, 1.0, 1.0), (0.0665, 0.0665, 0.0665), (1.0, 0.3, 1.1),
                                       (2.0, 1.5, 0.9), (1.0, 1.0, 1.999), (1.0, 0.01, 1.0), (3.0, 2.5, 1.0)])
def test_dimer_area_matches_quadrature_and_closed_form(r1, r2, D):
    got = _area([[0, 0, 0], [0, 0, D]], [r1, r2])
    assert got == pytest.approx(_dimer_area_quadrature(r1, r2, D), rel=1e-10, abs=0)
    assert got == pytest.approx(_dimer_area_closed(r1, r2, D), rel=1e-10, abs=0)


def test_dimer_area_any_direction():
    e = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    got = _area([[1.0, 2.0, 3.0], np.add([1.0, 2.0, 3.0], 1.2 * e)], [1.0, 0.7])
    assert got == pytest.approx(_dimer_area_closed(1.0, 0.7, 1.2), rel=1e-12)


# ------------------------------------------------------------------ degenerate cases
def test_single_sphere():
    s = shape_descriptors([[0.1, -0.2, 0.3]], [0.25])
    assert s.surface_area == pytest.approx(4 * np.pi * 0.25**2, rel=1e-15)
    assert s.volume == pytest.approx(4 / 3 * np.pi * 0.25**3, rel=1e-15)
    assert s.diameter == pytest.approx(0.5, rel=1e-15)
    assert s.sphericity == pytest.approx(1.0, rel=1e-14)
    np.testing.assert_allclose(s.kappa, 0.4, rtol=1e-14)
    np.testing.assert_allclose(s.kappa_bounding, 0.4, rtol=1e-14)
    np.testing.assert_allclose(s.moment_ratios, 1.0, rtol=1e-14)
    np.testing.assert_allclose(s.extents, 0.5, rtol=1e-15)
    assert s.elongation == pytest.approx(1.0) and s.flatness == pytest.approx(1.0)
    np.testing.assert_allclose(s.bounding_center, [0.1, -0.2, 0.3], rtol=0, atol=1e-15)
    assert s.bounding_radius == pytest.approx(0.25, rel=1e-15)


def test_contained_and_coincident_spheres_add_no_area():
    big = 4 * np.pi * 1.0**2
    assert _area([[0, 0, 0], [0.2, 0.1, 0], [0.0, 0.0, 0.5]], [1.0, 0.5, 0.5]) == pytest.approx(big, rel=1e-14)
    assert _area([[0, 0, 0], [0, 0, 0]], [1.0, 1.0]) == pytest.approx(big, rel=1e-14)
    assert _area([[0, 0, 0], [0, 0, 0.5]], [1.0, 0.5]) == pytest.approx(big, rel=1e-14)  # internally tangent


def test_tangent_and_separate_spheres_add_their_areas():
    whole = 4 * np.pi * (1.0 + 0.5**2)
    assert _area([[0, 0, 0], [1.5, 0, 0]], [1.0, 0.5]) == pytest.approx(whole, rel=1e-14)
    assert _area([[0, 0, 0], [5.0, 0, 0]], [1.0, 0.5]) == pytest.approx(whole, rel=1e-14)


def test_many_separate_caps_on_one_sphere():
    """26 small spheres on a unit sphere, their caps apart: every cap is a dimer's (closed form each)."""
    dirs = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1) if (i, j, k) != (0, 0, 0)], float)
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    s, D = 0.15, 1.0
    centers = np.vstack([[0, 0, 0], D * dirs])
    radii = np.r_[1.0, np.full(len(dirs), s)]
    a = (D * D + 1.0 - s * s) / (2 * D)  # where each small sphere's plane cuts the axis
    expected = 4 * np.pi - len(dirs) * 2 * np.pi * (1 - a) + len(dirs) * 2 * np.pi * s * (s + D - a)
    assert _area(centers, radii) == pytest.approx(expected, rel=1e-12)


# ------------------------------------------------------------------ general clumps: Monte Carlo on the surfaces
def _random_clump(rng, n):
    centers, radii = [rng.normal(size=3) * 0.3], [rng.uniform(0.3, 0.6)]
    while len(radii) < n:  # each new sphere overlaps an earlier one: a connected clump with multiple overlaps
        k = rng.integers(len(radii))
        r = rng.uniform(0.2, 0.6)
        u = rng.normal(size=3)
        centers.append(centers[k] + u / np.linalg.norm(u) * rng.uniform(0.2, 0.95) * (radii[k] + r))
        radii.append(r)
    return np.array(centers), np.array(radii)


def _surface_monte_carlo(c, r, rng, n=40000):
    """Area = sum 4 pi r_i^2 * (fraction of uniform points on sphere i outside all others), with its standard error."""
    area, var = 0.0, 0.0
    for i in range(len(r)):
        u = rng.normal(size=(n, 3))
        p = c[i] + r[i] * u / np.linalg.norm(u, axis=1)[:, None]
        others = (np.arange(len(r)) != i) & (np.linalg.norm(c - c[i], axis=1) < r + r[i])  # the overlapping ones
        dist = np.linalg.norm(p[:, None, :] - c[others][None], axis=2)
        f = np.mean(np.all(dist > r[others], axis=1))
        area += 4 * np.pi * r[i] ** 2 * f
        var += (4 * np.pi * r[i] ** 2) ** 2 * f * (1 - f) / n
    return area, np.sqrt(var)


@pytest.mark.parametrize("seed, n", [(1, 3), (2, 5), (3, 8), (4, 12), (5, 20)])
def test_general_clump_area_within_four_standard_errors(seed, n):
    rng = np.random.default_rng(seed)
    c, r = _random_clump(rng, n)
    estimate, se = _surface_monte_carlo(c, r, rng)
    assert se > 0
    assert abs(_area(c, r) - estimate) <= 4 * se


def test_dense_clump_with_redundant_spheres():
    """Spheres with more than 48 caps (the core's subset path); duplicates and buried spheres add nothing."""
    rng = np.random.default_rng(3)
    c, r = grain_clumps(150, rng, 100.0)
    caps = (np.linalg.norm(c[:, None] - c[None], axis=2) < r[:, None] + r[None]).sum(axis=1) - 1
    assert caps.max() > 48
    area = _area(c, r)
    padded = _area(np.vstack([c, c[:40], c[:5] + 0.01]), np.r_[r, r[:40], r[:5] * 0.5])
    assert padded == pytest.approx(area, rel=1e-12)
    estimate, se = _surface_monte_carlo(c, r, rng, n=8000)
    assert abs(area - estimate) <= 4 * se


def grain_clumps(N, rng, neighbours):
    """N spheres (radii 0.8-1.2) in an elongated ellipsoid, each overlapping about `neighbours` others."""
    n = neighbours / (4.0 / 3.0 * np.pi * 8.0)
    a = (N / n / (4.0 / 3.0 * np.pi * 4.5)) ** (1.0 / 3.0)
    u = rng.normal(size=(N, 3))
    u *= rng.random((N, 1)) ** (1.0 / 3.0) / np.linalg.norm(u, axis=1)[:, None]
    return u * np.array([3.0, 1.5, 1.0]) * a, rng.uniform(0.8, 1.2, N)


def test_area_against_converging_mesh():
    trimesh = pytest.importorskip("trimesh")
    pytest.importorskip("manifold3d")  # trimesh's boolean engine
    rng = np.random.default_rng(7)
    c, r = _random_clump(rng, 6)
    exact = _area(c, r)
    errors = []
    for sub in (3, 4, 5):
        mesh = trimesh.creation.icosphere(subdivisions=sub, radius=r[0]).apply_translation(c[0])
        for ci, ri in zip(c[1:], r[1:]):
            mesh = mesh.union(trimesh.creation.icosphere(subdivisions=sub, radius=ri).apply_translation(ci))
        errors.append(abs(mesh.area - exact) / exact)
    assert errors[-1] < errors[0] and errors[-1] < 5e-3


# ------------------------------------------------------------------ invariance, batches
def test_rotation_and_translation_invariance():
    rng = np.random.default_rng(11)
    c, r = _random_clump(rng, 10)
    R = Rotation.from_rotvec([0.4, -1.1, 2.0]).as_matrix()
    shift = np.array([12.5, -3.0, 7.25])
    a, b = shape_descriptors(c, r), shape_descriptors(c @ R.T + shift, r)
    for name in ("volume", "surface_area", "diameter", "sphericity", "elongation", "flatness", "bounding_radius"):
        assert getattr(b, name) == pytest.approx(getattr(a, name), rel=1e-11), name
    for name in ("kappa", "kappa_bounding", "moment_ratios", "extents"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=1e-9, err_msg=name)
    np.testing.assert_allclose(b.bounding_center, R @ a.bounding_center + shift, rtol=0, atol=1e-9)


def test_scale_laws():
    rng = np.random.default_rng(12)
    c, r = _random_clump(rng, 7)
    a, b = shape_descriptors(c, r), shape_descriptors(c * 1e-4, r * 1e-4)
    assert b.surface_area == pytest.approx(a.surface_area * 1e-8, rel=1e-13)
    assert b.sphericity == pytest.approx(a.sphericity, rel=1e-13)
    np.testing.assert_allclose(b.kappa, a.kappa, rtol=1e-12)


def test_batch_and_ragged_match_single_clumps():
    rng = np.random.default_rng(13)
    clumps = [_random_clump(rng, 5) for _ in range(3)]
    batch = shape_descriptors(np.array([c for c, _ in clumps]), np.array([r for _, r in clumps]))
    ragged = shape_descriptors([clumps[0][0], clumps[1][0][:3]], [clumps[0][1], clumps[1][1][:3]])
    assert batch.batched and len(batch) == 3 and batch.kappa.shape == (3, 3)
    for m, (c, r) in enumerate(clumps):
        one = shape_descriptors(c, r)
        assert batch[m].surface_area == pytest.approx(one.surface_area, rel=1e-14)
        np.testing.assert_allclose(batch[m].extents, one.extents, rtol=1e-14)
    assert ragged[1].surface_area == pytest.approx(_area(clumps[1][0][:3], clumps[1][1][:3]), rel=1e-14)
    assert not batch.kappa.flags.writeable


def test_descriptor_definitions_for_a_dimer():
    """Equal-sphere dimer on z: extents 2r + D by 2r by 2r; Zingg I/L = 2r/(2r+D), S/I = 1; bounding R = r + D/2."""
    r, D = 0.5, 0.4
    s = shape_descriptors([[0, 0, 0], [0, 0, D]], [r, r])
    np.testing.assert_allclose(np.sort(s.extents), [2 * r, 2 * r, 2 * r + D], rtol=1e-14)
    assert s.elongation == pytest.approx(2 * r / (2 * r + D), rel=1e-14)
    assert s.flatness == pytest.approx(1.0, rel=1e-14)
    assert s.bounding_radius == pytest.approx(r + D / 2, rel=1e-13)
    lens = np.pi * (4 * r + D) * (2 * r - D) ** 2 / 12  # volume of the overlap of two equal balls
    V = 2 * 4 / 3 * np.pi * r**3 - lens
    assert s.diameter == pytest.approx((6 * V / np.pi) ** (1 / 3), rel=1e-14)
    assert s.sphericity < 1.0


def test_tangent_dimer_closed_forms():
    """Two touching balls (m_s, r each): I_axial = 2 (2/5) m_s r^2, I_perp = 2 (2/5 + 1) m_s r^2, d_v = 2^(4/3) r."""
    r = 0.3
    s = shape_descriptors([[0, 0, 0], [2 * r, 0, 0]], [r, r])
    np.testing.assert_allclose(s.kappa, np.array([0.4, 1.4, 1.4]) / 2 ** (2 / 3), rtol=1e-13)
    np.testing.assert_allclose(s.kappa_bounding, [0.1, 0.35, 0.35], rtol=1e-13)  # sigma = 4 r
    np.testing.assert_allclose(s.moment_ratios, [0.4 / 1.4, 1.0], rtol=1e-13)
    assert s.sphericity == pytest.approx(2 ** (-1 / 3), rel=1e-14)
    assert s.elongation == pytest.approx(0.5, rel=1e-14)


def test_invalid_input_raises_value_error():
    with pytest.raises(ValueError, match="radi"):
        shape_descriptors([[0, 0, 0]], [-1.0])
    with pytest.raises(ValueError, match="radii >= 0"):
        bounding_ball([[0, 0, 0]], [-1.0])
    with pytest.raises(ValueError, match="N, 3"):
        bounding_ball([0, 0, 0], [1.0])


# ------------------------------------------------------------------ extents and bounding sphere by brute force
def _union_surface_points(c, r, rng, n=20000):
    pts = []
    for i in range(len(r)):
        u = rng.normal(size=(n, 3))
        p = c[i] + r[i] * u / np.linalg.norm(u, axis=1)[:, None]
        pts.append(p[np.all(np.linalg.norm(p[:, None] - c[None], axis=2) >= r[None] * (1 - 1e-12), axis=1)])
    return np.vstack(pts)


def test_extents_against_sampled_surface():
    rng = np.random.default_rng(21)
    c, r = _random_clump(rng, 9)
    s = shape_descriptors(c, r)
    mp = clumpprops.mass_properties(c, r)
    proj = (_union_surface_points(c, r, rng) - mp.center_of_mass) @ s.principal_axes
    size = 2 * s.bounding_radius
    assert np.all(proj.max(axis=0) <= s.extent_max + 1e-12 * size)
    assert np.all(proj.min(axis=0) >= s.extent_min - 1e-12 * size)
    np.testing.assert_allclose(proj.max(axis=0), s.extent_max, atol=2e-3 * size)
    np.testing.assert_allclose(proj.min(axis=0), s.extent_min, atol=2e-3 * size)


def _brute_force_bounding_radius(c, r, rng):
    f = lambda x: np.max(np.linalg.norm(c - x, axis=1) + r)
    best = np.inf
    for x0 in [c.mean(axis=0)] + list(c[rng.integers(len(r), size=4)] + rng.normal(size=(4, 3)) * 0.1):
        res = minimize(f, x0, method="Nelder-Mead", options={"xatol": 1e-13, "fatol": 1e-15, "maxiter": 40000})
        best = min(best, res.fun)
    return best


@pytest.mark.parametrize("seed, n", [(31, 2), (32, 3), (33, 4), (34, 7), (35, 15), (36, 20)])
def test_bounding_ball_against_brute_force(seed, n):
    rng = np.random.default_rng(seed)
    c, r = _random_clump(rng, n)
    centre, R = bounding_ball(c, r)
    assert np.all(np.linalg.norm(c - centre, axis=1) + r <= R * (1 + 1e-14))
    brute = _brute_force_bounding_radius(c, r, rng)
    assert R <= brute * (1 + 1e-12)
    assert R == pytest.approx(brute, rel=1e-7)


def test_bounding_ball_known_cases():
    # regular tetrahedron of equal balls: circumradius + r
    t = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    centre, R = bounding_ball(t, np.full(4, 0.5))
    assert R == pytest.approx(np.sqrt(3) + 0.5, rel=1e-14)
    np.testing.assert_allclose(centre, 0.0, atol=1e-14)
    # a ball containing the others is its own bounding ball
    centre, R = bounding_ball([[0, 0, 0], [0.3, 0, 0], [0, -0.2, 0.1]], [1.0, 0.4, 0.5])
    assert R == pytest.approx(1.0, rel=1e-15)
    # two unequal balls: the segment through both, R = (D + r1 + r2) / 2
    centre, R = bounding_ball([[0, 0, 0], [3.0, 4.0, 0]], [1.0, 2.0])
    assert R == pytest.approx(4.0, rel=1e-14)
    np.testing.assert_allclose(centre, [1.8, 2.4, 0], atol=1e-13)  # 3 along the unit (0.6, 0.8, 0)
