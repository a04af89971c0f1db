"""Time-origin averaged correlation functions of trajectories, by FFT: the VACF and the MSD.

Small pure functions (numpy/scipy only, no I/O) in the manner of tidynamics: one velocity
autocorrelation (:func:`vacf_fft`) and one mean-square displacement (:func:`msd_fft`), each
optionally per disjoint particle group (:func:`group_labels`, for per-run jackknife errors), and
their O(T^2) definitions for tests (:func:`vacf_bruteforce`, :func:`msd_bruteforce`).

For a trajectory x_0 .. x_{T-1} (unwrapped) the time-origin averaged MSD at lag m is

    MSD(m) = 1/(T-m) sum_{k=0}^{T-m-1} |x_{k+m} - x_k|^2 = S1(m) - 2 S2(m),

with S2(m) = 1/(T-m) sum_k x_k . x_{k+m} (an autocorrelation, by FFT with zero padding) and
S1(m) = 1/(T-m) sum_{k=0}^{T-m-1} (|x_k|^2 + |x_{k+m}|^2), here as a cumulative sum
(Calandrini, Pellegrini, Calligari, Hinsen, Kneller, Ecole thematique SFN 12 (2011) 201, the
nMoldyn algorithm).  Units: whatever the input's (m and m/s in the gas study).
"""
from __future__ import annotations

import numpy as np
from scipy import fft as sfft

__all__ = ["group_labels", "vacf_fft", "vacf_bruteforce", "msd_fft", "msd_bruteforce"]


def group_labels(n_particles, n_groups=16):
    """Group index (0..G-1) of every particle: G contiguous, near-equal blocks of indices.

    The engine splits particles "by index" this way (``np.array_split`` sizes: the first
    ``n % G`` groups have one particle more).  864 particles / 16 groups = 54 each.
    """
    if n_groups < 1 or n_groups > n_particles:
        raise ValueError(f"n_groups must be in 1..{n_particles}, got {n_groups}")
    sizes = [len(a) for a in np.array_split(np.arange(n_particles), n_groups)]
    return np.repeat(np.arange(n_groups), sizes)


def _labels(N, groups):
    if groups is None:
        return np.zeros(N, dtype=int), 1
    labels = group_labels(N, groups) if np.isscalar(groups) else np.asarray(groups, int)
    if labels.shape != (N,) or labels.min() < 0:
        raise ValueError("groups must be an int or (N,) labels 0..G-1")
    G = int(labels.max()) + 1
    if np.any(np.bincount(labels, minlength=G) == 0):
        raise ValueError("every group needs at least one particle")
    return labels, G


