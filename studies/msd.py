"""Mean-square displacement with time-origin averaging, O(T log T) by FFT.

For a trajectory x_0 .. x_{T-1} (unwrapped) the time-origin averaged MSD at lag m is

    MSD(m) = 1/(T-m) sum_{k=0}^{T-m-1} |x_{k+m} - x_k|^2
           = S1(m) - 2 S2(m),

with S2(m) = 1/(T-m) sum_k x_k . x_{k+m} (an autocorrelation, by FFT with zero padding
to 2T) and S1(m) = 1/(T-m) sum_{k=0}^{T-m-1} (|x_k|^2 + |x_{k+m}|^2)
(Calandrini, Pellegrini, Calligari, Hinsen, Kneller, Ecole thematique SFN 12 (2011) 201,
the nMoldyn algorithm), here as a cumulative sum.  ``msd_bruteforce`` is the O(T^2) definition for tests.
"""
from __future__ import annotations

import numpy as np


def _autocorr(x):
    """sum_k x_k x_{k+m} for m = 0..T-1 of every column of x (T, K), summed over columns."""
    T = x.shape[0]
    n = 1 << int(np.ceil(np.log2(2 * T)))
    y = np.ascontiguousarray(x.T)             # FFT along the contiguous axis: ~2x faster
    f = np.fft.rfft(y, n=n, axis=1)
    return np.fft.irfft(f.real ** 2 + f.imag ** 2, n=n, axis=1)[:, :T]


def msd_fft(x, per_particle=False):
    """Time-origin averaged MSD of unwrapped positions ``x`` (T, N, 3) or (T, 3).

    Returns (T,) averaged over particles (or (T, N) with ``per_particle``); entry m is the
    lag of m frames (frames must be evenly spaced).  Works in float64 whatever the input.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 2:
        x = x[:, None, :]
    T, N = x.shape[:2]
    x = x - x[0]                              # translation invariant; improves round-off
    d = np.sum(x ** 2, axis=-1)               # (T, N)
    # S1(m) = [sum_{k<T-m} d_k + sum_{k>=m} d_k] / (T-m), from one cumulative sum
    C = np.concatenate([np.zeros((1, N)), np.cumsum(d, axis=0)])
    m = np.arange(T)
    counts = (T - m)[:, None]
    s1 = (C[T - m] + (C[T] - C[m])) / counts
    s2 = _autocorr(x.reshape(T, 3 * N)).reshape(N, 3, T).sum(axis=1).T / counts
    out = s1 - 2.0 * s2
    out[0] = 0.0
    out = np.maximum(out, 0.0)
    return out if per_particle else out.mean(axis=1)


def msd_bruteforce(x):
    """O(T^2) time-origin averaged MSD, the definition (for tests)."""
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 2:
        x = x[:, None, :]
    T = x.shape[0]
    out = np.zeros(T)
    for m in range(1, T):
        out[m] = np.mean(np.sum((x[m:] - x[:-m]) ** 2, axis=-1))
    return out

