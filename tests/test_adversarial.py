"""Adversarial input: every clump gets the right answer or a clear refusal.

* the pairwise method refuses every clump with a triple overlap, whatever the order of its
  spheres (coincident and near-coincident pairs cut by a third sphere included), checked
  against an independent convex-minimisation criterion;
* complex numbers, booleans, strings and numbers beyond float64 are refused with one
  ValueError, for every method;
* Monte Carlo sample counts and voxel grids beyond the stated limits are refused;
"""
from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest
from scipy.optimize import minimize

import clumpprops as cp
from clumpprops import _input
from clumpprops.methods import MAX_DISCRETIZATION, MAX_SAMPLES, MonteCarlo, Voxel
from clumpprops.pairwise import pairwise_moments

PERMS = list(itertools.permutations(range(3)))


def _twin_pair_cut_by_third(rng, gap):
    """Spheres 1 and 2 are one sphere (centres `gap` apart), sphere 0 cuts into it by >= 5 % of r."""
    c = rng.normal(size=(3, 3))
    r = rng.uniform(0.5, 1.5, 3)
    r[2] = r[1]
    u = rng.normal(size=3)
    c[2] = c[1] + gap * u / np.linalg.norm(u)
    v = rng.normal(size=3)
    depth = rng.uniform(0.05, 0.95) * min(r[0], r[1]) * 2
    c[0] = c[1] + (r[0] + r[1] - depth) * v / np.linalg.norm(v)
    return c, r


def _refuses_core(c, r):
    try:
        cp.mass_properties(c, r, method="pairwise")
    except cp.ClumpGeometryError:
        return True
    return False


def _refuses_numpy(c, r):
    try:
        pairwise_moments(_input.normalize(c, r))
    except cp.ClumpGeometryError:
        return True
    return False


@pytest.mark.parametrize("gap", [0.0, 1e-300, 1e-184, 1e-20])
def test_pairwise_refuses_a_twin_pair_cut_by_a_third_sphere_in_every_order(gap):
    rng = np.random.default_rng(11)
    for _ in range(60):
        c, r = _twin_pair_cut_by_third(rng, gap)
        for perm in PERMS:
            p = list(perm)
            assert _refuses_core(c[p], r[p]), (c[p].tolist(), r[p].tolist())
            assert _refuses_numpy(c[p], r[p]), (c[p].tolist(), r[p].tolist())


def _triple_depth(c, r):
    """min over x of max_i (|x - c_i| - r_i): < 0 iff the three balls share an interior point.

    A convex function, minimised from the pairwise contact points and the centres (an
    independent route: no lens, no rim circle)."""
    f = lambda x: float(np.max(np.linalg.norm(x - c, axis=1) - r))
    starts = list(c) + [(r[b] * c[a] + r[a] * c[b]) / (r[a] + r[b]) for a, b in ((0, 1), (0, 2), (1, 2))]
    x0 = min(starts, key=f)
    res = minimize(f, x0, method="Nelder-Mead", options={"xatol": 1e-9, "fatol": 1e-12, "maxiter": 2000})
    return min(f(x0), res.fun)


def test_pairwise_triple_decision_is_the_same_in_every_order_and_right():
    rng = np.random.default_rng(5)
    decided = {True: 0, False: 0}
    while min(decided.values()) < 25:
        c = rng.normal(size=(3, 3)) * 0.8
        r = rng.uniform(0.4, 1.2, 3)
        k = rng.integers(4)
        if k == 1:  # a near-coincident pair
            c[2], r[2] = c[1] + rng.normal(size=3) * 1e-9, r[1]
        elif k == 2:  # nested pair
            c[2], r[2] = c[1] + rng.normal(size=3) * 0.05, r[1] * 0.5
        elif k == 3:  # around a hole: a triangle of side 1, radii between 1/2 and 1/sqrt(3)
            c = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, np.sqrt(0.75), 0]]) + rng.normal(size=(3, 3)) * 0.02
            r = rng.uniform(0.51, 0.6, 3)
        D = np.linalg.norm(c[:, None] - c[None], axis=-1)
        if not np.all((D < r[:, None] + r[None])[np.triu_indices(3, 1)]):
            continue  # not a triangle of overlapping pairs: nothing to decide
        depth = _triple_depth(c, r)
        if abs(depth) < 1e-3 * r.min():
            continue  # too close to tangency for the minimiser to be trusted
        want = depth < 0
        for perm in PERMS:
            p = list(perm)
            assert _refuses_core(c[p], r[p]) == want
            assert _refuses_numpy(c[p], r[p]) == want
        decided[want] += 1


