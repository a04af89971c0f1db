"""Invariance properties (hypothesis) and degenerate-but-valid geometry.

Properties, for methods "pairwise" (on clumps without triple overlaps: dimers and
chains where only neighbours overlap), "sum" and "exact" (any clump):

* translation by t (up to 1e6 m): mass and inertia unchanged, COM moves by t;
* rotation R: I -> R I R^T, COM -> R COM, principal moments unchanged;
* permutation of the spheres: nothing changes;
* scaling lengths by s: mass ~ s^3, COM ~ s, inertia ~ s^5.

Degenerate geometry (tiny overlaps, nearly coincident spheres, radius ratios up to
1e6, clumps 1e6 m from the origin) is compared with an exact high-precision
(mpmath, 60 digits) piecewise-polynomial integration of the union of two spheres
(``_clump_reference.dimer_reference_mp``), so it never compares the code with itself.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from clumpprops import mass_properties

import _clump_reference as ref
from _profiles import examples

EPS = np.finfo(float).eps



EXACT = "exact"
ALL_METHODS = ["pairwise", "sum", EXACT]
UNION_METHODS = ["pairwise", EXACT]

# derandomize, deadline, database: the hypothesis profile (tests/_profiles.py, "ci" by default)
SETTINGS = settings(max_examples=examples(60))

# ------------------------------------------------------------------ strategies
unit_vectors = (
    st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 3)
    .map(np.array)
    .filter(lambda v: np.linalg.norm(v) > 0.1)
    .map(lambda v: v / np.linalg.norm(v))
)
offsets = st.tuples(*[st.floats(-5, 5, allow_nan=False)] * 3).map(np.array)


@st.composite
def dimers(draw):
    """Two spheres with any relation: separate, tangent-ish, overlapping, contained, coincident."""
    r1 = draw(st.floats(0.1, 2.0))
    r2 = r1 * draw(st.floats(0.05, 20.0))
    D = draw(st.floats(0.0, 1.3)) * (r1 + r2)
    e = draw(unit_vectors)
    c1 = draw(offsets)
    return np.array([c1, c1 + D * e]), np.array([r1, r2])


@st.composite
def chains(draw):
    """2..6 spheres, each overlapping only its neighbours (so never three sharing a point)."""
    n = draw(st.integers(2, 6))
    r = np.array(draw(st.lists(st.floats(0.3, 1.0), min_size=n, max_size=n)))
    d = draw(unit_vectors)
    pos = [draw(offsets)]
    for k in range(1, n):
        bend = draw(unit_vectors)
        dk = d + 0.4 * bend
        dk /= np.linalg.norm(dk)
        step = draw(st.floats(0.55, 0.98)) * (r[k - 1] + r[k])
        pos.append(pos[-1] + step * dk)
    c = np.array(pos)
    for i in range(n):
        for j in range(i + 2, n):
            assume(np.linalg.norm(c[i] - c[j]) > (r[i] + r[j]) * (1 + 1e-9))
    return c, r


@st.composite
def general_clumps(draw):
    """1..8 spheres anywhere in a 3 m box: triple overlaps allowed."""
    n = draw(st.integers(1, 8))
    c = np.array(draw(st.lists(st.tuples(*[st.floats(-1.5, 1.5)] * 3), min_size=n, max_size=n)), dtype=float)
    r = np.array(draw(st.lists(st.floats(0.2, 1.2), min_size=n, max_size=n)))
    return c, r


def clumps_for(method):
    if method == "pairwise":
        return st.one_of(dimers(), chains())
    return st.one_of(dimers(), chains(), general_clumps())


def rel_err(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def size(c, r):
    return float(np.ptp(c, axis=0).max() + 2 * r.max())


# ------------------------------------------------------------------ properties
@pytest.mark.parametrize("method", ALL_METHODS)
def test_translation(method):
    @SETTINGS
    @given(
        clumps_for(method),
        st.tuples(*[st.floats(-1.0, 1.0)] * 3).map(np.array),
        st.sampled_from([1.0, 1e3, 1e6]),
    )
    def check(clump, direction, magnitude):
        c, r = clump
        t = direction * magnitude
        a = mass_properties(c, r, density=1200.0, method=method)
        b = mass_properties(c + t, r, density=1200.0, method=method)
        L = size(c, r)
        # c + t is rounded to ~eps |t|: the geometry itself moves by that much
        tol = 1e-12 + 64 * EPS * np.abs(t).max() / r.min()
        assert b.mass == pytest.approx(a.mass, rel=tol)
        assert rel_err(b.inertia, a.inertia) <= tol
        assert rel_err(b.principal_moments, a.principal_moments) <= tol
        np.testing.assert_allclose(b.center_of_mass - t, a.center_of_mass, rtol=0, atol=1e-12 * L + 8 * EPS * np.abs(t).max())

    check()


@pytest.mark.parametrize("method", ALL_METHODS)
def test_rotation(method):
    @SETTINGS
    @given(clumps_for(method), st.integers(0, 2**32 - 1))
    def check(clump, seed):
        c, r = clump
        R = Rotation.random(random_state=seed).as_matrix()
        a = mass_properties(c, r, density=2.0, method=method)
        b = mass_properties(c @ R.T, r, density=2.0, method=method)
        L = size(c, r) + np.abs(c).max()
        assert b.mass == pytest.approx(a.mass, rel=1e-12)
        np.testing.assert_allclose(b.center_of_mass, R @ a.center_of_mass, rtol=0, atol=1e-12 * L)
        assert rel_err(b.inertia, R @ a.inertia @ R.T) <= 1e-11
        assert rel_err(b.principal_moments, a.principal_moments) <= 1e-11

    if method != "pairwise":
        # found by hypothesis: two nearly coincident spheres (D/r ~ 5e-6), others buried or cutting both
        near = (
            np.array([[0.0, 0, 0]] * 5 + [[0.0, 0.0, 7.62939453e-06]]),
            np.array([1.0, 1.0, 1.0, 1.0, 1.2, 1.2]),
        )
        cut = (np.array([[0.0, 0, 0], [3.81469727e-06, 0, 3.81469727e-06], [0.0, 0.0, 1.0]]), np.array([1.2, 1.2, 1.0]))
        check = example(near, 0)(example(cut, 0)(check))
    check()


@pytest.mark.parametrize("method", ALL_METHODS)
def test_permutation(method):
    @SETTINGS
    @given(clumps_for(method), st.randoms(use_true_random=False))
    def check(clump, rnd):
        c, r = clump
        perm = list(range(len(r)))
        rnd.shuffle(perm)
        a = mass_properties(c, r, density=3.0, method=method)
        b = mass_properties(c[perm], r[perm], density=3.0, method=method)
        assert b.mass == pytest.approx(a.mass, rel=1e-13)
        np.testing.assert_allclose(b.center_of_mass, a.center_of_mass, rtol=0, atol=1e-13 * (size(c, r) + np.abs(c).max()))
        assert rel_err(b.inertia, a.inertia) <= 1e-12

    check()


@pytest.mark.parametrize("method", ALL_METHODS)
def test_scaling(method):
    @SETTINGS
    @given(clumps_for(method), st.floats(-3.0, 3.0))
    def check(clump, log_s):
        c, r = clump
        s = 10.0**log_s
        a = mass_properties(c, r, density=7.5, method=method)
        b = mass_properties(c * s, r * s, density=7.5, method=method)
        assert b.mass == pytest.approx(a.mass * s**3, rel=1e-12)
        assert b.volume == pytest.approx(a.volume * s**3, rel=1e-12)
        np.testing.assert_allclose(b.center_of_mass, a.center_of_mass * s, rtol=0, atol=1e-12 * s * (size(c, r) + np.abs(c).max()))
        assert rel_err(b.inertia, a.inertia * s**5) <= 1e-11

    check()


@pytest.mark.parametrize("method", ALL_METHODS)
def test_density_is_a_factor(method):
    @SETTINGS
    @given(clumps_for(method), st.floats(1e-3, 1e5))
    def check(clump, rho):
        c, r = clump
        a = mass_properties(c, r, density=1.0, method=method)
        b = mass_properties(c, r, density=rho, method=method)
        assert b.mass == pytest.approx(rho * a.mass, rel=1e-14)
        assert b.volume == a.volume
        assert rel_err(b.inertia, rho * a.inertia) <= 1e-14
        np.testing.assert_array_equal(b.center_of_mass, a.center_of_mass)

    check()


@pytest.mark.parametrize("method", UNION_METHODS)
def test_union_never_exceeds_sum_and_covers_largest_sphere(method):
    @SETTINGS
    @given(clumps_for(method))
    def check(clump):
        c, r = clump
        a = mass_properties(c, r, method=method)
        s = mass_properties(c, r, method="sum")
        assert a.volume <= s.volume * (1 + 1e-14)
        assert a.volume >= 4 / 3 * math.pi * r.max() ** 3 * (1 - 1e-14)
        assert np.all(np.isfinite(a.inertia))

    check()


# ------------------------------------------------------------------ degenerate geometry vs mpmath
def _check_against_mp(method, c1, R1, c2, R2, rho=1000.0, tol=1e-14, com_tol=None):
    mp = mass_properties([c1, c2], [R1, R2], density=rho, method=method)
    m_ref, com_ref, I_ref = ref.dimer_reference_mp(c1, R1, c2, R2, rho)
    assert mp.mass == pytest.approx(m_ref, rel=tol, abs=0)
    assert rel_err(mp.inertia, I_ref) <= tol
    L = max(R1, R2)
    atol = tol * L if com_tol is None else com_tol
    np.testing.assert_allclose(mp.center_of_mass, com_ref, rtol=0, atol=atol)
    return mp


TINY = [1e-8, 1e-9, 1e-10, 1e-11, 1e-12]


@pytest.mark.parametrize("method", UNION_METHODS)
@pytest.mark.parametrize("ratio", [1.0, 3.7, 1e3, 1e6])
@pytest.mark.parametrize("delta", TINY)
def test_tiny_overlap_matches_mpmath(method, ratio, delta):
    """Overlap depth delta * R_small between spheres R and R / ratio, tilted axis."""
    R1, R2 = 1.3, 1.3 / ratio
    e = np.array([2.0, -1.0, 2.0]) / 3.0
    D = (R1 + R2) - delta * R2
    c1 = np.array([0.1, 0.2, -0.3])
    _check_against_mp(method, c1, R1, c1 + D * e, R2)


NEAR = [1e-8, 3e-9, 1e-9, 3e-10, 1e-10, 1e-11, 3e-12, 1e-12]


@pytest.mark.parametrize("method", UNION_METHODS)
@pytest.mark.parametrize("gap", NEAR)
def test_nearly_coincident_spheres_match_mpmath(method, gap):
    """D / R = gap: the union exceeds one sphere by ~ pi R^2 D, a relative 1e-8..1e-12.

    The comparison at 1e-14 checks that excess to ~1e-6..1e-2 relative: no cancellation
    in the lens (which is nearly the whole sphere)."""
    R = 0.8
    e = np.array([0.0, 0.6, 0.8])
    c1 = np.zeros(3)
    mp = _check_against_mp(method, c1, R, c1 + gap * R * e, R)
    one = 4 / 3 * math.pi * R**3 * 1000.0
    assert mp.mass >= one * (1 - 1e-15), "the union is smaller than one of its spheres"
    excess = math.pi * R**2 * gap * R * 1000.0  # leading order of the union's extra volume
    assert mp.mass - one == pytest.approx(excess, rel=max(2e-3, 10 * 1e-16 / gap))


@pytest.mark.parametrize("method", UNION_METHODS)
@pytest.mark.parametrize("gap", NEAR)
def test_nearly_concentric_unequal_spheres_match_mpmath(method, gap):
    """Radii R and R (1 + 3e-9), centres gap * R apart: a thin shell-like union."""
    R1, R2 = 0.8, 0.8 * (1 + 3e-9)
    e = np.array([0.0, 0.6, 0.8])
    c1 = np.zeros(3)
    mp = _check_against_mp(method, c1, R1, c1 + gap * R1 * e, R2)
    assert mp.volume >= 4 / 3 * math.pi * R2**3 * (1 - 1e-15)


@pytest.mark.parametrize("method", UNION_METHODS)
@pytest.mark.parametrize("gap", TINY)
def test_nearly_internally_tangent_matches_mpmath(method, gap):
    """Small sphere poking out of a big one by gap * r: D + r = R + gap r."""
    R, r = 1.0, 0.25
    D = R - r + gap * r
    c1 = np.array([0.5, 0.5, 0.5])
    _check_against_mp(method, c1, R, c1 + D * np.array([1.0, 0.0, 0.0]), r)


@pytest.mark.parametrize("method", UNION_METHODS)
@pytest.mark.parametrize("where", [-0.999, -0.5, 0.0, 0.5, 0.999])
@pytest.mark.parametrize("ratio", [1e3, 1e6])
@pytest.mark.parametrize("order", ["big-first", "small-first"])
def test_radius_ratio_up_to_1e6_matches_mpmath(method, where, ratio, order):
    """A sphere of radius R / ratio centred at distance R + where * r from a big sphere's centre."""
    R = 2.0
    r = R / ratio
    e = np.array([1.0, 1.0, 1.0]) / math.sqrt(3.0)
    cb = np.array([-1.0, 3.0, 0.5])
    cs = cb + (R + where * r) * e
    if order == "big-first":
        _check_against_mp(method, cb, R, cs, r)
    else:
        _check_against_mp(method, cs, r, cb, R)


