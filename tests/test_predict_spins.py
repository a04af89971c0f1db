"""The spins of a case drawn from exact's (studies.maps.spin_map): equipartition with the case's
inertia tensor, for tensors that are not diagonal in the members' frame (the many-sphere grain)."""
import numpy as np
import pytest

from studies import maps
from studies import shapes as shp


def test_the_map_scales_axis_by_axis_for_diagonal_tensors():
    m = maps.spin_map(np.diag([1.0, 2.0, 4.0]), np.diag([2.0, 2.0, 1.0]), 1.5)
    assert np.allclose(m, np.diag(np.sqrt(1.5 * np.array([0.5, 1.0, 4.0]))), rtol=0, atol=1e-15)


def test_mapped_spins_have_the_case_tensors_equipartition_covariance():
    grain = {"kind": "file", "path": "studies/grains/ellipsoid20.txt", "scale": 1.0}
    props = shp.properties(grain, 1140.0)
    i_e, i_c = np.asarray(props["exact"]["inertia"]), np.asarray(props["sum"]["inertia"])
    assert np.max(np.abs(i_c - np.diag(np.diag(i_c)))) > 1e-3 * np.max(i_c)     # not diagonal there
    kt, ratio = 0.9, 1.64
    m = maps.spin_map(i_e, i_c, ratio)
    # covariance of w_e is kT I_e^-1; of M w_e, M kT I_e^-1 M^T, which must be ratio kT I_c^-1
    cov = m @ (kt * np.linalg.inv(i_e)) @ m.T
    assert cov == pytest.approx(ratio * kt * np.linalg.inv(i_c), rel=1e-10)
    # and the rotational energy per body, <w.I_c w>/2 = 3 ratio kT/2, from samples
    z = np.random.default_rng(0).standard_normal((200_000, 3))
    w_e = z @ np.linalg.cholesky(kt * np.linalg.inv(i_e)).T
    w_c = w_e @ m.T
    energy = 0.5 * np.einsum("ni,ij,nj->n", w_c, i_c, w_c).mean()
    assert energy == pytest.approx(1.5 * ratio * kt, rel=0.01)