# ---------------------------------------------------------------- input that is not a real number
_C2 = np.array([[0.0, 0, 0], [1, 0, 0]])
_R2 = np.array([1.0, 0.8])
BAD_INPUT = {
    "complex centers": (lambda: (_C2 + 0j, _R2, 1.0), "complex"),
    "complex radii": (lambda: (_C2, _R2 + 0j, 1.0), "complex"),
    "boolean radii": (lambda: (_C2, np.array([True, True]), 1.0), "boolean"),
    "string radii": (lambda: (_C2, ["1", "0.8"], 1.0), "string"),
    "string centers": (lambda: ([["0", "0", "0"], ["1", "0", "0"]], _R2, 1.0), "string"),
    "huge Python int centre": (lambda: ([[10**400, 0, 0], [1, 0, 0]], _R2, 1.0), "too large"),
    "huge Python int radius": (lambda: (_C2, [10**400, 1], 1.0), "too large"),
    "ragged complex radii": (lambda: ([_C2, _C2[:1]], [_R2 + 0j, _R2[:1]], 1.0), "complex"),
    "ragged boolean radii": (lambda: ([_C2, _C2[:1]], [_R2, np.array([True])], 1.0), "boolean"),
    "density True": (lambda: (_C2, _R2, True), "density"),
    "density string": (lambda: (_C2, _R2, "2"), "density"),
    "density complex": (lambda: (_C2, _R2, 2 + 0j), "density"),
    "density huge Python int": (lambda: (_C2, _R2, 10**400), "too large"),
}


@pytest.mark.parametrize("method", ["exact", "pairwise", "sum", "montecarlo", "voxel"])
@pytest.mark.parametrize("case", sorted(BAD_INPUT))
def test_input_that_is_not_a_real_number_is_refused_with_one_value_error(case, method):
    make, word = BAD_INPUT[case]
    c, r, rho = make()
    opts = {"n_samples": 1000} if method == "montecarlo" else {}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a ComplexWarning is not a refusal
        with pytest.raises(ValueError, match=word):
            cp.mass_properties(c, r, rho, method=method, **opts)


def test_real_input_of_any_numeric_type_gives_the_float_answer():
    want = cp.mass_properties(_C2, np.array([1.0, 2.0]), 3.0)
    for c, r, rho in [(_C2.tolist(), [1, 2], 3), (_C2.astype(np.float32), np.array([1, 2], np.int64), np.float32(3)),
                      ([_C2], [np.array([1, 2], np.uint8)], np.int64(3)), ([[0, 0, 0], [10**0, 0, 0]], [1, 2], 3.0)]:
        got = cp.mass_properties(c, r, rho)
        assert np.allclose(np.ravel(got.mass), want.mass, rtol=1e-15, atol=0)
        assert np.allclose(np.reshape(got.inertia, (3, 3)), want.inertia, rtol=1e-15, atol=1e-15 * want.inertia.max())


# ---------------------------------------------------------------- stated limits of the baselines
@pytest.mark.parametrize("kw, word", [
    ({"method": "montecarlo", "n_samples": 10**15}, "n_samples is too large"),
    ({"method": "voxel", "discretization": 10**6}, "discretization is too large"),
    ({"method": "montecarlo", "n_samples": True}, "integer"),
    ({"method": "voxel", "discretization": "10"}, "integer"),
])
def test_sample_counts_and_grids_beyond_the_stated_limit_are_refused(kw, word):
    with pytest.raises(ValueError, match=word):
        cp.mass_properties(_C2, _R2, **kw)


