"""The two-temperature balance from binary collisions (studies/predict_hcs.py) on spheres, against
the rough-sphere HCS theory (studies/hcs_theory.py): Haff's cooling rate of smooth spheres, the
constant-beta closed forms, and Walton's Coulomb friction through the theory's own Monte Carlo."""
import math

import numpy as np
import pytest

from studies import hcs_theory as ht
from studies import predict_hcs as ph

DRAWS = ph.sphere_draws(200_000, seed=11)


def test_smooth_inelastic_spheres_cool_at_haffs_rate():
    zeta, se = ph.smooth_cooling(ht.constant_beta_rule(0.9, -1.0), DRAWS)
    haff = ht.haff_cooling_rate(0.9, 1.0, sonine=False)         # (1 - e^2) / 3 in units of omega
    assert abs(zeta - haff) < 4 * se
    assert se < 0.01 * haff


def test_smooth_cooling_rate_scales_with_one_minus_e_squared():
    z9, _ = ph.smooth_cooling(ht.constant_beta_rule(0.9, -1.0), DRAWS)
    z7, _ = ph.smooth_cooling(ht.constant_beta_rule(0.7, -1.0), DRAWS)
    assert z7 / z9 == pytest.approx((1 - 0.49) / (1 - 0.81), rel=1e-9)   # the same draws: exact ratio


def test_constant_beta_balance_matches_the_closed_forms():
    rule = ht.constant_beta_rule(0.9, 0.4)
    p = ph.hcs_balance(lambda r: ph.sphere_collisions(rule, 0.4, r, DRAWS))
    assert abs(p.ratio - ht.hcs_temperature_ratio(0.9, 0.4, 0.4)) < 4 * p.ratio_se
    assert abs(p.zeta_over_omega - ht.hcs_cooling_rate(0.9, 0.4, 0.4, 1.0)) < 4 * p.zeta_over_omega_se


def test_walton_friction_balance_matches_the_theory_within_both_monte_carlo_errors():
    rule = ht.walton_rule(0.9, 0.5, 0.4)
    p = ph.hcs_balance(lambda r: ph.sphere_collisions(rule, 0.4, r, DRAWS))
    theory = np.array([ht.hcs_ratio_for_rule(rule, 0.4, size=200_000, seed=s) for s in (1, 2, 3)])
    t_mean, t_se = theory.mean(0), theory.std(0, ddof=1) / math.sqrt(len(theory))
    assert abs(p.ratio - t_mean[0]) < 4 * math.hypot(p.ratio_se, t_se[0])
    assert abs(p.zeta_over_omega - t_mean[1]) < 4 * math.hypot(p.zeta_over_omega_se, t_se[1])
    assert 0.5 < p.ratio < 1.0 and p.ratio_se < 0.01 * p.ratio


def test_elastic_perfectly_rough_spheres_share_energy_equally():
    rule = ht.constant_beta_rule(1.0, 1.0)
    p = ph.hcs_balance(lambda r: ph.sphere_collisions(rule, 0.4, r, DRAWS))
    assert p.ratio == pytest.approx(1.0, abs=4 * p.ratio_se)
    assert abs(p.zeta_over_omega) < 4 * p.zeta_over_omega_se + 1e-12
