"""studies/pair_correlation.py's statistics (python -m studies pair-correlation) on synthetic pairs
with a known correlation (no YADE)."""
import numpy as np
import pytest

from studies import pair_correlation as pc


def _pairs(rng, n, rho, sd_a, sd_b, ratio=1.10, d=15.0):
    z = rng.standard_normal((n, 2))
    za, zb = z[:, 0], rho * z[:, 0] + np.sqrt(1.0 - rho ** 2) * z[:, 1]
    return d * (1.0 + sd_a * za), ratio * d * (1.0 + sd_b * zb)


@pytest.mark.parametrize("rho", [0.0, 0.4])
def test_fisher_interval_covers_the_known_correlation_and_the_spreads_are_recovered(rho):
    """2,000 replicas of 16 seed pairs (the study's size), the case's D 10 % above exact: the 95 %
    Fisher-z interval covers the true rho in 93-97 % of them; pooled over replicas, each relative sd
    and the per-pair spread match their known values to 1.5 % (sd of b/a - 1 = 1.10 sqrt(sa^2 + sb^2
    - 2 rho sa sb) to first order; the pooled estimates' own error is about 0.4 %), and the
    uncorrelated spread is 1.10 sqrt(sa^2 + sb^2) whatever rho is."""
    rng = np.random.default_rng(12)
    sa, sb = 0.015, 0.02
    res = [pc.pair_stats(*_pairs(rng, 16, rho, sa, sb)) for _ in range(2000)]
    cover = np.mean([r["rho_low"] <= rho <= r["rho_high"] for r in res])
    assert 0.93 <= cover <= 0.97, cover

    def pooled(k):
        return np.sqrt(np.mean([r[k] ** 2 for r in res]))
    assert pooled("sd_exact") == pytest.approx(sa, rel=0.015)
    assert pooled("sd_case") == pytest.approx(sb, rel=0.015)
    assert pooled("sd_rel") == pytest.approx(1.10 * np.sqrt(sa ** 2 + sb ** 2 - 2 * rho * sa * sb), rel=0.015)
    assert pooled("sd_uncorrelated") == pytest.approx(1.10 * np.hypot(sa, sb), rel=0.015)


def test_pair_stats_refuses_too_few_or_unequal_samples():
    with pytest.raises(ValueError, match="at least 4 seeds"):
        pc.pair_stats([1.0, 2.0, 3.0], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="equal-length"):
        pc.pair_stats([1.0, 2.0, 3.0, 4.0, 5.0], [1.0, 2.0, 3.0, 4.0])