def test_method_objects_refuse_counts_beyond_the_stated_limit():
    with pytest.raises(ValueError, match="too large"):
        MonteCarlo(n_samples=MAX_SAMPLES + 1)
    with pytest.raises(ValueError, match="too large"):
        Voxel(discretization=MAX_DISCRETIZATION + 1)


def test_an_elongated_voxel_grid_beyond_the_cell_limit_is_refused():
    c = np.stack([np.linspace(0, 200, 300), np.zeros(300), np.zeros(300)], 1)
    with pytest.raises(ValueError, match="voxel grid is too large"):
        cp.mass_properties(c, np.ones(300), method="voxel", discretization=MAX_DISCRETIZATION)


# ---------------------------------------------------------------- any scale
def _scaled_cases():
    rng = np.random.default_rng(1)
    return {"exact": (rng.normal(size=(6, 3)), rng.uniform(0.6, 1.2, 6)),
            "pairwise": (np.array([[0.0, 0, 0], [1.5, 0, 0], [0.2, 1.6, 0.3]]), np.array([1.0, 0.8, 0.7])),
            "sum": (rng.normal(size=(4, 3)), rng.uniform(0.6, 1.2, 4))}


@pytest.mark.parametrize("method", ["exact", "pairwise", "sum"])
def test_scaled_clumps_are_exact_where_representable_else_refused_naming_the_direction(method):
    """Scaling lengths by s scales mass by s^3 and inertia by s^5 (an exact symmetry): the
    answer at s equals the answer at 1 times those powers to 1e-13, or, where mass or inertia
    leaves float64's normal range, a ValueError saying 'too large' or 'too small'."""
    c, r = _scaled_cases()[method]
    base = cp.mass_properties(c, r, 1.0, method=method)
    tiny, huge = np.finfo(float).tiny, np.finfo(float).max
    for k in range(-100, 101):
        s = 3.0 * 10.0**k if k % 2 else 10.0**k
        logs = np.log10(s)
        lo = min(3 * logs + np.log10(base.mass), 5 * logs + np.log10(base.principal_moments.max()))
        hi = max(3 * logs + np.log10(base.mass), 5 * logs + np.log10(base.principal_moments.max()))
        representable = lo > np.log10(tiny) + 1 and hi < np.log10(huge) - 1
        try:
            mp = cp.mass_properties(c * s, r * s, 1.0, method=method)
        except ValueError as exc:
            assert not representable, (k, str(exc))
            word = "too large" if hi >= np.log10(huge) - 1 else "too small"
            assert word in str(exc), (k, str(exc))
            continue
        if not representable:  # at the edge of the range: an answer must still be right
            assert np.log10(tiny) <= lo and hi <= np.log10(huge), k
        assert mp.mass == pytest.approx(base.mass * s**3, rel=1e-13)
        assert np.allclose(mp.center_of_mass, base.center_of_mass * s, rtol=0, atol=1e-13 * s * np.abs(c).max())
        scale = base.principal_moments.max()
        # s^5 may itself overflow where the inertia does not: scale the answer down instead
        assert np.max(np.abs(mp.inertia / s**2 / s**3 - base.inertia)) <= 1e-13 * scale, k


