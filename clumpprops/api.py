"""``mass_properties``: one call, one immutable answer, for one clump or a batch."""
from __future__ import annotations

import numpy as np

from . import _input
from ._properties import MassProperties, finish

METHODS = ("exact", "pairwise", "sum", "montecarlo", "voxel")
_BATCH_CHUNK = 32768  # clumps per block for large batches
DEFAULT_METHOD = "exact"


def mass_properties(centers, radii, density=1.0, method=DEFAULT_METHOD, **options) -> MassProperties:
    """Mass, volume, centre of mass, inertia tensor and principal axes of sphere clumps.

    Parameters
    ----------
    centers : array (N, 3) in m for one clump, (M, N, 3) for a batch of M clumps,
        or a list of M arrays (N_m, 3) for clumps of different sizes.
    radii : array (N,) in m, (M, N), or a list of M arrays (N_m,); all > 0.
    density : kg/m^3, > 0 (the solid density of the member spheres).
    method :
        ``"exact"`` (default): the union of the spheres, any overlap pattern (see
        docs/exact_method.md); round-off accurate.
        ``"pairwise"``: the paper's eqs. (1)-(7); raises ClumpGeometryError where three
        spheres share a region.
        ``"sum"``: overlaps counted twice (YADE's default clump, LAMMPS fix rigid).
        ``"montecarlo"``: options ``n_samples`` (default 10**6), ``seed``; sets
        ``standard_error``.
        ``"voxel"``: option ``discretization`` (default 10), YADE's regular-grid scheme.

    Returns
    -------
    MassProperties, with a leading M axis on every array for batch input.
    """
    rho = _input.check_density(density)
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    allowed = {"montecarlo": {"n_samples", "seed", "chunk"}, "voxel": {"discretization"}}.get(method, set())
    extra = set(options) - allowed
    if extra:
        raise ValueError(f"method {method!r} takes no option(s) {sorted(extra)}; it accepts {sorted(allowed) or 'none'}")
    sph = _input.normalize(centers, radii)
    # overflow (absurdly large input) is reported by finish() as a ValueError, not as a warning
    with np.errstate(over="ignore"):
        if sph.n_clumps <= _BATCH_CHUNK or method not in ("exact", "pairwise", "sum"):
            return _compute(sph, rho, method, options)
        # large batches in blocks of clumps: temporaries stay in cache (~1.5x faster)
        parts = [_compute(sph.clumps(m0, m0 + _BATCH_CHUNK), rho, method, options)
                 for m0 in range(0, sph.n_clumps, _BATCH_CHUNK)]
    return MassProperties(
        *(np.concatenate([getattr(p, name) for p in parts]) for name in MassProperties._ARRAYS),
        method=method,
        density=rho,
    )


def _compute(sph, rho, method, options):
    if method == "pairwise":
        from .pairwise import pairwise_moments

        V, S, Q = pairwise_moments(sph)
    elif method == "sum":
        from .pairwise import sphere_moments

        V, S, Q = sphere_moments(sph)
    elif method == "exact":
        from .exact import exact_moments

        V, S, Q = exact_moments(sph)
    elif method == "montecarlo":
        from .baselines import montecarlo_moments

        return montecarlo_moments(sph, rho, **options)
    else:  # voxel
        from .baselines import voxel_moments

        V, S, Q = voxel_moments(sph, **options)
    return finish(V, S, Q, sph.origin, rho, method, sph.batched)
