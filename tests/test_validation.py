"""Bad input raises ValueError with a message naming the problem; results are immutable, never NaN."""
from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import clumpprops
from clumpprops import MassProperties, mass_properties

from _profiles import examples

C2 = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]
R2 = [0.7, 0.6]


METHODS = ["pairwise", "sum", "exact", "montecarlo", "voxel"]
CHEAP = {"montecarlo": {"n_samples": 20000, "seed": 1}, "voxel": {"discretization": 8}}


def raises(match, *args, **kw):
    with pytest.raises(ValueError, match=match) as info:
        mass_properties(*args, **kw)
    msg = str(info.value)
    assert "\n" not in msg.strip() or len(msg) < 500
    return msg


# ---------------------------------------------------------------- shapes
@pytest.mark.parametrize(
    "centers,radii,match",
    [
        ([[0, 0]], [1.0], r"3 coordinates|shape"),
        ([[0, 0, 0, 0]], [1.0], r"3 coordinates|shape"),
        ([0.0, 0.0, 0.0], [1.0], r"shape \(N, 3\)"),
        ([[[[0, 0, 0]]]], [[[1.0]]], r"shape \(N, 3\)"),
        ([[0, 0, 0], [1, 0, 0]], [1.0], r"radii must have shape \(2,\)"),
        ([[0, 0, 0]], [1.0, 2.0], r"radii must have shape \(1,\)"),
        ([[0, 0, 0]], 1.0, r"radii must have shape"),
        (np.zeros((2, 3, 3)), np.ones(3), r"radii must have shape \(2, 3\)"),
        (np.zeros((2, 3, 3)), np.ones((3, 2)), r"radii must have shape \(2, 3\)"),
        ("abc", [1.0], r"centers must be numeric"),
        ([["a", "b", "c"]], [1.0], r"centers must be numeric"),
        ([[0, 0, 0]], ["x"], r"radii must be numeric"),
    ],
)
def test_wrong_shapes(centers, radii, match):
    raises(match, centers, radii)


def test_radii_with_an_extra_axis_for_a_single_clump_are_rejected():
    # centers (N, 3) is one clump; radii (1, N) is the batch layout: ambiguous, must not pass silently
    raises(r"radii must have shape \(2,\)", C2, [R2])


def test_ragged_mismatches():
    raises(r"2 clumps of centers but 1 of radii", [np.zeros((2, 3)), np.zeros((1, 3))], [np.ones(2)])
    raises(r"radii\[1\] must have shape \(1,\)", [np.zeros((2, 3)), np.zeros((1, 3))], [np.ones(2), np.ones(2)])
    raises(r"centers\[0\] must have shape \(N, 3\)", [np.zeros((2, 2)), np.zeros((1, 3))], [np.ones(2), np.ones(1)])


@pytest.mark.parametrize(
    "centers,radii,match",
    [
        (np.zeros((0, 3)), np.zeros(0), r"empty clump"),
        (np.zeros((2, 0, 3)), np.zeros((2, 0)), r"empty clump"),
        (np.zeros((0, 2, 3)), np.zeros((0, 2)), r"empty batch"),
        ([np.zeros((2, 3)), np.zeros((0, 3))], [np.ones(2), np.ones(0)], r"clump 1 is empty"),
        ([], [], r"empty|shape"),
    ],
)
def test_empty_input(centers, radii, match):
    raises(match, centers, radii)


# ---------------------------------------------------------------- values
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_centers(bad):
    c = np.array(C2)
    c[1, 2] = bad
    raises(r"centers contains NaN or inf", c, R2)
    raises(r"centers contains NaN or inf", [c, np.array(C2)], [R2, R2])


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_radii(bad):
    raises(r"radii contains NaN or inf", C2, [0.7, bad])


@pytest.mark.parametrize("bad", [0.0, -0.5, -np.inf])
def test_non_positive_radius(bad):
    msg = raises(r"radii", C2, [0.7, bad])
    assert re.search(r"> 0|positive|NaN or inf", msg)


@pytest.mark.parametrize("density", [0, -1.0, np.nan, np.inf, -np.inf, "abc", None, [1.0, 2.0]])
def test_bad_density(density):
    msg = raises(r"density", C2, R2, density=density)
    assert "kg/m^3" in msg


def test_unknown_method_lists_the_choices():
    msg = raises(r"unknown method 'foo'", C2, R2, method="foo")
    for m in ("exact", "pairwise", "sum", "montecarlo", "voxel"):
        assert m in msg


@pytest.mark.parametrize("method", ["pairwise", "sum", "exact"])
def test_unknown_option(method):
    msg = raises(r"takes no option", C2, R2, method=method, n_samples=10)
    assert "n_samples" in msg


def test_option_of_another_method():
    raises(r"discretization", C2, R2, method="montecarlo", discretization=5)
    raises(r"n_samples", C2, R2, method="voxel", n_samples=5)


def test_error_is_raised_before_any_work_and_input_is_not_modified():
    c = np.array(C2)
    r = np.array(R2)
    c0, r0 = c.copy(), r.copy()
    mass_properties(c, r, density=1000.0, method="pairwise")
    np.testing.assert_array_equal(c, c0)
    np.testing.assert_array_equal(r, r0)


