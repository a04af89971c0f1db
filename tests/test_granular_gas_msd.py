"""The FFT mean-square displacement against the O(T^2) definition and closed forms."""

import numpy as np
import pytest

from studies.correlation import msd_bruteforce, msd_fft


@pytest.mark.parametrize("T,N", [(1, 3), (2, 1), (7, 4), (64, 5), (301, 9)])
def test_fft_equals_bruteforce_on_random_walks(T, N):
    rng = np.random.default_rng(T * 100 + N)
    x = np.cumsum(rng.normal(size=(T, N, 3)), axis=0) + rng.uniform(-50, 50, size=(1, N, 3))
    a, b = msd_fft(x), msd_bruteforce(x)
    assert a.shape == (T,)
    np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10)


def test_per_particle_groups_and_single_trajectory():
    rng = np.random.default_rng(1)
    x = np.cumsum(rng.normal(size=(50, 3, 3)), axis=0)
    mean, per_particle = msd_fft(x, groups=np.arange(3))
    assert per_particle.shape == (3, 50)
    for k in range(3):
        np.testing.assert_allclose(per_particle[k], msd_bruteforce(x[:, k]), rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(mean, per_particle.mean(axis=0), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(msd_fft(x[:, 0]), msd_bruteforce(x[:, 0]), rtol=1e-10, atol=1e-10)


def test_random_walk_msd_is_linear():
    # unit-variance steps in 3D: MSD(m) = 3 m on average
    rng = np.random.default_rng(2)
    x = np.cumsum(rng.normal(size=(2000, 400, 3)).astype(np.float32), axis=0)
    m = msd_fft(x)
    lags = np.arange(1, 200)
    np.testing.assert_allclose(m[lags] / (3 * lags), 1.0, atol=0.03)


def test_ballistic_closed_form():
    rng = np.random.default_rng(3)
    v = rng.normal(size=(20, 3))
    t = np.arange(100) * 0.25
    x = rng.uniform(0, 10, size=(20, 3)) + t[:, None, None] * v
    np.testing.assert_allclose(msd_fft(x), np.mean(np.sum(v ** 2, 1)) * t ** 2, rtol=1e-9, atol=1e-12)


def test_detects_a_wrong_trajectory():
    # must be able to fail: a wrapped (jumping) trajectory does not give the ballistic MSD
    v = np.array([[1.0, 0.0, 0.0]])
    t = np.arange(100) * 0.5
    x = t[:, None, None] * v
    wrapped = np.mod(x, 10.0)
    assert not np.allclose(msd_fft(wrapped), t ** 2, rtol=1e-3)
