"""The homogeneous-cooling-state theory (studies/hcs_theory.py) against independent routes.

The closed forms (Haff's law, the rough-sphere coefficients A, B, C, the velocity relaxation rate)
come from Maxwellian integrals done by hand; they are checked here against a Monte Carlo average
of the collision rule itself over sampled pairs, against numerical integration of the cooling
equations, and against the conservation laws of a single collision.
"""
import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

from studies import hcs_theory as hcs

CASES = [(0.9, -1.0, 0.4), (0.9, 0.5, 0.4), (1.0, 1.0, 0.4), (0.8, 0.0, 0.25), (0.7, -0.6, 0.6)]


def _random_pairs(rng, k=2000):
    v1, v2, w1, w2 = (rng.standard_normal((k, 3)) for _ in range(4))
    n = rng.standard_normal((k, 3))
    return v1, v2, w1, w2, n / np.linalg.norm(n, axis=1)[:, None]


@pytest.mark.parametrize("e, beta, kappa", CASES)
def test_one_collision_conserves_momentum_and_angular_momentum_and_restitutes_the_contact_velocity(e, beta, kappa):
    m, sigma = 2.0, 0.3
    a, inertia = sigma / 2, kappa * m * sigma ** 2 / 4
    v1, v2, w1, w2, n = _random_pairs(np.random.default_rng(3))
    v1n, v2n, w1n, w2n, g_n = hcs.collide(v1, v2, w1, w2, n, hcs.constant_beta_rule(e, beta), kappa, m, sigma)
    hit = g_n > 0
    assert hit.sum() > 500
    np.testing.assert_allclose(m * (v1n + v2n), m * (v1 + v2), atol=1e-12)
    # angular momentum about sphere 1's centre (sphere 2 at sigma n)
    ang = lambda u1, u2, o1, o2: m * np.cross(sigma * n, u2) + inertia * (o1 + o2)
    np.testing.assert_allclose(ang(v1n, v2n, w1n, w2n), ang(v1, v2, w1, w2), atol=1e-12)
    g = lambda u1, u2, o1, o2: u1 - u2 + a * np.cross(o1 + o2, n)
    g0, g1 = g(v1, v2, w1, w2)[hit], g(v1n, v2n, w1n, w2n)[hit]
    nn = n[hit]
    gn0, gn1 = np.einsum("ij,ij->i", g0, nn), np.einsum("ij,ij->i", g1, nn)
    np.testing.assert_allclose(gn1, -e * gn0, atol=1e-12)
    np.testing.assert_allclose(g1 - gn1[:, None] * nn, -beta * (g0 - gn0[:, None] * nn), atol=1e-12)
    untouched = ~hit
    np.testing.assert_array_equal(v1n[untouched], v1[untouched])


@pytest.mark.parametrize("e, beta, kappa", CASES)
@pytest.mark.parametrize("t_tr, t_rot", [(1.0, 1.0), (1.0, 0.3), (0.5, 2.0)])
def test_monte_carlo_collision_averages_match_the_maxwellian_closed_forms(e, beta, kappa, t_tr, t_rot):
    """<dE_tr> = 4 (-A T_tr + B T_rot), <dE_rot> = 4 (B T_tr - C T_rot), <dv1.v1> = -2 (T/m)((1+e)/2 + eta)."""
    m = 1.7
    avg = hcs.collision_averages(hcs.constant_beta_rule(e, beta), t_tr, t_rot, kappa, m=m, size=100_000,
                                 rng=np.random.default_rng(11))
    a, b, c = hcs.rough_coefficients(e, beta, kappa)
    eta = kappa * (1 + beta) / (2 * (1 + kappa))
    checks = [(avg.d_e_tr, avg.d_e_tr_se, 4 * (-a * t_tr + b * t_rot)),
              (avg.d_e_rot, avg.d_e_rot_se, 4 * (b * t_tr - c * t_rot)),
              (avg.d_v_dot_v, avg.d_v_dot_v_se, -2 * t_tr / m * ((1 + e) / 2 + eta))]
    for got, se, want in checks:
        assert abs(got - want) <= 4.5 * se + 1e-12, (got, want, se)


