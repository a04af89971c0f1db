"""The pairwise method never answers where it must refuse: a clump with two identical or nearly
identical spheres that a third sphere cuts has a triple overlap (the third sphere's lens with one of
the pair lies in the other), whatever the order the spheres are listed in."""
import itertools

import numpy as np
import pytest

import clumpprops as cp
from clumpprops import _input
from clumpprops.pairwise import pairwise_moments

SEPARATIONS = (0.0, 1e-300, 1e-184, 1e-17, 1e-12)


def _twin_and_cutter(rng, sep):
    """Sphere 0 cuts sphere 1; sphere 2 is sphere 1 moved by ``sep`` (m): a triple overlap."""
    while True:
        c = rng.uniform(-1, 1, (2, 3))
        r = rng.uniform(0.5, 1.0, 2)
        gap = np.linalg.norm(c[0] - c[1])
        if abs(r[0] - r[1]) < gap < r[0] + r[1]:          # a proper lens: neither ball inside the other
            u = rng.normal(size=3)
            return np.array([c[0], c[1], c[1] + sep * u / np.linalg.norm(u)]), np.array([r[0], r[1], r[1]])


@pytest.mark.parametrize("sep", SEPARATIONS)
def test_every_order_of_a_twin_pair_cut_by_a_third_sphere_is_refused(sep):
    rng = np.random.default_rng(int(sep > 0) + len(str(sep)))
    for _ in range(340):                                  # x 5 separations x 6 orders: > 10^4 clumps
        c, r = _twin_and_cutter(rng, sep)
        for perm in itertools.permutations(range(3)):
            p = list(perm)
            with pytest.raises(cp.ClumpGeometryError, match="triple overlap"):
                cp.mass_properties(c[p], r[p], method="pairwise")


@pytest.mark.parametrize("sep", SEPARATIONS)
def test_the_numpy_pairwise_check_refuses_them_in_every_order_too(sep):
    rng = np.random.default_rng(100 + int(sep > 0))
    for _ in range(30):
        c, r = _twin_and_cutter(rng, sep)
        for perm in itertools.permutations(range(3)):
            p = list(perm)
            with pytest.raises(cp.ClumpGeometryError):
                pairwise_moments(_input.normalize(c[p], r[p]))


def test_a_twin_pair_alone_or_with_a_sphere_apart_is_still_answered_exactly():
    """No triple overlap, no refusal: the twins' union is one sphere (pairwise: sphere + sphere - lens)."""
    r = 0.7
    for sep in SEPARATIONS:
        c = np.array([[0.0, 0.0, 0.0], [sep, 0.0, 0.0], [5.0, 0.0, 0.0]])
        rr = np.array([r, r, 0.3])
        mp = cp.mass_properties(c, rr, density=1.0, method="pairwise")
        want = 4 / 3 * np.pi * (r ** 3 + 0.3 ** 3)
        assert mp.volume == pytest.approx(want, rel=1e-12)
