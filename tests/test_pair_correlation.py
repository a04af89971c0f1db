"""benchmarks/pair_correlation.py's statistics on synthetic pairs with a known correlation (no YADE)."""
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import pair_correlation as pc  # noqa: E402


def _pairs(rng, n, rho, sd_a=0.015, sd_b=0.02, d=15.0):
    z = rng.standard_normal((n, 2))
    za, zb = z[:, 0], rho * z[:, 0] + np.sqrt(1.0 - rho ** 2) * z[:, 1]
    return d * (1.0 + sd_a * za), 1.02 * d * (1.0 + sd_b * zb)


@pytest.mark.parametrize("rho", [0.0, 0.4])
def test_fisher_interval_covers_the_known_correlation_and_the_spreads_are_recovered(rho):
    """600 replicas of 16 seed pairs (the study's size): the 95 % Fisher-z interval covers the true
    rho in 93-97 % of them; pooled over replicas, each relative sd and the per-pair spread match
    their known values (sd of b/a - 1 = 1.02 sqrt(sa^2 + sb^2 - 2 rho sa sb) to first order)."""
    rng = np.random.default_rng(12)
    sa, sb = 0.015, 0.02
    res = [pc.pair_stats(*_pairs(rng, 16, rho, sa, sb)) for _ in range(600)]
    cover = np.mean([r["rho_low"] <= rho <= r["rho_high"] for r in res])
    assert 0.93 <= cover <= 0.97, cover
    assert np.sqrt(np.mean([r["sd_exact"] ** 2 for r in res])) == pytest.approx(sa, rel=0.03)
    assert np.sqrt(np.mean([r["sd_case"] ** 2 for r in res])) == pytest.approx(sb, rel=0.03)
    want = 1.02 * np.sqrt(sa ** 2 + sb ** 2 - 2 * rho * sa * sb)
    assert np.sqrt(np.mean([r["sd_rel"] ** 2 for r in res])) == pytest.approx(want, rel=0.03)
    assert np.sqrt(np.mean([r["sd_uncorrelated"] ** 2 for r in res])) == pytest.approx(np.hypot(sa, sb), rel=0.03)


def test_pair_stats_refuses_too_few_or_unequal_samples():
    with pytest.raises(ValueError, match="at least 4 seeds"):
        pc.pair_stats([1.0, 2.0, 3.0], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="equal-length"):
        pc.pair_stats([1.0, 2.0, 3.0, 4.0, 5.0], [1.0, 2.0, 3.0, 4.0])
