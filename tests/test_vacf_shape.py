"""studies/vacf_shape.py's analysis (python -m studies vacf-shape) on autocorrelations with a known
shape (no simulation).

A single exponential has the same local decay time on every lag window; a mixture of two has one
that grows with the lag, to the value its closed form gives.  The jackknife over rows reproduces
the textbook standard error of a mean (the ratio of means: tests/test_estimators.py).
"""
import math

import numpy as np
import pytest

from studies import vacf_shape as vs

LAG = np.arange(601) * 0.25


def test_single_exponential_has_one_decay_time_on_every_window():
    c = 3.0 * np.exp(-LAG / 14.0)
    assert vs.local_decay_times(LAG, c, 14.0) == pytest.approx([14.0] * 4, rel=1e-10)


def test_mixture_of_two_rates_decays_more_slowly_at_long_lags():
    """C = w e^(-t/a) + (1 - w) e^(-t/b): the fitted slope on a window is close to the local
    -d ln C / dt at its middle (C is nearly log-linear on a window); both grow with the lag."""
    w, a, b = 0.6, 12.0, 18.0
    c = w * np.exp(-LAG / a) + (1 - w) * np.exp(-LAG / b)
    tau = 14.0
    got = vs.local_decay_times(LAG, c, tau)
    assert np.all(np.diff(got) > 0)

    def local(t):
        num = w * np.exp(-t / a) + (1 - w) * np.exp(-t / b)
        return num / (w / a * np.exp(-t / a) + (1 - w) / b * np.exp(-t / b))

    mids = [0.5 * (lo + hi) * tau for lo, hi in vs.WINDOWS]
    assert got == pytest.approx([local(t) for t in mids], rel=5e-4)


@pytest.mark.parametrize("bad", [-1e-3, 0.0, float("nan"), float("inf")])
def test_local_decay_times_refuse_a_vacf_that_is_not_finite_and_positive(bad):
    c = np.exp(-LAG / 14.0)
    c[20] = bad                                        # lag 5 s: inside 0-0.5 tau
    with pytest.raises(ValueError, match="not finite and positive"):
        vs.local_decay_times(LAG, c, 14.0)


def test_local_decay_times_refuse_windows_past_the_lags_or_too_short():
    c = np.exp(-LAG / 14.0)
    with pytest.raises(ValueError, match="past the largest lag"):
        vs.local_decay_times(LAG, c, 40.0)             # 4 tau = 160 s > 150 s
    with pytest.raises(ValueError, match="need >= 5"):
        vs.local_decay_times(LAG, c, 1.0)              # 0-0.5 s: 3 lags


def test_jackknife_of_a_mean_is_the_standard_error():
    rng = np.random.default_rng(3)
    x = rng.normal(2.0, 0.5, size=(40, 3))
    full, se = vs.jackknife(lambda m: m, x)
    assert full == pytest.approx(x.mean(axis=0), rel=1e-14)
    assert se == pytest.approx(x.std(axis=0, ddof=1) / math.sqrt(40), rel=1e-10)
