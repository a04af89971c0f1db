"""``mass_properties``: one call, one immutable answer, for one clump or a batch.

Methods ``exact``, ``pairwise`` and ``sum`` run in the compiled core
(``clumpprops/core/clumpprops.hpp`` through the pybind11 module ``clumpprops.core._core``):
the input is checked and flattened once here, then one core call per block of clumps
computes every clump (origin, moments, mass, centre of mass, inertia, principal axes)
straight into the result arrays; there is no Python work per clump.  ``montecarlo`` and
``voxel`` are numpy baselines (``baselines.py``).
"""
from __future__ import annotations

import numpy as np

from . import _input
from ._properties import MassProperties, finish
from .core import _core
from .methods import BY_NAME

METHODS = ("exact", "pairwise", "sum", "montecarlo", "voxel")
_BATCH_CHUNK = 32768  # clumps per core call for large batches (errors name the clump of the whole batch)
DEFAULT_METHOD = "exact"
_CORE = {"exact": _core.EXACT, "pairwise": _core.PAIRWISE, "sum": _core.SUM}


def _method(method, options):
    """(name, options) from a method name with keyword options, or a typed method object."""
    if isinstance(method, str):
        if method not in METHODS:
            raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
        return method, options
    if isinstance(method, tuple(BY_NAME.values())):
        if options:
            raise ValueError(f"give options either in the method object {method!r} or as keywords, not both")
        return method.name, method.options()
    raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)} or a clumpprops.methods object")


def mass_properties(centers, radii, density=1.0, method=DEFAULT_METHOD, **options) -> MassProperties:
    """Mass, volume, centre of mass, inertia tensor and principal axes of sphere clumps.

    Parameters
    ----------
    centers : array_like, shape (N, 3), (M, N, 3), or a list of M arrays (N_m, 3)
        Sphere centres, in m: one clump, a batch of M clumps, or M clumps of different sizes.
    radii : array_like, shape (N,), (M, N), or a list of M arrays (N_m,)
        Sphere radii, in m; all > 0.
    density : float, optional
        Solid density of the member spheres, in kg/m^3; > 0.
    method : str or a method object of :mod:`clumpprops.methods`, optional
        The method, by name with its options as keywords, or as an object with its options:

        * ``"exact"`` / ``Exact()`` (default): the union of the spheres, any overlap pattern
          (see docs/exact_method.md); round-off accurate.
        * ``"pairwise"`` / ``Pairwise()``: the paper's eqs. (1)-(7).
        * ``"sum"`` / ``Sum()``: overlaps counted twice (YADE's default clump, LAMMPS fix rigid).
        * ``"montecarlo"`` / ``MonteCarlo(n_samples=10**6, seed=None)``: sets
          ``standard_error``; at most 10^9 samples.
        * ``"voxel"`` / ``Voxel(discretization=10)``: YADE's regular-grid scheme;
          discretization at most 1000 and at most 10^9 cells per clump.
    **options
        The options of a method given by name: ``n_samples``, ``seed`` and ``chunk`` for
        ``"montecarlo"``, ``discretization`` for ``"voxel"``; none for the others.

    Returns
    -------
    MassProperties
        The properties, with a leading M axis on every array for batch input.

    Raises
    ------
    ValueError
        For bad input (shapes, non-positive radii or density, an unknown method or option,
        complex numbers, booleans, strings, numbers beyond float64), and where a result would
        not be a normal float64 number ("too large", "too small").
    ClumpGeometryError
        With ``method="pairwise"``, where three spheres of a clump share a region.

    Notes
    -----
    Spheres that do not change the union: ``exact`` drops exact duplicates (in clumps of more
    than 64 spheres, before the pair search) and spheres contained in another; ``pairwise``
    takes the spheres as given (a contained pair removes the smaller sphere, eq. 1-7's lens
    rule; a duplicate pair cut by a third sphere is a triple overlap and refused); ``sum``
    drops nothing (it reproduces the engines' sums, duplicates counted each time).

    ``exact``, ``pairwise`` and ``sum`` are scale-free: each clump is computed in units of a
    power of two near its largest radius and scaled back exactly, so the answer is exact
    wherever mass (~ density r^3) and inertia (~ density r^5) are normal float64 numbers;
    beyond that range a ValueError says "too large" or "too small".
    """
    rho = _input.check_density(density)
    name, options = _method(method, options)
    allowed = {"montecarlo": {"n_samples", "seed", "chunk"}, "voxel": {"discretization"}}.get(name, set())
    extra = set(options) - allowed
    if extra:
        raise ValueError(f"method {name!r} takes no option(s) {sorted(extra)}; it accepts {sorted(allowed) or 'none'}")
    if name in _CORE:
        return _compiled(centers, radii, rho, name)
    sph = _input.normalize(centers, radii)
    with np.errstate(over="ignore"):
        if name == "montecarlo":
            from .baselines import montecarlo_moments

            return montecarlo_moments(sph, rho, **options)
        from .baselines import voxel_moments

        V, S, Q = voxel_moments(sph, **options)
        return finish(V, S, Q, sph.origin, rho, name, sph.batched)


