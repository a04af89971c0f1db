"""Statistics across runs: Student-t intervals, the paired ratio of means, Fieller's interval.

Seeds are the study's independent units: a Student-t interval over per-run D
(:func:`t_interval`), over per-seed differences for paired cases, and Fieller's interval for a
ratio of two independent means (:func:`fieller_ratio`, :func:`fieller_from_means`).  Pure
functions (numpy/scipy only).
"""
from __future__ import annotations

import math

import numpy as np
from scipy import stats

__all__ = ["t_quantile", "t_interval", "ratio_of_means", "fieller_ratio", "fieller_from_means"]


def t_quantile(conf, dof):
    """Two-sided Student-t quantile: t_{dof, 1/2 + conf/2} (1.96... for conf = 0.95 at large dof)."""
    return float(stats.t.ppf(0.5 + conf / 2, dof))


def ratio_of_means(a, b):
    """Paired ratio of means: (mean(a)/mean(b) - 1, its delta-method standard error).

    ``a``, ``b`` (n,) paired samples (run i gives a[i] and b[i]); the error is
    r sd(a/mean(a) - b/mean(b)) / sqrt(n) with r = mean(a)/mean(b), i.e. sd(a - r b) / (sqrt(n) mean(b)).
    Unlike the mean of per-pair ratios it carries no bias from a noisy denominator."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape or a.ndim != 1 or len(a) < 2:
        raise ValueError("a and b must be paired 1-D samples of at least 2")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))) or b.mean() == 0:
        raise ValueError("a and b must be finite, and mean(b) non-zero")
    r = a.mean() / b.mean()
    return float(r - 1.0), float(np.std(a - r * b, ddof=1) / math.sqrt(len(a)) / abs(b.mean()))


def t_interval(x, conf=0.95):
    """(mean, low, high, stderr, n) of a sample with a Student-t interval (n-1 dof).

    The study's published interval: x = per-seed D of a case, or per-seed differences
    D_case - D_exact of paired runs.
    """
    x = np.asarray(x, dtype=np.float64)
    n = len(x)
    if n == 0:
        return (np.nan,) * 4 + (0,)
    m = float(np.mean(x))
    if n < 2:
        return m, np.nan, np.nan, np.nan, n
    se = float(np.std(x, ddof=1) / np.sqrt(n))
    h = t_quantile(conf, n - 1) * se
    return m, m - h, m + h, se, n


def fieller_ratio(a, b, conf=0.95):
    """(theta, low, high, dof, n_a, n_b): theta = mean(a) / mean(b) of two independent samples, with
    Fieller's interval {theta : (mean(a) - theta mean(b))^2 <= q^2 (se_a^2 + theta^2 se_b^2)},
    q the Student-t quantile at the Welch-Satterthwaite dof of mean(a) - theta mean(b) at theta-hat.

    For the paper's "about 10 %": a = per-seed D_uncorrected/D_exact - 1 (paired runs), b = per-seed
    D_spheres/D_exact - 1 (other paired runs); seeds are the independent units of each.  When
    mean(b) is not resolved from 0 (mean(b)^2 <= q^2 se_b^2) the set is unbounded: low and high
    are NaN.  Coverage on normal samples of the study's sizes: tests/test_estimators.py.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    na, nb = len(a), len(b)
    if na < 2 or nb < 2:
        raise ValueError(f"fieller_ratio needs at least 2 values in each sample (got {na} and {nb})")
    th, lo, hi, dof = fieller_from_means(float(a.mean()), float(a.var(ddof=1)) / na, na - 1,
                                         float(b.mean()), float(b.var(ddof=1)) / nb, nb - 1, conf)
    return th, lo, hi, dof, na, nb


def fieller_from_means(ma, va, dfa, mb, vb, dfb, conf=0.95, dof=None):
    """(theta, low, high, dof): :func:`fieller_ratio` from two independent means ma, mb, the
    variances of those means va, vb and their degrees of freedom dfa, dfb (> 0; the sample
    size - 1 of a mean over seeds, or of a Monte Carlo estimate over independent chains).
    ``dof``: the Student-t degrees of freedom to use; None: Welch-Satterthwaite at theta-hat.

    For the sphere gas: a = the mean D over runs, b = the kinetic theory's Monte Carlo D with its
    standard error over n_chains independent chains (``studies.kinetic.d_boltzmann``), so the
    interval of D_measured / D_theory carries both errors.  There ``dof = dfa``: the theory's
    variance, from 1,999 dof, is as good as known, and Welch-Satterthwaite's dof, which grow when
    a known variance is added, under-cover with few runs (94.1-94.3 % at 4 runs; tests/test_estimators.py).
    """
    if not all(math.isfinite(x) for x in (ma, va, mb, vb)):
        raise ValueError(f"need finite means and variances, got ma={ma}, va={va}, mb={mb}, vb={vb}")
    if not (dfa > 0 and dfb > 0 and va >= 0 and vb >= 0 and (dof is None or dof > 0)):
        raise ValueError(f"need dof > 0 and variances >= 0, got dfa={dfa}, dfb={dfb}, va={va}, vb={vb}, dof={dof}")
    if mb == 0.0:
        return np.nan, np.nan, np.nan, np.nan
    th = ma / mb
    if dof is None:
        num = (va + th * th * vb) ** 2
        den = va * va / dfa + (th * th * vb) ** 2 / dfb
        dof = num / den if den > 0 else float(min(dfa, dfb))
    q2 = t_quantile(conf, dof) ** 2
    A = mb * mb - q2 * vb
    B = ma * mb
    C = ma * ma - q2 * va
    disc = B * B - A * C
    if -1e-12 * B * B <= disc < 0:       # zero variances: the set is the point theta, up to round-off
        disc = 0.0
    if A <= 0 or disc < 0:
        return th, np.nan, np.nan, dof
    r = np.sqrt(disc)
    return th, (B - r) / A, (B + r) / A, dof
