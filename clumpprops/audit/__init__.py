"""``clumpprops audit``: how far each engine's own mass properties are from the exact ones.

For one clump, :func:`audit_clump` computes the exact values beside each engine method at that
engine's default setting (:mod:`clumpprops.audit.methods`), the setting each sampled method
needs to reach a tolerance with 95 % probability and its cost (:mod:`clumpprops.audit.advice`),
and, when a file states values, what is wrong with them (:mod:`clumpprops.audit.diagnose`).
The command line is :mod:`clumpprops.audit.cli`; docs/audit.md describes the methods.
"""
from __future__ import annotations

import time
from typing import Optional, Sequence

import numpy as np

from . import advice, methods
from .diagnose import diagnose

__all__ = ["audit_clump", "diagnose"]


def _row(est, exact):
    err = advice.relative_errors(est, exact)
    return {"method": est.method, "setting": est.setting, "mass": est.mass, "volume": est.volume,
            "com": est.com.tolist(), "principal_moments": est.moments.tolist(),
            "mass_error": float(err[0]), "moment_errors": err[1:].tolist(), "cost": est.cost, "seconds": est.seconds}


def _shape(centers, radii):
    """The exact shape descriptors (:func:`clumpprops.shape_descriptors`) as plain numbers."""
    from ..shape import shape_descriptors

    return shape_descriptors(centers, radii).to_dict()


def audit_clump(centers, radii, density: float = 1000.0, tolerances: Sequence[float] = (0.01, 0.001),
                seed: Optional[int] = None, ntry: int = methods.LIGGGHTS_NTRY,
                discretization: int = methods.YADE_DISCRETIZATION, qmc_points: int = methods.QMC_POINTS,
                stated=None, max_voxels: int = 4_000_000, confirm: bool = False) -> dict:
    """Every method's values for one clump and the setting each sampled method needs.

    Parameters
    ----------
    centers : array_like, shape (N, 3)
        Sphere centres in m.
    radii : array_like, shape (N,)
        Sphere radii in m.
    density : float, optional
        Density in kg/m^3.
    tolerances : sequence of float, optional
        Relative tolerances on mass and each principal moment.
    seed : int or None, optional
        Seed of the sampled methods.
    ntry, discretization, qmc_points : int, optional
        The engines' settings the table shows (their defaults by default).
    stated : sequence of clumpprops.io.stated.Stated, optional
        Values a file states for this clump.
    max_voxels : int, optional
        The largest voxel grid tried for a recommendation.
    confirm : bool, optional
        Measure the quasi-Monte Carlo error at each recommended N too (see
        :func:`clumpprops.audit.advice.qmc`); slow for small tolerances.

    Returns
    -------
    dict
        ``methods`` (rows: values, relative errors, cost, seconds), ``advice`` (per sampled method
        and tolerance: setting, cost, seconds), ``curves`` (error against cost, for plots),
        ``stated`` (diagnoses), ``shape`` (:meth:`clumpprops.ShapeDescriptors.to_dict`) and
        ``seconds`` (whole audit and exact values alone).
    """
    t0 = time.perf_counter()
    c, r = np.asarray(centers, float), np.asarray(radii, float)
    exact = methods.exact(c, r, density)
    summed = methods.summed(c, r, density)
    seeds = np.random.SeedSequence(seed).spawn(3)
    mc = methods.liggghts_montecarlo(c, r, density, ntry, seed=seeds[0])
    mc38 = methods.with_iyz_defect(mc)
    rows = [exact, summed, methods.yade_voxel(c, r, density, discretization), mc, mc38,
            methods.halton_qmc(c, r, density, qmc_points, seed=seeds[1])]
    bias = float(np.max(np.abs(np.linalg.eigvalsh(methods.with_iyz_defect(exact).extra["inertia"]) / exact.moments - 1)))
    vox_adv, vox_curve = advice.voxel(c, r, density, exact, tolerances, max_voxels)
    qmc_adv, qmc_curve = advice.qmc(c, r, density, exact, tolerances, seed=seeds[2], confirm=confirm)
    frame = float(np.max(np.abs(np.sort(np.diag(exact.extra["inertia"])) / exact.moments - 1.0)))
    for a in qmc_adv:
        if frame > a.tolerance:
            a.note += f"; the diagonal in this frame is {100 * frame:.3g} % off: rotate to the principal frame"
    adv = advice.montecarlo(mc, exact, tolerances) + advice.montecarlo(mc38, exact, tolerances, bias) + vox_adv + qmc_adv
    s = float(np.max(mc.extra["rel_sd"]))
    return {
        "density": float(density),
        "exact": _row(exact, exact),
        "methods": [_row(e, exact) for e in rows[1:]],
        "advice": [vars(a) for a in adv],
        "curves": {"LIGGGHTS Monte Carlo": [(2 * n, advice.Z_JOINT * s / np.sqrt(n)) for n in np.logspace(3, 9, 13)],
                   "YADE voxel": [(cells, err) for _, cells, err in vox_curve],
                   "Halton QMC (DEME)": qmc_curve},
        "qmc_frame_error": frame,
        "stated": [diagnose(st, exact, summed) for st in (stated or [])],
        "shape": _shape(c, r),
        "seconds": {"audit": time.perf_counter() - t0, "exact": exact.seconds},
    }