def _compiled(centers, radii, rho, name, with_area=False):
    """MassProperties from the core; with ``with_area``, (MassProperties, area (M,) in m^2) from one pass."""
    c_given, r_given, starts, N, M, batched = _input.flatten(centers, radii)
    c, r, exponent = _unit_scale(c_given, r_given, starts, N, M)
    mass, vol = np.empty(M), np.empty(M)
    com, inertia = np.empty((M, 3)), np.empty((M, 3, 3))
    w, axes = np.empty((M, 3)), np.empty((M, 3, 3))
    area = np.empty(M)
    code = _CORE[name]
    for m0 in range(0, M, _BATCH_CHUNK):
        block = (code, c, r, starts, N, m0, min(M, m0 + _BATCH_CHUNK), rho, True, True, mass, vol, com, inertia, w, axes)
        status = _core.run_area(*block, area) if with_area else _core.run(*block)
        if status[0]:
            _core_error(status, c_given, r_given, batched, name)
    if exponent is not None:
        mass, vol, com, inertia, w = _scale_back(exponent, mass, vol, com, inertia, w)
        area = np.ldexp(area, 2 * exponent)
    _check_representable(mass, w, batched)
    for a in (mass, vol, com, inertia, w, axes):
        a.flags.writeable = False
    if not batched:
        mp = MassProperties._make(float(mass[0]), float(vol[0]), com[0], inertia[0], w[0], axes[0], name, rho)
    else:
        mp = MassProperties._make(mass, vol, com, inertia, w, axes, name, rho)
    return (mp, area) if with_area else mp


_SCALE_FREE = 2.0**-20, 2.0**20  # clumps with every radius in this band are computed as given


def _unit_scale(c, r, starts, N, M):
    """Each clump divided by a power of two 2^e near its largest radius (exact: only exponents change).

    Returns (centres, radii, e per clump), or the input and None when every radius lies in
    _SCALE_FREE (no clump needs it).  The core then works with radii near 1, so no power of a
    length (up to r^5 and the lens formulas' l^8) under- or overflows on the way, and the
    results scale back exactly: lengths by 2^e, volume and mass by 2^3e, inertia by 2^5e.
    """
    if not len(r) or (_SCALE_FREE[0] <= r.min() and r.max() <= _SCALE_FREE[1]):
        return c, r, None
    with np.errstate(invalid="ignore"):
        rmax = r.reshape(M, N).max(axis=1) if starts is None else np.maximum.reduceat(r, starts[:-1])
    exponent = np.frexp(np.where(np.isfinite(rmax) & (rmax > 0), rmax, 1.0))[1]
    per_sphere = np.repeat(exponent, N) if starts is None else np.repeat(exponent, np.diff(starts))
    c_unit = np.ldexp(c, -per_sphere[:, None])
    if np.any(np.isinf(c_unit) & np.isfinite(c)):
        raise ValueError("a clump's centres are too large relative to its radii (|centre| / radius beyond "
                         "~1e308): positions cannot resolve spheres that small there")
    return np.ascontiguousarray(c_unit), np.ldexp(r, -per_sphere), exponent


def _scale_back(exponent, mass, vol, com, inertia, w):
    e = exponent
    with np.errstate(over="ignore", under="ignore"):
        return (np.ldexp(mass, 3 * e), np.ldexp(vol, 3 * e), np.ldexp(com, e[:, None]),
                np.ldexp(inertia, 5 * e[:, None, None]), np.ldexp(w, 5 * e[:, None]))


_TINY = np.finfo(np.float64).tiny  # the smallest normal float64; below it values lose digits


def _check_representable(mass, w, batched):
    """ValueError, naming the direction, where a mass or an inertia is beyond float64's normal range."""
    largest = w[:, 2]  # ascending principal moments: the largest
    if _TINY <= mass.min() and mass.max() < np.inf and _TINY <= largest.min() and w.max() < np.inf:
        return  # (NaN fails every comparison and takes the slow path)
    big = ~np.isfinite(mass) | ~np.all(np.isfinite(w), axis=1)
    small = (np.abs(mass) < _TINY) | (np.max(np.abs(w), axis=1) < _TINY)
    for bad, word, why in ((big, "too large", "overflows float64 (above ~1.8e308)"),
                           (small, "too small", "underflows float64 (below ~2.2e-308, where digits are lost)")):
        if np.any(bad):
            m = int(np.flatnonzero(bad)[0])
            where = f" of clump {m}" if batched else ""
            raise ValueError(f"input {word}: the mass or inertia{where} {why}; mass scales as density * r^3 "
                             "and inertia as density * r^5; express the input in other units")


def _core_error(status, c_given, r_given, batched, name):
    """The error for a core status: ``c_given`` (S, 3) and ``r_given`` (S,) the flat input as given."""
    code, m = status[0], status[1]
    where = f" of clump {m}" if batched else ""
    if code == _core.TRIPLE:
        from .pairwise import ClumpGeometryError

        i, j, k, count = status[2:]
        raise ClumpGeometryError(
            f"spheres {(i, j, k)}{where} share a common region (a triple overlap; {count} such triple(s) in "
            "that clump): the pairwise method (paper eqs. 1-7) would be wrong there; use method='exact'"
        )
    if code == _core.OVERFLOW:
        raise ValueError(
            "the clump's moments overflow float64 (input too large: density * radius^5 must stay "
            f"below ~1e308 in SI units){where}; express the input in other units"
        )
    if code == _core.NONPOSITIVE_VOLUME:
        raise ArithmeticError(f"internal error in method {name!r}: non-positive volume{where}")
    _input.check_values(c_given, r_given)  # bad values (NaN, inf, radius <= 0): raises naming the problem
    raise ValueError(f"invalid sphere data{where}")  # pragma: no cover