@pytest.mark.parametrize("method", UNION_METHODS)
@pytest.mark.parametrize("offset", [1e3, 1e6, -1e6])
def test_far_from_origin_matches_mpmath(method, offset):
    R1, R2 = 0.06665, 0.05
    c1 = np.array([offset, -0.5 * offset, 0.25 * offset])
    e = np.array([0.36, 0.48, 0.8])
    c2 = c1 + 0.09 * e
    # the inputs are exact floats; the result's COM is rounded once near |offset|
    _check_against_mp(method, c1, R1, c2, R2, rho=1140.0, tol=1e-13, com_tol=4 * EPS * abs(offset))


@pytest.mark.parametrize("method", ALL_METHODS)
def test_batch_of_clumps_far_apart_and_at_all_scales(method):
    """A batch mixing clumps near and far from the origin and 1e-6..1e3 m big equals per-clump calls."""
    rng = np.random.default_rng(11)
    cs, rs = [], []
    for k, (scale, off) in enumerate([(1e-6, 0.0), (1.0, 1e6), (1e3, -1e4), (0.05, 3.0)]):
        c = np.array([[0.0, 0.0, 0.0], [0.9, 0.0, 0.0], [0.9, 0.9, 0.0]]) * scale + off
        cs.append(c)
        rs.append(np.array([0.5, 0.5, 0.55]) * scale)
    batch = mass_properties(cs, rs, density=2500.0, method=method)
    for m, (c, r) in enumerate(zip(cs, rs)):
        one = mass_properties(c, r, density=2500.0, method=method)
        assert batch.mass[m] == pytest.approx(one.mass, rel=1e-14)
        assert rel_err(batch.inertia[m], one.inertia) <= 1e-13
        np.testing.assert_allclose(batch.center_of_mass[m], one.center_of_mass, rtol=1e-15, atol=1e-13 * r.max())