def test_a_perfectly_rough_elastic_gas_keeps_its_energy_and_equipartitions():
    assert hcs.hcs_temperature_ratio(1.0, 1.0, 0.4) == pytest.approx(1.0, rel=1e-14)
    v1, v2, w1, w2, n = _random_pairs(np.random.default_rng(5))
    kappa, m, sigma = 0.4, 1.0, 1.0
    inertia = kappa * m * sigma ** 2 / 4
    out = hcs.collide(v1, v2, w1, w2, n, hcs.constant_beta_rule(1.0, 1.0), kappa, m, sigma)
    energy = lambda u1, u2, o1, o2: 0.5 * m * ((u1 ** 2).sum(1) + (u2 ** 2).sum(1)) + 0.5 * inertia * ((o1 ** 2).sum(1) + (o2 ** 2).sum(1))
    np.testing.assert_allclose(energy(*out[:4]), energy(v1, v2, w1, w2), rtol=1e-12)


def test_haff_law_solves_the_smooth_cooling_equation():
    n, sigma, m, t0, e = 2e3, 0.01, 1e-3, 1e-6, 0.9
    zeta = lambda t: hcs.haff_cooling_rate(e, hcs.enskog_frequency(n, sigma, m, t))
    tau0 = 2.0 / zeta(t0)
    sol = solve_ivp(lambda _, y: [-zeta(y[0]) * y[0]], (0, 20 * tau0), [t0], rtol=1e-11, atol=0, dense_output=True)
    times = np.linspace(0, 20 * tau0, 9)
    np.testing.assert_allclose(hcs.haff_temperature(times, t0, tau0), sol.sol(times)[0], rtol=1e-8)


@pytest.mark.parametrize("e, beta, kappa", [c for c in CASES if c[1] > -1.0])
def test_the_two_temperature_equations_relax_to_the_hcs_ratio_and_cooling_rate(e, beta, kappa):
    a, b, c = hcs.rough_coefficients(e, beta, kappa)

    def rhs(_, y):
        # in the collision-counting time s (ds = G sqrt(T_tr) dt), where the HCS is reached at finite s
        r = math.exp(y[1] - y[0])
        return [-(a - b * r), b / r - c]

    sol = solve_ivp(rhs, (0, 3000), np.log([1.0, 1e-3]), rtol=1e-11, atol=1e-12, method="LSODA")
    ratio = math.exp(sol.y[1, -1] - sol.y[0, -1])
    assert ratio == pytest.approx(hcs.hcs_temperature_ratio(e, beta, kappa), rel=1e-6)
    # -d ln T_tr/dt = G sqrt(T_tr) (A - B r), with G sqrt(T_tr) = (4/3) omega
    assert -rhs(0, sol.y[:, -1])[0] * 4 / 3 == pytest.approx(hcs.hcs_cooling_rate(e, beta, kappa, 1.0), rel=1e-6)


def test_monte_carlo_hcs_ratio_of_a_constant_rule_matches_the_closed_form():
    """Four independent seeds: the mean within 4 standard errors of the seeds' spread."""
    for e, beta, kappa in [(0.9, 0.5, 0.4), (0.8, 0.0, 0.25)]:
        runs = np.array([hcs.hcs_ratio_for_rule(hcs.constant_beta_rule(e, beta), kappa, size=100_000, seed=s)
                         for s in range(4)])
        mean, se = runs.mean(axis=0), runs.std(axis=0, ddof=1) / 2.0
        want = [hcs.hcs_temperature_ratio(e, beta, kappa), hcs.hcs_cooling_rate(e, beta, kappa, 1.0)]
        assert np.all(np.abs(mean - want) <= 4 * se), (mean, se, want)
        assert np.all(se < 0.02 * np.abs(mean))   # the check has teeth: 4 se is under 8 %


