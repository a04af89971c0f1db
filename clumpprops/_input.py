"""Validation and normalisation of clump input (no physics here).

Every public entry point funnels ``centers``, ``radii`` and ``density`` through
:func:`normalize`, which turns the three accepted layouts into one flat
representation that all methods share:

* one clump: ``centers`` (N, 3), ``radii`` (N,)
* a regular batch: ``centers`` (M, N, 3), ``radii`` (M, N)
* a ragged batch: a sequence of M arrays (N_m, 3) and a sequence of M arrays (N_m,)

The flat form is ``Spheres``: all spheres stacked (S, 3) and (S,), the clump
index of each sphere (S,), the number of clumps M, and a per-clump origin (M, 3)
near the clump's centre (the volume-weighted mean of its sphere centres).  All
moments are taken about that origin, so clumps far from the world origin
(1e6 m offsets) lose no digits to cancellation.

Bad input raises ``ValueError`` naming the problem, never NaN.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Spheres:
    centers: np.ndarray  # (S, 3) m, relative to the clump origin
    radii: np.ndarray  # (S,) m
    clump: np.ndarray  # (S,) int, clump index of each sphere
    n_clumps: int  # M
    origin: np.ndarray  # (M, 3) m, world position of each clump's origin
    local: np.ndarray  # (S,) int, index of the sphere inside its clump
    batched: bool  # True when the caller passed a batch (regular or ragged)
    counts: np.ndarray  # (M,) number of spheres per clump
    starts: np.ndarray  # (M,) index of each clump's first sphere (spheres are grouped by clump)
    regular: int  # N if every clump has N spheres, else 0
    first_clump: int = 0  # index of clump 0 in the caller's batch (for messages)

    def clumps(self, m0: int, m1: int) -> "Spheres":
        """The clumps m0 .. m1-1 as their own Spheres (views where possible)."""
        m1 = min(m1, self.n_clumps)
        s0 = int(self.starts[m0])
        s1 = int(self.starts[m1]) if m1 < self.n_clumps else len(self.radii)
        return Spheres(
            centers=self.centers[s0:s1],
            radii=self.radii[s0:s1],
            clump=self.clump[s0:s1] - m0,
            n_clumps=m1 - m0,
            origin=self.origin[m0:m1],
            local=self.local[s0:s1],
            batched=self.batched,
            counts=self.counts[m0:m1],
            starts=self.starts[m0:m1] - s0,
            regular=self.regular,
            first_clump=self.first_clump + m0,
        )


_REAL_KINDS = "fiu"  # numpy dtype kinds taken as real numbers (float, signed and unsigned int)


def _refuse_kind(kind, name):
    what = {"b": "booleans", "c": "complex numbers", "U": "strings", "S": "bytes", "M": "dates",
            "m": "time deltas", "V": "records"}.get(kind, f"values of dtype kind {kind!r}")
    raise ValueError(f"{name} must be numeric: real numbers, got {what}")


def _object_to_float(a, name):
    """An object array (Python ints beyond int64, Fractions, mixtures) as float64, or ValueError."""
    for x in a.flat:
        if isinstance(x, (bool, np.bool_, str, bytes, complex, np.complexfloating)):
            _refuse_kind(np.asarray(x).dtype.kind, name)
    try:
        return a.astype(np.float64)
    except OverflowError:
        raise ValueError(f"{name} holds a number too large for float64 (|x| > ~1.8e308)") from None
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric array-like: {exc}") from None


def _as_float_array(x, name):
    """x as a float64 array; booleans, complex numbers, strings and numbers beyond float64 raise ValueError."""
    if isinstance(x, np.ndarray) and x.dtype == np.float64:
        return x
    try:
        a = np.asarray(x)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"{name} must be numeric array-like: {exc}") from None
    if a.dtype.kind == "O":
        return _object_to_float(a, name)
    if a.dtype.kind not in _REAL_KINDS:
        _refuse_kind(a.dtype.kind, name)
    return a.astype(np.float64, copy=False)


def real_pieces(pieces) -> bool:
    """True if every array of a ragged batch is of a real numeric dtype (else _as_float_array explains)."""
    return all(isinstance(x, np.ndarray) and x.dtype.kind in _REAL_KINDS for x in pieces)


def _check_finite_positive(radii, name="radii"):
    if not np.all(np.isfinite(radii)):
        raise ValueError(f"{name} contains NaN or inf")
    if np.any(radii <= 0):
        bad = np.flatnonzero(radii.ravel() <= 0)[:5]
        raise ValueError(f"{name} must be > 0 (m); got non-positive value(s) at flat index {bad.tolist()}")


def check_density(density) -> float:
    if isinstance(density, (bool, np.bool_, str, bytes, complex, np.complexfloating)):
        raise ValueError(f"density must be a positive real number (kg/m^3), got {density!r}")
    try:
        rho = float(density)
    except OverflowError:
        raise ValueError(f"density is too large for float64 (> ~1.8e308 kg/m^3), got {density!r}") from None
    except (TypeError, ValueError):
        raise ValueError(f"density must be a positive number (kg/m^3), got {density!r}") from None
    if not np.isfinite(rho) or rho <= 0:
        raise ValueError(f"density must be a positive finite number (kg/m^3), got {density!r}")
    return rho


def normalize(centers, radii) -> Spheres:
    """Check and flatten clump input; see the module docstring for layouts."""
    ragged = (
        isinstance(centers, (list, tuple))
        and len(centers) > 0
        and all(np.ndim(c) == 2 for c in centers)
        and isinstance(radii, (list, tuple))
    )
    if ragged:
        if len(centers) != len(radii):
            raise ValueError(f"got {len(centers)} clumps of centers but {len(radii)} of radii")
        cs, rs = [], []
        for m, (c, r) in enumerate(zip(centers, radii)):
            c = _as_float_array(c, f"centers[{m}]")
            r = _as_float_array(r, f"radii[{m}]")
            if c.ndim != 2 or c.shape[1] != 3:
                raise ValueError(f"centers[{m}] must have shape (N, 3), got {c.shape}")
            if r.shape != (c.shape[0],):
                raise ValueError(f"radii[{m}] must have shape ({c.shape[0]},) to match centers[{m}], got {r.shape}")
            if c.shape[0] == 0:
                raise ValueError(f"clump {m} is empty (no spheres)")
            cs.append(c)
            rs.append(r)
        counts = np.array([len(r) for r in rs], dtype=np.int64)
        c_all = np.concatenate(cs, axis=0)
        r_all = np.concatenate(rs)
        batched = True
    else:
        c = _as_float_array(centers, "centers")
        r = _as_float_array(radii, "radii")
        if c.ndim == 2:
            batched = False
            if r.shape != (c.shape[0],):
                raise ValueError(f"radii must have shape ({c.shape[0]},) to match centers {c.shape}, got {r.shape}")
            c = c[None]
            r = r[None]
        elif c.ndim == 3:
            batched = True
        else:
            raise ValueError(f"centers must have shape (N, 3) or (M, N, 3), got {c.shape}")
        if c.shape[-1] != 3:
            raise ValueError(f"centers must have 3 coordinates in the last axis, got shape {c.shape}")
        if r.shape != c.shape[:-1]:
            want = c.shape[1:-1] if not batched else c.shape[:-1]
            raise ValueError(f"radii must have shape {want} to match centers {centers_shape(centers)}, got {np.shape(radii)}")
        if c.shape[0] == 0:
            raise ValueError("empty batch: no clumps")
        if c.shape[1] == 0:
            raise ValueError("empty clump: no spheres")
        M, N = c.shape[:2]
        counts = np.full(M, N, dtype=np.int64)
        c_all = c.reshape(-1, 3)
        r_all = r.reshape(-1)
    if not np.all(np.isfinite(c_all)):
        raise ValueError("centers contains NaN or inf")
    _check_finite_positive(r_all)
    M = len(counts)
    N = int(counts[0]) if np.all(counts == counts[0]) else 0
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    # origin: volume-weighted mean of sphere centres, accumulated relative to the first
    # sphere so that the sum involves only small numbers
    # radii ~1e103 and up overflow r^3 here: the result is then non-finite and the assembly raises
    # its documented "moments overflow float64" ValueError, without numpy warnings on the way
    with np.errstate(over="ignore", invalid="ignore"):
        r3 = r_all * r_all * r_all
    if N:
        c3 = c_all.reshape(M, N, 3)
        first = c3[:, 0, :]
        w = r3.reshape(M, N)
        with np.errstate(over="ignore", invalid="ignore"):
            w = w / _rowsum(w)[:, None]
        origin = first + _rowsum(w[:, :, None] * (c3 - first[:, None, :]))
        rel = (c3 - origin[:, None, :]).reshape(-1, 3)
        clump = np.repeat(np.arange(M), N)
        local = np.tile(np.arange(N), M)
    else:
        clump = np.repeat(np.arange(M), counts)
        local = np.arange(len(r_all)) - np.repeat(starts, counts)
        first = c_all[starts]
        rel0 = c_all - first[clump]
        w = r3 / np.repeat(np.add.reduceat(r3, starts), counts)
        origin = first + np.add.reduceat(w[:, None] * rel0, starts, axis=0)
        rel = c_all - origin[clump]
    return Spheres(
        centers=rel,
        radii=r_all,
        clump=clump,
        n_clumps=M,
        origin=origin,
        local=local,
        batched=batched,
        counts=counts,
        starts=starts,
        regular=N,
    )


def _rowsum(x):
    """x (M, N, ...) summed over axis 1; explicit adds for small N (numpy's small-axis sum is slow)."""
    if x.shape[1] > 16:
        return x.sum(axis=1)
    acc = x[:, 0].copy()
    for k in range(1, x.shape[1]):
        acc += x[:, k]
    return acc


def segment_sum(x, sph: Spheres):
    """Sum per-sphere values x (S, ...) over each clump -> (M, ...)."""
    if sph.regular:
        return _rowsum(x.reshape((sph.n_clumps, sph.regular) + x.shape[1:]))
    return np.add.reduceat(x, sph.starts, axis=0)


def centers_shape(centers):
    try:
        return np.shape(centers)
    except Exception:  # pragma: no cover - exotic input
        return "?"
