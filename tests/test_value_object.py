"""MassProperties as a value object: moved bodies against recomputing from moved spheres,
inertia_about against the parallel-axis sum over disjoint spheres, equality/hash, allclose,
orientation, concatenate, and the typed method options."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import clumpprops as cp

C = np.array([[0.0, 0.0, 0.0], [0.7, 0.1, 0.0], [0.3, 0.6, 0.2], [0.2, 0.2, 0.7]])
R = np.array([0.5, 0.45, 0.4, 0.35])  # triple overlaps: exact only


def test_translated_equals_recomputing_from_moved_spheres():
    mp = cp.mass_properties(C, R, 1140.0)
    v = np.array([3.0, -2.0, 1e3])
    moved = cp.mass_properties(C + v, R, 1140.0)
    assert mp.translated(v).allclose(moved, rtol=1e-12)
    assert not mp.allclose(moved, rtol=1e-6)  # the test can tell: the COM moved
    np.testing.assert_array_equal(mp.translated(v).inertia, mp.inertia)


@pytest.mark.parametrize("as_scipy", [False, True])
def test_rotated_equals_recomputing_from_rotated_spheres(as_scipy):
    rot = Rotation.from_rotvec([0.4, -1.1, 0.7])
    Rm = rot.as_matrix()
    mp = cp.mass_properties(C + [1.0, 2.0, 3.0], R, 7.0)
    ref = cp.mass_properties((C + [1.0, 2.0, 3.0]) @ Rm.T, R, 7.0)
    out = mp.rotated(rot if as_scipy else Rm)
    assert out.allclose(ref, rtol=1e-12)
    assert not mp.allclose(ref, rtol=1e-6)
    J, w = out.principal_axes, out.principal_moments
    np.testing.assert_allclose(J @ np.diag(w) @ J.T, ref.inertia, rtol=0, atol=1e-13 * np.abs(ref.inertia).max())
    assert np.linalg.det(J) > 0
    with pytest.raises(ValueError, match="proper rotation"):
        mp.rotated(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="proper rotation"):
        mp.rotated(2.0 * Rm)


def test_inertia_about_matches_the_parallel_axis_sum_over_disjoint_spheres():
    c = np.array([[0.0, 0.0, 0.0], [3.0, 0.5, -1.0], [-2.0, 2.0, 1.0]])
    r = np.array([1.0, 0.6, 0.8])
    rho = 2.0
    mp = cp.mass_properties(c, r, rho)
    p = np.array([0.3, -4.0, 2.5])
    ref = np.zeros((3, 3))
    for ci, ri in zip(c, r):
        m = rho * 4.0 / 3.0 * math.pi * ri**3
        d = ci - p
        ref += 0.4 * m * ri * ri * np.eye(3) + m * (d @ d * np.eye(3) - np.outer(d, d))
    np.testing.assert_allclose(mp.inertia_about(p), ref, rtol=1e-13)
    np.testing.assert_allclose(mp.inertia_about(mp.center_of_mass), mp.inertia, rtol=0, atol=1e-15 * np.abs(ref).max())


def test_equality_and_hash_are_consistent():
    a = cp.mass_properties(C, R, 1140.0)
    b = cp.mass_properties(C.copy(), R.copy(), 1140.0)
    assert a == b and hash(a) == hash(b) and not (a != b)
    assert len({a, b}) == 1
    assert a != cp.mass_properties(C, R, 1141.0)
    assert a != cp.mass_properties(C, R, 1140.0, method="sum")
    assert a != a.translated([1e-9, 0, 0])
    assert a != "not a MassProperties" and a != None  # noqa: E711
    # -0.0 and 0.0 are equal, and hash the same
    z = cp.mass_properties([[0.0, 0.0, 0.0]], [1.0])
    zt = z.translated([-0.0, -0.0, -0.0])
    assert z == zt and hash(z) == hash(zt)
    # batches: element-wise values, one answer
    batch = cp.mass_properties([C, C + 1], [R, R])
    assert batch == cp.mass_properties(np.stack([C, C + 1]), np.stack([R, R]))
    assert batch != a


def test_allclose_tolerances():
    a = cp.mass_properties(C, R)
    b = cp.mass_properties(C * (1 + 1e-12), R * (1 + 1e-12))
    assert a.allclose(b, rtol=1e-9) and not a.allclose(b, rtol=1e-15)
    assert a.allclose(a, rtol=0.0)
    assert not a.allclose(cp.mass_properties([C, C], [R, R]))  # shapes differ
    with pytest.raises(TypeError):
        a.allclose(1.0)


def test_orientation_is_the_right_handed_principal_frame():
    mp = cp.mass_properties(C, R)
    Rm = mp.orientation.as_matrix()
    np.testing.assert_allclose(Rm, mp.principal_axes, atol=1e-15)
    np.testing.assert_allclose(Rm @ np.diag(mp.principal_moments) @ Rm.T, mp.inertia, atol=1e-14 * mp.inertia.max())
    batch = cp.mass_properties([C, C + 1.0], [R, R])
    assert len(batch.orientation) == 2


def test_concatenate_equals_the_batch_computed_at_once():
    singles = [cp.mass_properties(C + k, R, 5.0) for k in range(3)]
    two = cp.mass_properties([C + 3, C + 4], [R, R], 5.0)
    allb = cp.concatenate(singles + [two])
    ref = cp.mass_properties([C + k for k in range(5)], [R] * 5, 5.0)
    assert allb == ref
    assert len(allb) == 5 and allb[4] == ref[4]
    with pytest.raises(ValueError, match="one method"):
        cp.concatenate([singles[0], cp.mass_properties(C, R, 5.0, method="sum")])
    mc = [cp.mass_properties(C, R, method=cp.MonteCarlo(2000, seed=s)) for s in (1, 2)]
    assert cp.concatenate(mc).standard_error.mass.shape == (2,)


def test_typed_method_options_equal_the_keyword_form():
    a = cp.mass_properties(C, R, method=cp.MonteCarlo(n_samples=5000, seed=3))
    b = cp.mass_properties(C, R, method="montecarlo", n_samples=5000, seed=3)
    assert a == b and a.method == "montecarlo"
    assert cp.mass_properties(C, R, method=cp.Voxel(12)) == cp.mass_properties(C, R, method="voxel", discretization=12)
    assert cp.mass_properties(C, R, method=cp.Exact()) == cp.mass_properties(C, R)
    assert cp.mass_properties(C[:2], R[:2], method=cp.Pairwise()) == cp.mass_properties(C[:2], R[:2], method="pairwise")
    assert cp.mass_properties(C, R, method=cp.Sum()) == cp.mass_properties(C, R, method="sum")
    with pytest.raises(ValueError, match="not both"):
        cp.mass_properties(C, R, method=cp.MonteCarlo(5000), seed=1)
    with pytest.raises(ValueError, match="n_samples"):
        cp.MonteCarlo(n_samples=10)
    with pytest.raises(ValueError, match="discretization"):
        cp.Voxel(0)
    with pytest.raises(ValueError, match="unknown method"):
        cp.mass_properties(C, R, method=object())