@pytest.mark.parametrize("method", [EXACT])
@pytest.mark.parametrize("gap", [1e-4, 1e-6, 1e-8, 1e-10])
def test_near_duplicate_spheres_cut_by_a_third_are_rotation_invariant(method, gap):
    """Two spheres r = 1.2 whose centres are gap apart, and a unit sphere cutting both.

    The union's volume is well conditioned (perturbing a centre by eps moves it by at
    most area * eps), so every rotation of the input must give the same mass to ~1e-13.
    """
    c = np.array([[0.0, 0.0, 0.0], [gap / math.sqrt(2), 0.0, gap / math.sqrt(2)], [0.0, 0.0, 1.0]])
    r = np.array([1.2, 1.2, 1.0])
    masses = [mass_properties(c @ Rotation.random(random_state=s).as_matrix().T, r, method=method).mass for s in range(20)]
    spread = (max(masses) - min(masses)) / np.mean(masses)
    assert spread <= 1e-12, f"mass varies by {spread:.2e} (relative) under rotation"
    # and the union is at least the larger sphere plus the part of the unit sphere outside it
    big = 4 / 3 * math.pi * 1.2**3
    outside = 4 / 3 * math.pi - ref.lens_volume_closed_form(1.2, 1.0, 1.0)
    assert min(masses) >= (big + outside) * (1 - 1e-13)  # density 1 kg/m^3
