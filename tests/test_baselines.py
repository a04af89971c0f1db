"""The numerical baselines: Monte Carlo (with its standard errors) and YADE's voxel grid.

Independent routes: the paper's pairwise equations on valid clumps (for Monte Carlo), the
spread of Monte Carlo estimates over seeds (for its standard errors), and convergence to the
exact union (for the voxel scheme; YADE's own grid is checked in tests/test_baselines_yade.py).
"""
import numpy as np
import pytest

import clumpprops as cp

RHO = 1140.0


def valid_pairwise_clump(rng, n=4):
    """A chain of n spheres where only neighbours overlap (no triple overlap)."""
    c = [np.zeros(3)]
    r = [rng.uniform(0.6, 1.0)]
    for _ in range(n - 1):
        u = rng.normal(size=3)
        u[0] = abs(u[0]) + 1.0  # keep the chain going along +x so non-neighbours stay apart
        u /= np.linalg.norm(u)
        rn = rng.uniform(0.6, 1.0)
        c.append(c[-1] + u * (r[-1] + rn) * rng.uniform(0.6, 0.9))
        r.append(rn)
    return np.array(c), np.array(r)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pairwise_agrees_with_montecarlo_within_4_standard_errors(seed):
    rng = np.random.default_rng(seed)
    c, r = valid_pairwise_clump(rng)
    pw = cp.mass_properties(c, r, RHO, method="pairwise")  # raises if the chain had a triple overlap
    mc = cp.mass_properties(c, r, RHO, method="montecarlo", n_samples=300_000, seed=seed)
    se = mc.standard_error
    assert abs(mc.mass - pw.mass) <= 4 * se.mass
    assert np.all(np.abs(mc.center_of_mass - pw.center_of_mass) <= 4 * se.center_of_mass)
    assert np.all(np.abs(mc.inertia - pw.inertia) <= 4 * se.inertia + 1e-12 * np.abs(pw.inertia).max())
    # the error bars are meaningful, not huge: 1-sigma mass error ~ 1e-3 relative at 3e5 samples
    assert se.mass / pw.mass < 5e-3


def test_montecarlo_standard_error_matches_the_spread_over_seeds():
    """The reported 1-sigma error of the mass agrees with the scatter of independent estimates."""
    c, r = valid_pairwise_clump(np.random.default_rng(5), n=3)
    ref = cp.mass_properties(c, r, RHO, method="pairwise")
    runs = [cp.mass_properties(c, r, RHO, method="montecarlo", n_samples=20_000, seed=s) for s in range(40)]
    z = np.array([(m.mass - ref.mass) / m.standard_error.mass for m in runs])
    # 40 standard normal draws: mean within 3/sqrt(40), std within [0.6, 1.5]
    assert abs(z.mean()) < 3 / np.sqrt(40)
    assert 0.6 < z.std() < 1.5


def test_montecarlo_is_reproducible_and_seeded():
    c, r = valid_pairwise_clump(np.random.default_rng(6), n=3)
    a = cp.mass_properties(c, r, method="montecarlo", n_samples=5000, seed=11)
    b = cp.mass_properties(c, r, method="montecarlo", n_samples=5000, seed=11)
    d = cp.mass_properties(c, r, method="montecarlo", n_samples=5000, seed=12)
    assert a.mass == b.mass and np.array_equal(a.inertia, b.inertia)
    assert a.mass != d.mass


def test_montecarlo_rejects_too_few_samples():
    with pytest.raises(ValueError, match="n_samples"):
        cp.mass_properties([[0, 0, 0]], [1.0], method="montecarlo", n_samples=10)


@pytest.mark.parametrize("bad", [0, -3, 2.5, "ten"])
def test_voxel_rejects_bad_discretization(bad):
    with pytest.raises(ValueError, match="discretization"):
        cp.mass_properties([[0, 0, 0], [0.5, 0, 0]], [1.0, 1.0], method="voxel", discretization=bad)


def test_voxel_converges_to_exact_on_the_paper_dimer():
    d = 0.1333
    c, r = [[0, 0, -d / 4], [0, 0, d / 4]], [d / 2, d / 2]
    ex = cp.mass_properties(c, r, RHO)
    errs = [abs(cp.mass_properties(c, r, RHO, method="voxel", discretization=k).mass / ex.mass - 1) for k in (10, 20, 40)]
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 2e-3
