"""Validation and normalisation of clump input (no physics here).

One parser, :func:`flatten`, reads ``centers`` and ``radii`` in any of the three accepted layouts

* one clump: ``centers`` (N, 3), ``radii`` (N,)
* a regular batch: ``centers`` (M, N, 3), ``radii`` (M, N)
* a ragged batch: a sequence of M arrays (N_m, 3) and a sequence of M arrays (N_m,)

and stacks all spheres into flat arrays, or raises the ``ValueError`` that names the problem;
:func:`check_values` checks the numbers (the compiled methods leave that to the core and call it
only to word an error); :func:`check_density` checks ``density``.

The numpy methods take :func:`normalize`'s ``Spheres``: all spheres stacked (S, 3) and (S,), the clump
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


def _real_pieces(pieces) -> bool:
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


def flatten(centers, radii):
    """Check the layout of clump input and flatten it: the one parser of ``centers`` and ``radii``.

    Parameters
    ----------
    centers, radii : any of the three layouts of the module docstring.

    Returns
    -------
    tuple ``(c, r, starts, N, M, batched)``: all spheres stacked, ``c`` (S, 3) and ``r`` (S,)
    float64 (contiguous); ``starts`` (M + 1,) the first sphere of each clump and S for clumps of
    different sizes, else None; ``N`` the spheres per clump (0 for different sizes); ``M`` the
    number of clumps; ``batched`` True where the caller passed a batch.  A plain tuple: this runs
    once per ``mass_properties`` call, where a microsecond counts.

    Raises
    ------
    ValueError
        naming the first problem of layout, shape or number type.  The values (NaN, inf,
        radius <= 0) are :func:`check_values`' job.
    """
    if isinstance(centers, (list, tuple)) and isinstance(radii, (list, tuple)) and len(centers) > 0 \
            and all(np.ndim(c) == 2 for c in centers):
        return _flatten_ragged(centers, radii)
    try:
        c = _as_float_array(centers, "centers")
    except ValueError:
        if isinstance(centers, (list, tuple)):  # numpy's own error where the nesting is uneven inside a clump
            all(np.ndim(x) == 2 for x in centers)
        raise
    r = _as_float_array(radii, "radii")
    if c.ndim == 2 and c.shape[1] == 3 and r.shape == (c.shape[0],) and c.shape[0] > 0:
        return np.ascontiguousarray(c), np.ascontiguousarray(r), None, c.shape[0], 1, False
    if c.ndim == 3 and c.shape[2] == 3 and r.shape == c.shape[:2] and c.shape[0] > 0 and c.shape[1] > 0:
        M, N = c.shape[:2]
        return np.ascontiguousarray(c).reshape(M * N, 3), np.ascontiguousarray(r).reshape(M * N), None, N, M, True
    _raise_layout_error(c, r, centers, radii)


def _raise_layout_error(c, r, centers, radii):
    """The ValueError for one clump (N, 3) or a regular batch (M, N, 3) that :func:`flatten` refused."""
    if c.ndim == 2:
        if r.shape != (c.shape[0],):
            raise ValueError(f"radii must have shape ({c.shape[0]},) to match centers {c.shape}, got {r.shape}")
        c, r = c[None], r[None]
    elif c.ndim != 3:
        raise ValueError(f"centers must have shape (N, 3) or (M, N, 3), got {c.shape}")
    if c.shape[-1] != 3:
        raise ValueError(f"centers must have 3 coordinates in the last axis, got shape {c.shape}")
    if r.shape != c.shape[:-1]:
        raise ValueError(f"radii must have shape {c.shape[:-1]} to match centers {centers_shape(centers)}, "
                         f"got {np.shape(radii)}")
    if c.shape[0] == 0:
        raise ValueError("empty batch: no clumps")
    raise ValueError("empty clump: no spheres")


def _flatten_ragged(centers, radii):
    """:func:`flatten` for a sequence of M arrays (N_m, 3) and a sequence of M arrays (N_m,): one
    concatenation where every piece is well formed, else each piece checked in turn."""
    M = len(centers)
    if len(radii) != M:
        raise ValueError(f"got {len(centers)} clumps of centers but {len(radii)} of radii")
    if M == 1:  # one clump given as a batch of one (the YADE adapter's append_clump)
        try:
            c, r = _as_float_array(centers[0], ""), _as_float_array(radii[0], "")
        except ValueError:
            c = r = None
        if c is None or c.ndim != 2 or c.shape[1] != 3 or r.shape != (c.shape[0],) or c.shape[0] == 0:
            _checked_pieces(centers, radii)  # raises naming the piece
        return np.ascontiguousarray(c), np.ascontiguousarray(r), None, c.shape[0], 1, True
    pieces = (centers, radii) if _real_pieces(centers) and _real_pieces(radii) else _checked_pieces(centers, radii)
    try:
        nc = np.fromiter(map(len, pieces[0]), np.int64, M)
        nr = np.fromiter(map(len, pieces[1]), np.int64, M)
        c = np.concatenate(pieces[0], axis=0, dtype=np.float64)
        r = np.concatenate(pieces[1], axis=0, dtype=np.float64)
        well_formed = (np.array_equal(nc, nr) and not np.any(nc == 0) and c.ndim == 2 and c.shape[1:] == (3,)
                       and r.shape == (len(c),))
    except (TypeError, ValueError):
        well_formed = False
    if not well_formed:
        _checked_pieces(centers, radii)  # raises naming the piece
        raise ValueError("centers and radii do not form clumps of spheres")  # pragma: no cover
    starts = np.zeros(M + 1, np.int64)
    np.cumsum(nc, out=starts[1:])
    N = int(nc[0]) if np.all(nc == nc[0]) else 0
    return np.ascontiguousarray(c), r, (None if N else starts), N, M, True


def _checked_pieces(centers, radii):
    """The pieces of a ragged batch as float64 arrays, clump by clump; ValueError naming the first bad piece."""
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
    return cs, rs


def check_values(c, r):
    """ValueError where the flat centres ``c`` (S, 3) hold NaN or inf, or the flat radii ``r`` (S,)
    NaN, inf or a value <= 0 (the flat index of the first ones named)."""
    if not np.all(np.isfinite(c)):
        raise ValueError("centers contains NaN or inf")
    _check_finite_positive(r)


def normalize(centers, radii) -> Spheres:
    """Check and flatten clump input (:func:`flatten`, :func:`check_values`) into :class:`Spheres`,
    each clump about its origin; see the module docstring for layouts."""
    c_all, r_all, starts, N, M, batched = flatten(centers, radii)
    check_values(c_all, r_all)
    counts = np.full(M, N, dtype=np.int64) if starts is None else np.diff(starts)
    starts = starts[:-1] if starts is not None else np.arange(0, M * N, N, dtype=np.int64)
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