def test_walton_rule_limits_are_the_smooth_and_the_constant_beta_rules():
    rng = np.random.default_rng(7)
    pairs = _random_pairs(rng)
    kappa = 0.4
    smooth = hcs.collide(*pairs, hcs.walton_rule(0.9, 0.0, 0.4), kappa)
    sticky = hcs.collide(*pairs, hcs.walton_rule(0.9, 1e9, 0.4), kappa)
    for got, want in zip(smooth[:4], hcs.collide(*pairs, hcs.constant_beta_rule(0.9, -1.0), kappa)[:4]):
        np.testing.assert_allclose(got, want, atol=1e-12)
    for got, want in zip(sticky[:4], hcs.collide(*pairs, hcs.constant_beta_rule(0.9, 0.4), kappa)[:4]):
        np.testing.assert_allclose(got, want, atol=1e-12)
    # Coulomb's law: a sliding impact's tangential impulse is mu times its normal impulse
    mu = 0.1
    v1, v2, w1, w2, n = pairs
    v1n, _, _, _, g_n = hcs.collide(*pairs, hcs.walton_rule(0.9, mu, 0.4), kappa)
    p = v1n - v1
    hit = g_n > 0
    p_n = np.einsum("ij,ij->i", p, n)
    p_t = np.linalg.norm(p - p_n[:, None] * n, axis=1)
    assert np.all(p_t[hit] <= mu * np.abs(p_n[hit]) * (1 + 1e-9))
    assert np.mean(np.isclose(p_t[hit], mu * np.abs(p_n[hit]), rtol=1e-9)) > 0.5


def test_elastic_smooth_diffusion_is_the_chapman_enskog_first_approximation():
    n, sigma, m, t = 1e4, 2e-3, 3e-5, 4e-9
    omega = hcs.enskog_frequency(n, sigma, m, t)
    d = hcs.hcs_diffusion(t, m, hcs.velocity_relaxation_rate(1.0, -1.0, 0.4, omega), 0.0)
    assert d == pytest.approx(3.0 / (8.0 * n * sigma ** 2) * math.sqrt(t / (math.pi * m)), rel=1e-12)


def test_hcs_msd_integrates_the_time_dependent_diffusion_coefficient():
    n, sigma, m, t0, e, beta, kappa = 2e3, 0.01, 1e-3, 1e-6, 0.9, 0.5, 0.4
    omega0 = hcs.enskog_frequency(n, sigma, m, t0)
    zeta0 = hcs.hcs_cooling_rate(e, beta, kappa, omega0)
    tau0 = 2.0 / zeta0

    def d_of_t(t):
        t_tr = hcs.haff_temperature(t, t0, tau0)
        omega = hcs.enskog_frequency(n, sigma, m, t_tr)
        return hcs.hcs_diffusion(t_tr, m, hcs.velocity_relaxation_rate(e, beta, kappa, omega),
                                 hcs.hcs_cooling_rate(e, beta, kappa, omega))

    d0 = d_of_t(0.0)
    for t in (0.3 * tau0, 5 * tau0):
        assert 6 * quad(d_of_t, 0, t, epsabs=0, epsrel=1e-11)[0] == pytest.approx(hcs.hcs_msd(t, d0, tau0), rel=1e-9)


def test_sonine_a2_vanishes_for_elastic_spheres_and_changes_sign_at_one_over_root_two():
    assert hcs.sonine_a2(1.0) == 0.0
    assert hcs.sonine_a2(2 ** -0.5) == pytest.approx(0.0, abs=1e-15)
    assert hcs.sonine_a2(0.9) < 0 < hcs.sonine_a2(0.5)


def test_smooth_spheres_have_no_hcs_temperature_ratio():
    with pytest.raises(ValueError, match="smooth"):
        hcs.hcs_temperature_ratio(0.9, -1.0, 0.4)