def _group_autocorr(a, L, labels, G):
    """sum over the particles of each group and the last axis of sum_k a_k . a_{k+m}, m < L.

    ``a`` (T, N, K) float64; returns (G, L).  FFT along time with zero padding to T + L
    (enough for lags < L), power spectra summed per group before one inverse transform each.
    """
    T, N, K = a.shape
    n = sfft.next_fast_len(T + L, real=True)
    spec = np.zeros((G, n // 2 + 1))
    chunk = max(1, int(4e6 // (n * K)))          # bound memory: ~64 MB of spectra at a time
    for s in range(0, N, chunk):
        y = np.ascontiguousarray(a[:, s:s + chunk, :].transpose(1, 2, 0))   # (n_c, K, T)
        f = sfft.rfft(y, n=n, axis=-1)
        p = (f.real ** 2 + f.imag ** 2).sum(axis=1)                        # (n_c, n//2+1)
        lab = labels[s:s + chunk]
        onehot = (lab[None, :] == np.arange(G)[:, None]).astype(np.float64)
        spec += onehot @ p
    return sfft.irfft(spec, n=n, axis=-1)[:, :L]


def _trajectories(a, name):
    """``a`` as float64 (T, N, 3); a (T, 3) array is one particle's trajectory."""
    out = np.asarray(a, dtype=np.float64)
    if out.ndim == 2:
        out = out[:, None, :]
    if out.ndim != 3:
        raise ValueError(f"{name} must be (T, N, 3) or (T, 3), got shape {np.shape(a)}")
    return out


def vacf_fft(vel, max_lag_frames, groups=None):
    """Time-origin and particle averaged velocity autocorrelation, by FFT.

    ``vel``: (T, N, 3) velocities in m/s at T evenly spaced frames (or (T, 3) for one
    particle).  Returns ``C`` (L,) with L = min(max_lag_frames, T-1) + 1 and

        C[m] = 1/N sum_i 1/(T-m) sum_{k=0}^{T-m-1} v_i(k) . v_i(k+m)     (m^2/s^2),

    i.e. the mean over particles of the time-origin average (no mean subtraction: the
    gas's total momentum is zero).  With ``groups`` (an int G: :func:`group_labels`, or an
    (N,) array of labels 0..G-1) returns ``(C, C_groups)`` with ``C_groups`` (G, L) the same
    average over the particles of each group; ``C`` is the particle-weighted mean of the
    groups.  Cost O(N T log T).
    """
    v = _trajectories(vel, "vel")
    T, N, _ = v.shape
    if T < 2:
        raise ValueError("need at least 2 frames")
    L = int(min(max_lag_frames, T - 1)) + 1
    labels, G = _labels(N, groups)
    s = _group_autocorr(v, L, labels, G) / (T - np.arange(L))
    counts = np.bincount(labels, minlength=G)
    c = s.sum(axis=0) / N
    return c if groups is None else (c, s / counts[:, None])


def msd_fft(pos, max_lag_frames=None, groups=None):
    """Time-origin averaged mean-square displacement of unwrapped positions, by FFT.

    ``pos``: (T, N, 3) positions (m) at T evenly spaced frames (or (T, 3) for one particle).
    Returns ``msd`` (L,) averaged over particles, entry m the lag of m frames, for lags
    0..L-1 with L = T (``max_lag_frames`` None) or min(max_lag_frames, T-1) + 1.  With
    ``groups`` (an int G: :func:`group_labels`, or (N,) labels 0..G-1; ``np.arange(N)`` gives
    one group per particle) returns ``(msd, msd_groups)`` with ``msd_groups`` (G, L) the same
    average over the particles of each group.  Works in float64 whatever the input; round-off
    below 0 is clipped to 0.  Cost O(N T log T), zero padding to T + L only.
    """
    x = _trajectories(pos, "pos")
    T, N, _ = x.shape
    L = T if max_lag_frames is None else int(min(max_lag_frames, T - 1)) + 1
    labels, G = _labels(N, groups)
    x = x - x[0]                                                  # translation invariant; improves round-off
    sq = np.sum(x ** 2, axis=-1)                                  # (T, N)
    onehot = (labels[None, :] == np.arange(G)[:, None]).astype(np.float64)
    sq_groups = sq @ onehot.T                                     # (T, G)
    # S1(m) = [sum_{k<T-m} |x_k|^2 + sum_{k>=m} |x_k|^2] / (T-m), from one cumulative sum
    cum = np.concatenate([np.zeros((1, G)), np.cumsum(sq_groups, axis=0)])
    lags = np.arange(L)
    s1 = ((cum[T - lags] + (cum[T] - cum[lags])) / (T - lags)[:, None]).T      # (G, L)
    s2 = _group_autocorr(x, L, labels, G) / (T - lags)
    sums = np.maximum(s1 - 2.0 * s2, 0.0)
    sums[:, 0] = 0.0
    msd = sums.sum(axis=0) / N
    return msd if groups is None else (msd, sums / np.bincount(labels, minlength=G)[:, None])

def vacf_bruteforce(vel, max_lag_frames):
    """O(T^2) definition of :func:`vacf_fft` (for tests)."""
    v = np.asarray(vel, dtype=np.float64)
    if v.ndim == 2:
        v = v[:, None, :]
    T = v.shape[0]
    L = int(min(max_lag_frames, T - 1)) + 1
    return np.array([np.mean(np.sum(v[m:] * v[:T - m], axis=-1)) for m in range(L)])


def msd_bruteforce(pos):
    """O(T^2) definition of :func:`msd_fft` (for tests): (T,) averaged over particles."""
    x = np.asarray(pos, dtype=np.float64)
    if x.ndim == 2:
        x = x[:, None, :]
    T = x.shape[0]
    out = np.zeros(T)
    for m in range(1, T):
        out[m] = np.mean(np.sum((x[m:] - x[:-m]) ** 2, axis=-1))
    return out
