"""Equilibration of a gas run: when the rotational share of kinetic energy settles at
equipartition (:func:`detect_equilibration`).  Pure numpy/scipy.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import stats

__all__ = ["detect_equilibration"]


def detect_equilibration(t, rot_share, target, block_s=None, late_fraction=0.5, alpha=0.05, n_batches=5):
    """First time after which the rotational share of kinetic energy stays at equipartition.

    ``t`` (T,) s, evenly spaced; ``rot_share`` (T,) = E_rot / (E_rot + E_trans);
    ``target`` = equipartition share (2/5 = 0.4 for frictionless two-sphere clumps, whose
    axial spin is conserved: 3 translational + 2 rotational quadratic degrees of freedom;
    3/6 = 0.5 for clumps with three active rotational degrees of freedom).

    Method.  The equilibrium fluctuation ``sd`` is the standard deviation of the frames in
    the last ``late_fraction`` of the run (about their mean).  The series is cut into
    consecutive blocks of ``block_s`` seconds (default: run length / 40, >= 2 frames); a
    block is "in" when |block mean - target| <= band = k sd, k = z_{1 - alpha / (2 n_blocks)}
    (Bonferroni over the blocks; the frame sd bounds the block-mean sd, so an equilibrated
    series has a chance <= alpha of any block falsely "out", even when the share's
    fluctuations are correlated over many blocks, as in the gas: ~28 s).  The cut is the
    start of the first block from which every later block is "in".

    ``ok`` is True when (1) a cut exists, (2) it lies before the late part (so the fluctuation
    was measured on equilibrated data) and (3) the late mean agrees with ``target``:
    |late mean - target| <= t_{nb-1, 0.995} SE, SE from ``n_batches`` batch means of the late
    part (robust to the correlation).  A wrong ``target`` (e.g. 0.5 for a dimer) or a run
    that has not relaxed gives ``ok`` False.

    Returns a dict: ``t_cut`` (s; nan if the last block is out), ``ok``, ``late_mean``,
    ``late_mean_se``, ``sd`` (frame sd, late part), ``band``, ``k``, ``block_s``,
    ``block_t`` (block start times), ``block_mean``.  Note: at the cut the transient is still
    up to ``band`` (~3 sd) from the target by construction; it keeps decaying afterwards.
    """
    t = np.asarray(t, dtype=np.float64)
    y = np.asarray(rot_share, dtype=np.float64)
    if t.ndim != 1 or y.shape != t.shape or len(t) < 8:
        raise ValueError("t and rot_share must be (T,) with T >= 8")
    if not np.all(np.isfinite(y)):
        raise ValueError("rot_share has non-finite values")
    dt = float(np.median(np.diff(t)))
    span = t[-1] - t[0] + dt
    if block_s is None:
        block_s = span / 40.0
    b = max(2, int(round(block_s / dt)))
    nb = len(t) // b
    if nb < 6:
        raise ValueError(f"only {nb} blocks of {b} frames; use shorter blocks")
    means = y[: nb * b].reshape(nb, b).mean(axis=1)
    starts = t[: nb * b: b]
    i_late = int(round((1 - late_fraction) * len(y)))
    late = y[i_late:]
    t_late = float(t[i_late])
    sd = float(np.std(late, ddof=1))
    late_mean = float(late.mean())
    nbat = max(2, min(n_batches, len(late) // 2))
    bm = late[: len(late) // nbat * nbat].reshape(nbat, -1).mean(axis=1)
    late_se = float(np.std(bm, ddof=1) / math.sqrt(nbat))
    k = float(stats.norm.ppf(1 - alpha / (2 * nb)))
    band = k * sd
    inside = np.abs(means - target) <= band
    if not inside[-1]:
        t_cut = float("nan")
    else:
        out = np.nonzero(~inside)[0]
        t_cut = float(starts[out[-1] + 1]) if len(out) else float(starts[0])
    agree = abs(late_mean - target) <= float(stats.t.ppf(0.995, nbat - 1)) * late_se + 1e-15
    ok = bool(np.isfinite(t_cut) and t_cut <= t_late + 1e-9 and agree)
    return dict(t_cut=t_cut, ok=ok, late_mean=late_mean, late_mean_se=late_se, sd=sd, band=band,
                k=k, block_s=b * dt, block_t=starts, block_mean=means)