# ---------------------------------------------------------------- never NaN
@pytest.mark.parametrize("method", ["pairwise", "sum", "exact"])
@pytest.mark.parametrize("radius", [1e-30, 1e-6, 1.0, 1e6, 1e30])
def test_finite_output_across_scales(method, radius):
    mp = mass_properties(np.array(C2) * radius, np.array(R2) * radius, density=1000.0, method=method)
    for name in ("mass", "volume", "center_of_mass", "inertia", "principal_moments", "principal_axes"):
        assert np.all(np.isfinite(getattr(mp, name))), name
    assert mp.mass > 0 and np.all(mp.principal_moments > 0)


@pytest.mark.parametrize("method", ["pairwise", "sum", "exact"])
@pytest.mark.parametrize("radius,density", [(1e70, 1.0), (1e30, 1e300)])
def test_overflowing_input_raises_instead_of_returning_nan(method, radius, density):
    """Finite input whose inertia overflows float64 (r^5 rho > 1e308) must not give NaN."""
    try:
        mp = mass_properties([[0.0, 0.0, 0.0]], [radius], density=density, method=method)
    except (ValueError, ArithmeticError) as exc:
        assert re.search(r"overflow|too large|range|finite", str(exc)), str(exc)
        return
    for name in ("mass", "inertia", "principal_moments", "principal_axes"):
        assert not np.any(np.isnan(getattr(mp, name))), f"{name} is NaN for r={radius}, rho={density}"


@settings(max_examples=examples(60))  # derandomized etc.: tests/_profiles.py
@given(
    st.lists(
        st.tuples(st.floats(-10, 10), st.floats(-10, 10), st.floats(-10, 10), st.floats(1e-3, 5.0)),
        min_size=1,
        max_size=6,
    ),
    st.floats(1e-3, 1e5),
)
def test_sum_never_nan(spheres, density):
    a = np.array(spheres)
    mp = mass_properties(a[:, :3], a[:, 3], density=density, method="sum")
    assert np.all(np.isfinite(mp.inertia)) and np.isfinite(mp.mass)


# ---------------------------------------------------------------- immutability
@pytest.mark.parametrize("method", METHODS)
def test_mass_properties_is_immutable(method):
    mp = mass_properties(C2, R2, density=1000.0, method=method, **CHEAP.get(method, {}))
    assert isinstance(mp, MassProperties)
    for name in ("mass", "volume", "center_of_mass", "inertia", "principal_moments", "principal_axes", "method", "density"):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(mp, name, 1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        del mp.mass
    for name in ("center_of_mass", "inertia", "principal_moments", "principal_axes"):
        arr = getattr(mp, name)
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 1.0
        with pytest.raises(ValueError):
            arr += 1.0
    assert isinstance(mp.mass, float) and isinstance(mp.volume, float)
    if mp.standard_error is not None:
        with pytest.raises(ValueError):
            mp.standard_error.inertia[0, 0] = 1.0
        with pytest.raises(dataclasses.FrozenInstanceError):
            mp.standard_error.mass = 0.0


def test_batch_results_and_their_items_are_immutable():
    mp = mass_properties([np.array(C2), np.array(C2) + 5], [R2, R2], method="pairwise")
    with pytest.raises(ValueError):
        mp.mass[0] = 1.0
    item = mp[1]
    with pytest.raises(ValueError):
        item.inertia[0, 0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        item.mass = 2.0


def test_results_do_not_alias_the_input():
    c = np.array(C2)
    r = np.array(R2)
    mp = mass_properties(c, r, method="sum")
    com = mp.center_of_mass.copy()
    c += 100.0
    r *= 2.0
    np.testing.assert_array_equal(mp.center_of_mass, com)


def test_exceptions_are_value_errors():
    assert issubclass(clumpprops.ClumpGeometryError, ValueError)


def test_one_parser_for_the_core_and_the_numpy_methods():
    """_input.flatten stacks the three layouts alike; normalize (the numpy methods' input) is built on
    it, so a layout error reads the same whichever method is asked for."""
    from clumpprops import _input

    rng = np.random.default_rng(3)
    c = rng.normal(size=(2, 3, 3))
    r = rng.uniform(0.5, 1.0, (2, 3))
    one = _input.flatten(c[0], r[0])
    regular = _input.flatten(c, r)
    ragged = _input.flatten([c[0], c[1, :2]], [r[0], r[1, :2]])
    np.testing.assert_array_equal(one[0], c[0])
    assert one[2:] == (None, 3, 1, False)
    np.testing.assert_array_equal(regular[0], c.reshape(6, 3))
    np.testing.assert_array_equal(regular[1], r.ravel())
    assert regular[2:] == (None, 3, 2, True)
    np.testing.assert_array_equal(ragged[0], np.concatenate([c[0], c[1, :2]]))
    assert ragged[2].tolist() == [0, 3, 5] and ragged[3:] == (0, 2, True)
    sph = _input.normalize([c[0], c[1, :2]], [r[0], r[1, :2]])
    assert sph.counts.tolist() == [3, 2] and sph.starts.tolist() == [0, 3] and sph.regular == 0
    np.testing.assert_allclose(sph.centers + sph.origin[sph.clump], ragged[0], rtol=0, atol=1e-15)
    bad = ([c[0], c[1, :, :2]], [r[0], r[1]])
    messages = set()
    for method in ("exact", "pairwise", "sum", "montecarlo", "voxel"):
        with pytest.raises(ValueError) as info:
            mass_properties(*bad, method=method)
        messages.add(str(info.value))
    assert messages == {"centers[1] must have shape (N, 3), got (3, 2)"}
