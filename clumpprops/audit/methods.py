"""The engines' own ways to get a clump's mass properties, reproduced for the audit.

Each function takes one clump (centres in m, radii in m) and a density (kg/m^3) and returns
an :class:`Estimate`: mass (kg), volume (m^3), centre of mass (m) and the ascending principal
moments (kg m^2) as that engine's method computes them.

* :func:`summed`: the member spheres added up, overlaps counted twice (YADE ``appendClumped``,
  LAMMPS ``fix rigid``, MClump mode 1, PFC without calculation);
* :func:`yade_voxel`: YADE's regular grid at ``discretization`` k
  (:func:`clumpprops.baselines.voxel_moments`, reproduced to 1e-14);
* :func:`liggghts_montecarlo`: LIGGGHTS' ``particletemplate/multisphere`` Monte Carlo over
  ``ntry`` points: uniform points in the spheres' bounding box; a first stream gives the
  volume (hits / ntry times the box volume) and the centre of mass (mean of the hits); a second,
  independent stream gives the inertia tensor about that centre.  ``iyz_defect`` reproduces
  LIGGGHTS 3.8.0, which stores Iyz as (Iyz + Ixz) / 2;
* :func:`halton_qmc`: a scrambled Halton quasi-Monte Carlo over the bounding box, as
  DEM-Engine's development branch samples; it keeps only the diagonal of the tensor about the
  centre of mass (DEME takes a clump in its principal frame and uses ``moi`` as the diagonal).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .. import mass_properties
from ..core import _core

#: LIGGGHTS ``particletemplate/multisphere`` requires ``ntry`` (it has no default: "need 'ntry' to be
#: defined"); 10^6 is the value its documentation's multisphere example uses.
LIGGGHTS_NTRY = 1_000_000
#: YADE ``updateClumpProperties`` default discretization.
YADE_DISCRETIZATION = 5
#: Halton points in a DEM-Engine-style quasi-Monte Carlo estimate.
QMC_POINTS = 2 ** 16
_CHUNK = 1 << 15


@dataclass
class Estimate:
    """One method's mass properties of one clump.

    Parameters
    ----------
    method : str
        The method's name as the audit prints it.
    mass, volume : float
        Mass (kg) and volume (m^3).
    com : numpy.ndarray, shape (3,)
        Centre of mass (m), in the file's frame.
    moments : numpy.ndarray, shape (3,)
        Principal moments of inertia (kg m^2), ascending.
    setting : str
        The setting used, e.g. ``"ntry=1000000"``.
    cost : int
        Samples or voxels evaluated (0 for closed-form methods).
    seconds : float
        Measured run time.
    """

    method: str
    mass: float
    volume: float
    com: np.ndarray
    moments: np.ndarray
    setting: str = ""
    cost: int = 0
    seconds: float = 0.0
    extra: dict = field(default_factory=dict)


def _box(centers, radii):
    return (centers - radii[:, None]).min(axis=0), (centers + radii[:, None]).max(axis=0)


def _hits(x, centers, radii):
    """Points strictly inside some sphere, |x - c|^2 < r^2 (the compiled core's loop, which stops
    at the first sphere that holds the point)."""
    return _core.union_hits(np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(centers, dtype=float),
                            np.ascontiguousarray(radii, dtype=float))


def _centred(centers, radii):
    """Spheres and bounding box relative to the box centre (keeps the hit test's round-off small)."""
    c, r = np.asarray(centers, float), np.asarray(radii, float)
    lo, hi = _box(c, r)
    mid = 0.5 * (lo + hi)
    return c - mid, r, lo - mid, hi - mid, mid


def _points(rng, n, lo, hi):
    done = 0
    while done < n:
        k = min(_CHUNK, n - done)
        yield lo + (hi - lo) * rng.random((k, 3))
        done += k


def _tensor(d):
    """Sum over points of the inertia integrand |d|^2 1 - d d^T (unit mass per point)."""
    dd = d.T @ d
    return np.trace(dd) * np.eye(3) - dd


def exact(centers, radii, density) -> Estimate:
    """The exact union (the library's default method).

    Parameters
    ----------
    centers : array_like, shape (N, 3)
        Sphere centres in m.
    radii : array_like, shape (N,)
        Sphere radii in m.
    density : float
        Density in kg/m^3.

    Returns
    -------
    Estimate
        The exact values (``extra["inertia"]`` holds the tensor about the centre of mass).
    """
    return _from_library("exact", centers, radii, density, label="exact")


def summed(centers, radii, density) -> Estimate:
    """The summed spheres: YADE ``appendClumped``, LAMMPS ``fix rigid``, MClump mode 1, PFC.

    Parameters
    ----------
    centers, radii, density
        As for :func:`exact`.

    Returns
    -------
    Estimate
        The summed values.
    """
    return _from_library("sum", centers, radii, density, label="summed spheres (YADE/LAMMPS/PFC)")


def yade_voxel(centers, radii, density, discretization=YADE_DISCRETIZATION) -> Estimate:
    """YADE's voxel grid at ``discretization`` cells along the shortest bounding-box side.

    Parameters
    ----------
    centers, radii, density
        As for :func:`exact`.
    discretization : int, optional
        YADE's ``discretization``, 1 to 1000.

    Returns
    -------
    Estimate
        The voxel values; ``cost`` is the number of grid cells.
    """
    est = _from_library("voxel", centers, radii, density, label="YADE voxel",
                        discretization=int(discretization))
    lo, hi = _box(np.asarray(centers, float), np.asarray(radii, float))
    dx = (hi - lo).min() / discretization
    est.cost = int(np.prod(np.ceil((hi - lo) / dx)))
    est.setting = f"discretization={int(discretization)}"
    return est


def _from_library(method, centers, radii, density, label, **options) -> Estimate:
    t0 = time.perf_counter()
    mp = mass_properties(np.asarray(centers, float), np.asarray(radii, float), density=density, method=method,
                         **options)
    return Estimate(label, float(mp.mass), float(mp.volume), np.asarray(mp.center_of_mass, float),
                    np.asarray(mp.principal_moments, float), seconds=time.perf_counter() - t0,
                    extra={"inertia": np.asarray(mp.inertia, float)})


def liggghts_montecarlo(centers, radii, density, ntry=LIGGGHTS_NTRY, seed=None, iyz_defect=False) -> Estimate:
    """LIGGGHTS' ``particletemplate/multisphere`` Monte Carlo (module docstring).

    Parameters
    ----------
    centers, radii, density
        As for :func:`exact`.
    ntry : int, optional
        Points per stream (LIGGGHTS' ``ntry``), at least 1000 as LIGGGHTS requires.
    seed : int or None, optional
        Seed of numpy's generator (LIGGGHTS' own generator is not reproduced, only its statistics).
    iyz_defect : bool, optional
        Store Iyz as (Iyz + Ixz) / 2, as LIGGGHTS 3.8.0 does.

    Returns
    -------
    Estimate
        ``extra`` holds the tensor and the per-point relative standard deviations (``rel_sd``:
        mass and the three principal moments) the recommendation scales.

    Raises
    ------
    ValueError
        If ``ntry`` is below 1000.
    """
    if int(ntry) < 1000:
        raise ValueError(f"ntry must be at least 1000 (LIGGGHTS refuses fewer), got {ntry}")
    t0 = time.perf_counter()
    c, r, lo, hi, mid = _centred(centers, radii)
    vbox = float(np.prod(hi - lo))
    rng = np.random.default_rng(seed)
    n_in, s1 = 0, np.zeros(3)
    for x in _points(rng, ntry, lo, hi):
        h = x[_hits(x, c, r)]
        n_in += len(h)
        s1 += h.sum(axis=0)
    if n_in == 0:
        raise ArithmeticError("no Monte Carlo point fell inside the clump; increase ntry")
    com = s1 / n_in  # in the box-centred frame
    T, q = np.zeros((3, 3)), []
    for x in _points(rng, ntry, lo, hi):
        d = x[_hits(x, c, r)] - com
        T += _tensor(d)
        q.append(d)
    T *= density * vbox / ntry
    sym = T.copy()
    if iyz_defect:
        sym[1, 2] = sym[2, 1] = 0.5 * (T[1, 2] + T[0, 2])
    moments, axes = np.linalg.eigh(sym)
    p = n_in / ntry
    rel_sd = [np.sqrt((1.0 - p) / p)] + list(_moment_rel_sd(np.concatenate(q), axes, ntry))
    return Estimate("LIGGGHTS Monte Carlo" + (" (3.8.0 Iyz)" if iyz_defect else ""), density * vbox * p,
                    vbox * p, com + mid, moments, f"ntry={int(ntry)}", 2 * int(ntry), time.perf_counter() - t0,
                    {"inertia": sym, "rel_sd": np.array(rel_sd)})


def _moment_rel_sd(d, axes, n):
    """Per-point relative standard deviation of each principal moment's estimator (n points in all)."""
    proj = d @ axes
    r2 = (d * d).sum(axis=1)
    out = []
    for k in range(3):
        g = r2 - proj[:, k] ** 2  # the integrand of I_k at the hits (zero outside)
        mean = g.sum() / n
        var = (g * g).sum() / n - mean * mean
        out.append(np.sqrt(max(var, 0.0)) / mean)
    return out


def halton_qmc(centers, radii, density, n_points=QMC_POINTS, seed=None) -> Estimate:
    """A scrambled Halton quasi-Monte Carlo estimate, diagonal inertia only (DEM-Engine style).

    Parameters
    ----------
    centers, radii, density
        As for :func:`exact`.
    n_points : int, optional
        Halton points over the bounding box, at least 16.
    seed : int or None, optional
        Seed of the scrambling.

    Returns
    -------
    Estimate
        ``moments`` are the sorted diagonal of the tensor about the estimated centre of mass, in
        the file's frame (what DEME returns); ``extra["diagonal"]`` keeps the x, y, z order.

    Raises
    ------
    ValueError
        If ``n_points`` is below 16.
    """
    from scipy.stats import qmc

    if int(n_points) < 16:
        raise ValueError(f"n_points must be at least 16, got {n_points}")
    t0 = time.perf_counter()
    c, r, lo, hi, mid = _centred(centers, radii)
    vbox = float(np.prod(hi - lo))
    u = qmc.Halton(d=3, scramble=True, seed=np.random.default_rng(seed)).random(int(n_points))
    n_in, s1, s2 = 0, np.zeros(3), np.zeros(3)
    for k in range(0, len(u), _CHUNK):
        x = lo + (hi - lo) * u[k:k + _CHUNK]
        h = x[_hits(x, c, r)]
        n_in += len(h)
        s1 += h.sum(axis=0)
        s2 += (h * h).sum(axis=0)
    if n_in == 0:
        raise ArithmeticError("no quasi-Monte Carlo point fell inside the clump; increase n_points")
    V = vbox * n_in / n_points
    com = s1 / n_in  # in the box-centred frame
    second = V * (s2 / n_in - com * com)  # integral of (x_i - com_i)^2 over the volume
    diag = density * (second.sum() - second)
    return Estimate("Halton QMC (DEME)", density * V, V, com + mid, np.sort(diag), f"N={int(n_points)}", int(n_points),
                    time.perf_counter() - t0, {"diagonal": diag})


def with_iyz_defect(est: Estimate) -> Estimate:
    """The same Monte Carlo tensor as LIGGGHTS 3.8.0 stores it: Iyz replaced by (Iyz + Ixz) / 2.

    Parameters
    ----------
    est : Estimate
        A :func:`liggghts_montecarlo` result without the defect.

    Returns
    -------
    Estimate
        A copy with the defective tensor and its principal moments.
    """
    T = est.extra["inertia"].copy()
    T[1, 2] = T[2, 1] = 0.5 * (T[1, 2] + T[0, 2])
    return Estimate(est.method + " (3.8.0 Iyz)", est.mass, est.volume, est.com, np.linalg.eigvalsh(T), est.setting,
                    est.cost, est.seconds, dict(est.extra, inertia=T))