def test_a_far_tiny_clump_keeps_its_digits():
    """Radii near 1e-9 m about 1e6 m from the origin (and radii near 1e-60 m): the answer of
    the same clump (as its rounded input holds it) moved to the origin at unit scale, with
    powers of two so that moving and scaling back are exact."""
    c0, r0 = _scaled_cases()["exact"]
    for s, shift in [(2.0**-30, 2.0**20), (2.0**-200, 0.0), (2.0**-200, 2.0**-170)]:
        c, r = c0 * s + shift, r0 * s
        ref = cp.mass_properties((c - shift) / s, r / s, 1.0)
        mp = cp.mass_properties(c, r, 1.0)
        assert mp.mass == pytest.approx(ref.mass * s**3, rel=1e-13)
        com_digits = max(1e-13, np.spacing(shift) / s)  # the position of the centre holds no more
        assert np.allclose((mp.center_of_mass - shift) / s, ref.center_of_mass, rtol=0, atol=com_digits)
        assert np.max(np.abs(mp.inertia / s**5 - ref.inertia)) <= 1e-13 * ref.principal_moments.max()


# ---------------------------------------------------------------- dense input
def test_ten_thousand_identical_spheres_are_one_ball_for_exact_and_n_balls_for_sum():
    """The union of n copies of a ball is the ball (closed form: m = 4/3 pi r^3 rho, I = 2/5 m r^2);
    the summed method counts every copy by design (YADE's and LAMMPS' sums)."""
    n, r, rho = 10**4, 0.3, 2.0
    c = np.tile([1.0, -2.0, 0.5], (n, 1))
    m_ball = 4.0 / 3.0 * np.pi * r**3 * rho
    one = cp.mass_properties(c, np.full(n, r), rho)
    assert one.mass == pytest.approx(m_ball, rel=1e-15)
    assert np.allclose(one.inertia, 0.4 * m_ball * r**2 * np.eye(3), rtol=0, atol=1e-15 * m_ball * r**2)
    summed = cp.mass_properties(c, np.full(n, r), rho, method="sum")
    assert summed.mass == pytest.approx(n * m_ball, rel=1e-13)


def test_a_large_clump_with_repeated_spheres_is_the_union_of_the_distinct_ones():
    """80 distinct spheres, each listed one to three times in a shuffled order (above the size
    where duplicates are dropped before the pair search): the same union as the 80 alone, and
    Monte Carlo over the union agrees within 5 standard errors."""
    rng = np.random.default_rng(3)
    c = rng.normal(size=(80, 3)) * 2.0
    r = rng.uniform(0.4, 1.0, 80)
    reps = rng.integers(1, 4, 80)
    idx = rng.permutation(np.repeat(np.arange(80), reps))
    got = cp.mass_properties(c[idx], r[idx])
    want = cp.mass_properties(c, r)
    assert got.mass == pytest.approx(want.mass, rel=1e-13)
    assert np.max(np.abs(got.inertia - want.inertia)) <= 1e-12 * want.principal_moments.max()
    mc = cp.mass_properties(c, r, method="montecarlo", n_samples=200_000, seed=4)
    assert abs(got.mass - mc.mass) <= 5 * mc.standard_error.mass


def test_thousands_of_spheres_inside_one_ball_are_that_ball():
    """3,000 spheres nested in one ball (concentric ones, and random ones inside it, some
    touching its surface from inside): the union is the ball, closed form."""
    rng = np.random.default_rng(8)
    R, centre = 2.0, np.array([0.5, -1.0, 3.0])
    r_in = rng.uniform(0.01, 1.5, 2000)
    u = rng.normal(size=(2000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    d = (R - r_in) * np.where(rng.random(2000) < 0.2, 1.0, rng.uniform(0, 1, 2000))
    c = np.vstack([centre + d[:, None] * u, np.tile(centre, (1000, 1)), [centre]])
    r = np.concatenate([r_in, np.linspace(0.01, R * (1 - 1e-9), 1000), [R]])
    p = rng.permutation(len(r))
    mp = cp.mass_properties(c[p], r[p], 1.5)
    m_ball = 4.0 / 3.0 * np.pi * R**3 * 1.5
    assert mp.mass == pytest.approx(m_ball, rel=1e-14)
    assert np.allclose(mp.center_of_mass, centre, rtol=0, atol=1e-14 * R)
    assert np.allclose(mp.inertia, 0.4 * m_ball * R**2 * np.eye(3), rtol=0, atol=1e-14 * m_ball * R**2)
