"""The setting each sampled method needs to reach a tolerance, with 95 % probability, and its cost.

The error of a method is the largest relative error of the mass and of the three principal
moments against the exact values.

* Monte Carlo (LIGGGHTS): the standard error of each quantity is ``s / sqrt(ntry)`` with the
  per-point relative standard deviation ``s`` measured in the default run, so
  ``ntry = (z s / tol)^2`` for the worst quantity, z = 2.50 so that all four quantities are
  within the tolerance together with probability >= 95 % (Bonferroni).  A bias that sampling does not remove
  (LIGGGHTS 3.8.0's Iyz) makes a tolerance below it unreachable.
* YADE voxel: deterministic; the error is computed at discretization 5, 10, 20, ... until it
  is within the tolerance (up to ``max_cells`` grid cells).
* Halton quasi-Monte Carlo: the root-mean-square error over scrambles is measured at increasing
  N, its largest five fitted as ``a N^-b`` on a log-log scale, and N chosen so that ``2.50 rms <= tol``.  The
  error is that of the estimated diagonal; when the file's frame is not principal, DEME's
  diagonal also carries the frame error, which no N removes (reported as ``frame_error``).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import List, Optional

import numpy as np

from . import methods

Z95 = 1.959963984540054  # two-sided 95 % normal quantile
#: The two-sided normal quantile that keeps four quantities (mass, three moments) within their
#: bounds together with probability >= 95 % (Bonferroni: 1.25 % per side and quantity).
Z_JOINT = 2.4977054744123026
VOXEL_LADDER = (5, 10, 20, 40, 80, 160, 320, 640)
QMC_LADDER = tuple(2 ** k for k in range(8, 16))
QMC_FIT_POINTS = 5  # the largest N of the ladder enter the fit (the asymptotic rate)
QMC_SCRAMBLES = 6


@dataclass
class Advice:
    """The setting a method needs for one tolerance.

    Parameters
    ----------
    method : str
        The method's name.
    tolerance : float
        The relative tolerance (e.g. 0.01).
    setting : int or None
        ``ntry``, ``discretization`` or N; None when the tolerance is not reachable.
    cost : int or None
        Samples or voxels at that setting.
    seconds : float or None
        Measured or scaled run time at that setting.
    note : str
        Why a tolerance is unreachable, or how the setting was found.
    """

    method: str
    tolerance: float
    setting: Optional[int]
    cost: Optional[int]
    seconds: Optional[float]
    note: str = ""


def relative_errors(est, ref) -> np.ndarray:
    """Relative errors of mass and of the three principal moments of ``est`` against ``ref``.

    Parameters
    ----------
    est, ref : clumpprops.audit.methods.Estimate
        An estimate and the exact values.

    Returns
    -------
    numpy.ndarray, shape (4,)
        ``(m - m_ref) / m_ref`` then ``(I_k - I_k,ref) / I_k,ref`` for k = 1, 2, 3.
    """
    return np.concatenate([[est.mass / ref.mass - 1.0], est.moments / ref.moments - 1.0])


def montecarlo(default, exact, tolerances, iyz_bias=0.0) -> List[Advice]:
    """``ntry`` for each tolerance from the standard error's 1/sqrt(ntry) scaling.

    Parameters
    ----------
    default : Estimate
        A :func:`~clumpprops.audit.methods.liggghts_montecarlo` run (its ``extra["rel_sd"]``).
    exact : Estimate
        The exact values.
    tolerances : sequence of float
        Relative tolerances.
    iyz_bias : float, optional
        The largest relative moment error sampling cannot remove (LIGGGHTS 3.8.0's Iyz).

    Returns
    -------
    list of Advice
    """
    s = float(np.max(default.extra["rel_sd"]))
    ntry0 = default.cost // 2
    out = []
    for tol in tolerances:
        if iyz_bias >= tol:
            out.append(Advice(default.method, tol, None, None, None,
                              f"unreachable: the Iyz defect alone gives {100 * iyz_bias:.3g} %"))
            continue
        n = max(1000, math.ceil((Z_JOINT * s / (tol - iyz_bias)) ** 2))
        out.append(Advice(default.method, tol, n, 2 * n, default.seconds * n / ntry0,
                          f"(2.50 s/tol)^2, s = {s:.3g} per point"))
    return out


def voxel(centers, radii, density, exact, tolerances, max_cells=4_000_000, ladder=VOXEL_LADDER):
    """The smallest discretization of the ladder whose error is within each tolerance.

    Parameters
    ----------
    centers, radii, density
        The clump, as for :func:`~clumpprops.audit.methods.exact`.
    exact : Estimate
        The exact values.
    tolerances : sequence of float
        Relative tolerances.
    max_cells : int, optional
        The largest grid tried.
    ladder : sequence of int, optional
        The discretizations tried, in order.

    Returns
    -------
    advice : list of Advice
    curve : list of (int, int, float)
        (discretization, cells, largest relative error) of every grid computed.
    """
    curve, todo, out = [], sorted(tolerances, reverse=True), {}
    for k in ladder:
        if not todo:
            break
        est = _voxel_or_none(centers, radii, density, k, max_cells)
        if est is None:
            break
        err = float(np.max(np.abs(relative_errors(est, exact))))
        curve.append((k, est.cost, err))
        while todo and err <= todo[0]:
            out[todo.pop(0)] = Advice("YADE voxel", 0.0, k, est.cost, est.seconds, "computed")
    advice = []
    for tol in tolerances:
        a = out.get(tol) or Advice("YADE voxel", tol, None, None, None, f"not reached within {max_cells:.0e} cells")
        a.tolerance = tol
        advice.append(a)
    return advice, curve


def _voxel_or_none(centers, radii, density, k, max_cells):
    lo, hi = methods._box(np.asarray(centers, float), np.asarray(radii, float))
    dx = (hi - lo).min() / k
    if np.prod(np.ceil((hi - lo) / dx)) > max_cells:
        return None
    return methods.yade_voxel(centers, radii, density, k)


def qmc(centers, radii, density, exact, tolerances, seed=None, ladder=QMC_LADDER, scrambles=QMC_SCRAMBLES,
        confirm=False):
    """N for each tolerance from the measured scramble-to-scramble error at increasing N.

    The N is extrapolated from a power law fitted to the largest N measured (tests check that
    the extrapolated N meets its tolerance in at least 95 % of scramblings); with ``confirm`` it
    is also measured at that N, and grown until the measurement meets the tolerance, at the cost
    of sampling at the recommended N itself.

    Parameters
    ----------
    centers, radii, density
        The clump, as for :func:`~clumpprops.audit.methods.exact`.
    exact : Estimate
        The exact values (``extra["inertia"]`` for the diagonal in the file's frame).
    tolerances : sequence of float
        Relative tolerances.
    seed : int or None, optional
        Seed of the scramblings.
    ladder : sequence of int, optional
        The N measured.
    scrambles : int, optional
        Scramblings per N.
    confirm : bool, optional
        Measure the error at each recommended N (slow for small tolerances).

    Returns
    -------
    advice : list of Advice
    curve : list of (int, float)
        (N, 2.50 times the root-mean-square largest relative error) measured.
    """
    ref = np.concatenate([[exact.mass], np.diag(exact.extra["inertia"])])
    root = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    seeds = root.spawn(len(ladder) * scrambles)
    curve, per_point = [], []
    for i, n in enumerate(ladder):
        t0 = time.perf_counter()
        errs = [_qmc_error(centers, radii, density, n, seeds[i * scrambles + j], ref) for j in range(scrambles)]
        per_point.append((time.perf_counter() - t0) / (scrambles * n))
        curve.append((n, Z_JOINT * float(np.sqrt(np.mean(np.square(errs))))))
    fit = curve[-QMC_FIT_POINTS:]
    logn, loge = np.log([c[0] for c in fit]), np.log([max(c[1], 1e-300) for c in fit])
    slope, icpt = np.polyfit(logn, loge, 1)
    rate = float(np.median(per_point))
    advice, more = [], root.spawn(1)[0]
    for tol in sorted(tolerances, reverse=True):
        if slope >= 0:
            advice.append(Advice("Halton QMC (DEME)", tol, None, None, None, "error does not fall with N"))
            continue
        n = max(16, int(math.ceil(math.exp((math.log(tol) - icpt) / slope))))
        note = "extrapolated"
        if confirm:
            n, note = _confirm(centers, radii, density, ref, n, tol, slope, scrambles, more, curve)
        advice.append(Advice("Halton QMC (DEME)", tol, n, n, rate * n, f"fit rms ~ N^{slope:.2f}, {note}"))
    order = {tol: i for i, tol in enumerate(tolerances)}
    return sorted(advice, key=lambda a: order[a.tolerance]), sorted(curve)


def _confirm(centers, radii, density, ref, n, tol, slope, scrambles, seeds, curve, tries=3):
    """Measure the error at the extrapolated N and grow N until it is within the tolerance."""
    for _ in range(tries):
        errs = [_qmc_error(centers, radii, density, n, s, ref) for s in seeds.spawn(scrambles)]
        bound = Z_JOINT * float(np.sqrt(np.mean(np.square(errs))))
        curve.append((n, bound))
        if bound <= tol:
            return n, "measured"
        n = int(math.ceil(1.1 * n * (bound / tol) ** (-1.0 / slope)))
    return n, "extrapolated"


def _qmc_error(centers, radii, density, n, seed, ref):
    est = methods.halton_qmc(centers, radii, density, n, seed=seed)
    return float(np.max(np.abs(np.concatenate([[est.mass], est.extra["diagonal"]]) / ref - 1.0)))
