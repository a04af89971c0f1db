"""studies/maps.py (python -m studies case-map): the ratio estimator of the collision-map prediction, on synthetic
collisions with a known answer (no YADE), and the per-case states it builds."""
import math

import numpy as np
import pytest

from studies import gas_model as gm
from studies import maps as cm
from studies import shapes as shp
from studies.timestep import collisions as tc


def _collisions(rng, n, c):
    """gamma^2 ~ Gamma(2) (the flux weight), q_exact uniform on [0, 2], q_case = c q_exact + independent
    noise: the population ratio <x q_e>/<x q_c> is exactly 1/c."""
    x = rng.gamma(2.0, 1.0, n)
    q_e = rng.uniform(0.0, 2.0, n)
    q_c = c * q_e + rng.normal(0.0, 0.2, n)
    return x, q_e, q_c


def test_ratio_is_unbiased_and_its_interval_covers():
    """500 replicas of 2,000 collisions: bias of D_case/D_exact - 1 under 0.05 %, 95 % coverage of
    +-1.96 se in 92-98 %, and the se matches the replicas' spread within 10 %."""
    rng = np.random.default_rng(5)
    c, ktm = 0.99, 1.05
    truth = math.sqrt(ktm) / c - 1.0
    est, cover, ses = [], 0, []
    for _ in range(500):
        rel, se = cm.ratio(*_collisions(rng, 2000, c), ktm)
        est.append(rel)
        ses.append(se)
        cover += abs(rel - truth) <= 1.96 * se
    est = np.array(est)
    assert abs(est.mean() - truth) < 5e-4
    assert 0.92 <= cover / 500 <= 0.98, cover / 500
    assert np.mean(ses) == pytest.approx(est.std(ddof=1), rel=0.10)


def test_difference_of_two_ratios_has_the_paired_se():
    """Two cases on the same collisions: the se of their difference from the influence values
    matches the spread of the difference over replicas, and is far below the unpaired sum."""
    rng = np.random.default_rng(6)
    diffs, ses, unpaired = [], [], []
    for _ in range(300):
        x, q_e, q_1 = _collisions(rng, 2000, 0.99)
        q_2 = 0.995 * q_1 + rng.normal(0.0, 0.02, 2000)
        r1, s1, d1 = cm.ratio(x, q_e, q_1, 1.0, full=True)
        r2, s2, d2 = cm.ratio(x, q_e, q_2, 1.0, full=True)
        diffs.append(r2 - r1)
        ses.append((d2 - d1).std(ddof=1) / math.sqrt(2000))
        unpaired.append(math.hypot(s1, s2))
    assert np.mean(ses) == pytest.approx(np.std(diffs, ddof=1), rel=0.12)
    assert np.mean(ses) < 0.5 * np.mean(unpaired)


def test_relaxation_time_of_hard_spheres_is_the_first_chapman_enskog_d():
    """Hard spheres of diameter sigma, impact parameters uniform over the disc of radius sigma:
    q = 1 - cos(chi) = 2 - 2 b^2/sigma^2, so <x q> = 2, and tau = m D_1 / kT with the closed form
    D_1 = 3 / (8 n sigma^2) sqrt(kT / (pi m)) (Chapman & Cowling).  Exactly with the population
    values, and within its standard error from 20,000 sampled courses."""
    sigma, m, kT, n = 0.2, 3.77, 1.25, 0.3
    area = math.pi * sigma ** 2
    tau_closed = (m / kT) * 3.0 / (8.0 * n * sigma ** 2) * math.sqrt(kT / (math.pi * m))
    tn, _ = cm.relaxation_time_n(np.full(10, 2.0), np.ones(10), kT, m, area)
    assert tn / n == pytest.approx(tau_closed, rel=1e-12)
    rng = np.random.default_rng(9)
    x, u = rng.gamma(2.0, 1.0, 20000), rng.uniform(size=20000)     # u = (b / sigma)^2
    tn, se = cm.relaxation_time_n(x, 2.0 - 2.0 * u, kT, m, area)
    assert abs(tn / n - tau_closed) < 3.0 * se / n
    assert 0.005 < se / tn < 0.02


@pytest.mark.parametrize("kind", ["dimer", "trimer_triangle", "tetrahedron"])
def test_case_states_follow_the_gas_study(kind):
    """Paired: exact's velocities, spins at the case's own equipartition (kT_c = kT_e m_c/m_e) axis
    by axis; equal energy: velocities scaled by sqrt(m_e/m_c); mass_scaled: mass and moments scaled
    alike (aspherical: the exact build's moments times moment_scale)."""
    shape = {"kind": kind, "sphere_diameter": 0.1333, "overlap": 0.5}
    props = shp.properties(shape, 1140.0)
    base = tc.make_pairs(shape, 50, 3)
    m_e = base["body"]["mass"]
    I_e = np.diag(props["exact"]["inertia"])
    v = np.asarray(base["vel"])
    ori = np.asarray(base["ori"]).reshape(-1, 3, 3)

    def body_energy_per_axis(inp, I):
        wb = np.einsum("nji,nj->ni", ori, np.asarray(inp["angvel"]))
        return 0.5 * I * np.sum(wb ** 2, axis=0)

    e_axis_e = body_energy_per_axis(base, I_e) / base["kT"]
    for case, prot in cm.CASES:
        inp, ktm = cm.case_input(base, shape, case, prot)
        m_c = inp["body"]["mass"]
        I_c = I_e * m_c / m_e if case == "mass_scaled" else np.diag(props[gm.CASE_SOURCES[case][1]]["inertia"])
        vc = np.asarray(inp["vel"])
        if prot == "paired":
            np.testing.assert_array_equal(vc, v)
            assert inp["kT"] == pytest.approx(base["kT"] * m_c / m_e, rel=1e-14)
            assert ktm == pytest.approx(1.0, rel=1e-14)
        else:
            assert 0.5 * m_c * np.sum(vc ** 2) == pytest.approx(0.5 * m_e * np.sum(v ** 2), rel=1e-12)
            assert ktm == pytest.approx(m_e / m_c, rel=1e-14)
        # each body axis carries the same energy over kT as in the exact case
        np.testing.assert_allclose(body_energy_per_axis(inp, I_c) / inp["kT"], e_axis_e, rtol=1e-12, atol=1e-12)
        if case == "mass_scaled":
            assert max(inp["body"]["moments"]) / m_c == pytest.approx(max(base["body"]["moments"]) / m_e, rel=1e-14)
            assert inp["body"]["builder"] == base["body"]["builder"]
            assert inp["body"]["moment_scale"] == pytest.approx(m_c / m_e, rel=1e-14)
        else:
            assert "moment_scale" not in inp["body"]
