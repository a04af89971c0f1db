"""YADE adapter: clumps that carry the exact mass properties from the moment they are built.

YADE (2023.02a, 2025.2) builds a clump's mass, centre of mass and inertia by summing its
member spheres (``discretization=0``: overlaps counted twice) or by voxelising
them (``discretization>0``: approximate and slow).  This module swaps one call
for the YADE one and the clump in the simulation has the properties
:func:`clumpprops.mass_properties` gives for the union of its spheres.

How (the *correction member*)
-----------------------------
``Clump::updateProperties`` sums each NON-spherical member with its own
``state.mass``, ``state.pos``, ``state.inertia`` and ``state.ori``.  Every
corrected clump gets one extra member, the correction: a body with the bare base
class ``Shape`` (no ``Bo1`` functor exists for it) and ``bounded=False``, so it
never has a bound, never enters collision detection and never makes a contact.
Its state holds exactly the difference "exact minus summed spheres":

* mass ``m_c = m_exact - sum(m_i)`` (negative where spheres overlap),
* position ``p_c`` such that the first moments add up to the exact centre of mass,
* principal moments and orientation such that the summed inertia tensor about the
  exact centre of mass equals the exact tensor (eigenvalues may be negative).

Its state is ``material.newAssocState()`` of the spheres' material (CpmState for CpmMat, ...)
and its ``mask`` the union of its spheres' mask bits.

YADE then computes mass, centre of mass, principal moments and axes itself, so the
correction is part of the scene: it is saved by ``O.save``/``O.saveTmp``, and a
later ``O.bodies.updateClumpProperties(discretization=0)`` reproduces the exact
values.  Member spheres are not touched: they keep their material (true density),
radius and world position.  Forces applied per member through the body's mass
(``GravityEngine``) act on the correction member too, so the clump receives the
exact weight ``m_exact g`` through the exact centre of mass.

The clump's life (docs/yade_adapter.md has the table): YADE's own release, add, erase and
update recompute a clump with whatever members it then has, so the correction would go stale
(or the summed mass reach zero and YADE abort).  :func:`release`, :func:`add_to_clump`,
:func:`erase` and :func:`update_clump_properties` neutralise the correction, let YADE do the
operation and correct the clump again; once this module is used, the same ``O.bodies`` methods
are routed through them for corrected clumps, ``deleteClumpMember``/``deleteClumpBody`` through
:func:`erase`, ``clump``/``appendClumped``/``addToClump`` refuse corrections and corrected clumps
they cannot keep exact (YADE would abort on ``M > 0`` or leave them stale), and
``clear``/``replace`` empty the registry (:func:`unguarded` gives YADE's own methods back).  Every
correction is recorded in ``O.tags["clumpprops.corrections*"]`` (a header and chunks of entries) with a fingerprint of its spheres,
and :func:`check` verifies the whole scene.

Nothing here is imported by ``import clumpprops``; YADE itself is imported inside
the functions, so this module works both in scripts run by the ``yade``
executable and after a plain ``import yade``.
"""
from __future__ import annotations

import contextlib
import gc
import hashlib
import math
import os
import struct
import warnings
from dataclasses import dataclass, field

import numpy as np

from .api import _CORE, DEFAULT_METHOD, mass_properties
from .core import _core

_adapter_clump = _core.adapter_clump  # module-level so a test can wrap it

_blake2b = hashlib.blake2b

__all__ = [
    "append_clump",
    "append_clumps",
    "correct_clump",
    "correct_clumps",
    "correct_all_clumps",
    "replace_by_clumps",
    "text_clumps",
    "export_text_clumps",
    "correction_id",
    "sphere_member_ids",
    "is_correction",
    "exact_properties",
    "clump_errors",
    "set_clump_velocity",
    "release",
    "add_to_clump",
    "erase",
    "update_clump_properties",
    "check",
    "CheckReport",
    "unguarded",
    "ClumpAdapterError",
]


class ClumpAdapterError(ValueError):
    """Bad input to the YADE adapter; the message names the offending body id.

    Raised before anything in the scene is modified.
    """


# --------------------------------------------------------------------------- YADE access (lazy)


class _Y:
    """The handful of YADE objects used here, imported on first use."""

    _loaded = False

    @classmethod
    def load(cls):
        if not cls._loaded:
            try:
                import yade  # noqa: F401  (initialises YADE on a plain import)
            except ModuleNotFoundError as e:
                if e.name != "yade":
                    raise
                raise ModuleNotFoundError(
                    "clumpprops.yade needs YADE, which is not on PyPI: install Debian's or Ubuntu's `yade` package "
                    "and run with its Python (`yade -x script.py`, or /usr/bin/python3 with YADE's py folder on "
                    "sys.path; docs/yade_adapter.md)", name="yade") from None
            from yade import wrapper
            from yade.minieigenHP import Matrix3, Quaternion, Vector3

            cls.O = yade.O
            cls.Body = wrapper.Body
            cls.Shape = wrapper.Shape
            cls.State = wrapper.State
            cls.Sphere = wrapper.Sphere
            cls.Clump = wrapper.Clump
            cls.Vector3 = Vector3
            cls.Quaternion = Quaternion
            cls.Matrix3 = Matrix3
            cls._loaded = True
            _install_guards(cls)
        return cls


def is_correction(body) -> bool:
    """True if ``body`` is a correction member made by this module.

    A correction is a clump member whose shape is exactly the base class ``Shape``
    (no YADE body has that for any other purpose: it has no bound, collision or
    rendering functor) and which is not bounded.
    """
    Y = _Y.load()
    return body is not None and type(body.shape) is Y.Shape and not body.bounded and body.isClumpMember


def _vec(v):
    return np.array([float(v[0]), float(v[1]), float(v[2])])


def _rotation(q):
    """Rotation matrix (numpy) of a minieigen quaternion."""
    m = q.toRotationMatrix()
    return np.array([[float(m[i, j]) for j in range(3)] for i in range(3)])


# --------------------------------------------------------------------------- the correction member (no YADE objects)


def _sphere_moments(centers, radii, densities):
    """Mass (N,) and own inertia (N,) of member spheres exactly as YADE sums them."""
    vol = (4.0 / 3.0) * math.pi * radii**3.0
    m = densities * vol
    return m, 0.4 * m * radii**2


def _pax(d):
    """Parallel-axis matrices |d|^2 1 - d d^T for d (..., 3)."""
    P = -d[..., :, None] * d[..., None, :]
    sq = np.einsum("...i,...i->...", d, d)
    for k in range(3):
        P[..., k, k] += sq
    return P


def correction_terms(centers, radii, densities, mass, com, inertia, strict=True):
    """State of the correction members of a batch of clumps (pure numpy).

    centers: list of (N_m, 3) world positions of the member spheres; radii: list of (N_m,);
    densities: list of (N_m,) material densities (as YADE reads them);
    mass (M,), com (M, 3), inertia (M, 3, 3): the target (exact) properties.

    Returns (mass_c (M,), offset_c (M, 3), moments_c (M, 3), axes_c (M, 3, 3) right-handed
    columns): the correction sits at ``com + offset_c`` and spheres + correction sum, the
    way ``Clump::updateProperties`` sums them, to the target.  All sums are taken about the
    target centre of mass, so nothing is lost to cancellation however far the clump is from
    the origin.

    The correction's offset cancels the spheres' first moment: ``m_c * offset = -S``.  Where
    ``|m_c| * reach`` is below the round-off of ``S`` (no real overlap: touching or separate
    spheres, one sphere) the offset is 0, which moves the centre of mass by round-off only.
    Both tests allow for a density spread between the spheres (accepted up to 1e-12; the target
    uses the first sphere's density): it adds sum m_i |rho_i - rho_0| / rho_i to the round-off of
    m_c, and that times |d_i| + r_i to the round-off of S.
    ``strict`` (the exact methods: "exact", "pairwise", "sum"): the target must be a union of
    the spheres, so the excess "summed minus union" is a non-negative distribution inside the
    clump: ``m_c <= 0`` and ``|offset| <=`` the clump's reach about its centre of mass.  A
    target that breaks either is a library error and raises :class:`ClumpAdapterError`
    naming the clump (index in the batch); nothing is clamped.
    """
    counts = np.array([len(r) for r in radii])
    x = np.concatenate([np.asarray(c, float).reshape(-1, 3) for c in centers])
    r = np.concatenate([np.asarray(a, float).ravel() for a in radii])
    rho = np.concatenate([np.asarray(a, float).ravel() for a in densities])
    return _correction_flat(x, r, rho, counts, mass, com, inertia, strict)


def _heavy_error(k, mass, m_s):
    return ClumpAdapterError(
        f"clump {k} of the batch: target mass {mass!r} exceeds the summed spheres' {m_s!r}; "
        "the union of the spheres cannot be heavier (library error)"
    )


def _outside_error(k, norm, reach):
    return ClumpAdapterError(
        f"clump {k} of the batch: the correction's centroid would lie {norm:.6g} m from the centre of "
        f"mass, outside the clump (reach {reach:.6g} m); the target centre of mass is inconsistent "
        "with the spheres (library error)"
    )


def _correction_flat(x, r, rho, counts, mass, com, inertia, strict=True):
    """:func:`correction_terms` on flat arrays: x (S, 3), r (S,), rho (S,), counts (M,) spheres per clump."""
    M = len(counts)
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    mass = np.asarray(mass, float).reshape(M)
    com = np.asarray(com, float).reshape(M, 3)
    inertia = np.asarray(inertia, float).reshape(M, 3, 3)
    m_i, j_i = _sphere_moments(x, r, rho)
    d = x - np.repeat(com, counts, axis=0)  # sphere centres relative to the exact COM
    m_s = np.add.reduceat(m_i, starts)
    S = np.add.reduceat(m_i[:, None] * d, starts, axis=0)  # first moment of the spheres about the COM
    I_s = np.add.reduceat(m_i[:, None, None] * _pax(d) + j_i[:, None, None] * np.eye(3), starts, axis=0)
    m_c = mass - m_s
    dist = np.linalg.norm(d, axis=1) + r
    reach = np.maximum.reduceat(dist, starts)
    # round-off of S (and of m_c * offset): a few ulps of sum m_i (|d_i| + r_i), plus what a density
    # spread (accepted up to 1e-12; the target uses the first sphere's density) puts into m_c and S
    eps = np.finfo(float).eps
    rho0 = np.repeat(rho[starts], counts)
    m_spread = m_i * np.abs(rho - rho0) / rho
    s_noise = 64.0 * eps * np.add.reduceat(m_i * dist, starts) + np.add.reduceat(m_spread * dist, starts)
    m_noise = 64.0 * eps * m_s + np.add.reduceat(m_spread, starts)
    roundoff = np.abs(m_c) * reach <= s_noise
    safe = np.where(roundoff, 1.0, m_c)
    off = np.where(roundoff[:, None], 0.0, -S / safe[:, None])
    if strict:
        heavy = m_c > m_noise
        if np.any(heavy):
            k = int(np.flatnonzero(heavy)[0])
            raise _heavy_error(k, mass[k], m_s[k])
        norm = np.linalg.norm(off, axis=1)
        tol = reach * 1e-9 + s_noise / np.where(roundoff, 1.0, np.abs(m_c))
        outside = ~roundoff & (norm > reach + tol)
        if np.any(outside):
            k = int(np.flatnonzero(outside)[0])
            raise _outside_error(k, norm[k], reach[k])
    J = inertia - I_s - m_c[:, None, None] * _pax(off)
    J = 0.5 * (J + np.swapaxes(J, 1, 2))
    w, V = np.linalg.eigh(J)
    flip = np.linalg.det(V) < 0
    V[flip, :, 2] *= -1.0
    return m_c, off, w, V


_EPS = float(np.finfo(float).eps)
_FOUR_THIRDS_PI = (4.0 / 3.0) * math.pi


def _correction_one(pts, radii, rhos, mass, com, inertia, strict=True, k=0):
    """:func:`correction_terms` for ONE clump in plain Python floats: the small-batch path where the
    compiled twin ``_core.adapter_clump`` does not apply (the baseline methods) or declines (it then
    raises the documented error here), and the reference that twin is tested against.  pts:
    [(x, y, z), ...], radii, rhos: lists; mass,
    com (3,), inertia (3, 3) nested lists.  Same formulas, checks and messages (``k``: index in the
    batch); returns (m_c, offset [3], moments [3], axes (3, 3) ndarray, right-handed columns)."""
    cx, cy, cz = com
    sqrt = math.sqrt
    m_s = sx = sy = sz = 0.0
    ixx = iyy = izz = ixy = ixz = iyz = 0.0
    reach = smd = sp = spd = 0.0
    d0 = rhos[0]
    for (px, py, pz), ri, di in zip(pts, radii, rhos):
        mi = di * (_FOUR_THIRDS_PI * ri**3.0)
        ji = 0.4 * mi * ri**2
        dx, dy, dz = px - cx, py - cy, pz - cz
        m_s += mi
        sx += mi * dx
        sy += mi * dy
        sz += mi * dz
        sq = dx * dx + dy * dy + dz * dz
        ixx += mi * (sq - dx * dx) + ji
        iyy += mi * (sq - dy * dy) + ji
        izz += mi * (sq - dz * dz) + ji
        ixy -= mi * (dx * dy)
        ixz -= mi * (dx * dz)
        iyz -= mi * (dy * dz)
        dist = sqrt(sq) + ri
        smd += mi * dist
        if di != d0:  # a density spread (see correction_terms)
            spread = mi * abs(di - d0) / di
            sp += spread
            spd += spread * dist
        if dist > reach:
            reach = dist
    m_c = mass - m_s
    s_noise = 64.0 * _EPS * smd + spd
    if abs(m_c) * reach <= s_noise:  # round-off: no offset (see correction_terms)
        roundoff, ox, oy, oz = True, 0.0, 0.0, 0.0
    else:
        roundoff, ox, oy, oz = False, -sx / m_c, -sy / m_c, -sz / m_c
    if strict:
        if m_c > 64.0 * _EPS * m_s + sp:
            raise _heavy_error(k, mass, m_s)
        norm = sqrt(ox * ox + oy * oy + oz * oz)
        if not roundoff and norm > reach + (reach * 1e-9 + s_noise / abs(m_c)):
            raise _outside_error(k, norm, reach)
    osq = ox * ox + oy * oy + oz * oz
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = inertia
    j01 = 0.5 * ((a01 - ixy + m_c * (ox * oy)) + (a10 - ixy + m_c * (oy * ox)))
    j02 = 0.5 * ((a02 - ixz + m_c * (ox * oz)) + (a20 - ixz + m_c * (oz * ox)))
    j12 = 0.5 * ((a12 - iyz + m_c * (oy * oz)) + (a21 - iyz + m_c * (oz * oy)))
    J = np.array([
        [a00 - ixx - m_c * (osq - ox * ox), j01, j02],
        [j01, a11 - iyy - m_c * (osq - oy * oy), j12],
        [j02, j12, a22 - izz - m_c * (osq - oz * oz)],
    ])
    w, V = np.linalg.eigh(J)
    (v00, v01, v02), (v10, v11, v12), (v20, v21, v22) = V.tolist()
    if v00 * (v11 * v22 - v12 * v21) - v01 * (v10 * v22 - v12 * v20) + v02 * (v10 * v21 - v11 * v20) < 0:
        V[:, 2] *= -1.0
    return m_c, [ox, oy, oz], w.tolist(), V


# --------------------------------------------------------------------------- reading the scene


def _body(bid, what="body"):
    Y = _Y.load()
    try:
        i = int(bid)
    except (TypeError, ValueError):
        raise ClumpAdapterError(f"{what} id {bid!r} is not an integer") from None
    if isinstance(bid, float) and bid != i:
        raise ClumpAdapterError(f"{what} id {bid!r} is not an integer")
    if i < 0 or i >= len(Y.O.bodies) or Y.O.bodies[i] is None:
        raise ClumpAdapterError(f"body #{i} does not exist (O.bodies has {len(Y.O.bodies)} slots)")
    return Y.O.bodies[i]


def _split_members(clump_body):
    """(sphere member bodies, correction member or None) of a clump; raises on anything else."""
    Y = _Y.load()
    cid = clump_body.id
    spheres, corr = [], []
    for mid in sorted(int(k) for k in clump_body.shape.members.keys()):
        b = Y.O.bodies[mid]
        if b is None:
            raise ClumpAdapterError(f"clump #{cid}: member #{mid} does not exist")
        if type(b.shape) is Y.Sphere or isinstance(b.shape, Y.Sphere):
            if b.material is None:
                raise ClumpAdapterError(f"clump #{cid}: sphere member #{mid} has no material (density unknown)")
            spheres.append(b)
        elif is_correction(b):
            corr.append(b)
        else:
            kind = type(b.shape).__name__ if b.shape is not None else "no shape"
            raise ClumpAdapterError(
                f"clump #{cid}: member #{mid} is not a sphere ({kind}); only clumps of spheres can be corrected"
            )
    if not spheres:
        raise ClumpAdapterError(f"clump #{cid} has no sphere members")
    if len(corr) > 1:
        raise ClumpAdapterError(f"clump #{cid} has {len(corr)} correction members {[b.id for b in corr]}; expected at most one")
    return spheres, (corr[0] if corr else None)


def _clump_density(label, bodies):
    rho = [float(b.material.density) for b in bodies]
    r0 = rho[0]
    if not all(math.isfinite(p) and p > 0 for p in rho):
        bad = [b.id for b, p in zip(bodies, rho) if not (math.isfinite(p) and p > 0)]
        raise ClumpAdapterError(f"{label}: sphere(s) {bad} have non-positive density")
    if any(abs(p - r0) > 1e-12 * r0 for p in rho):
        raise ClumpAdapterError(
            f"{label}: member spheres have different densities {sorted(set(rho))} "
            f"(ids {[b.id for b in bodies]}); the exact union needs one density"
        )
    return rho


def _geometry(bodies):
    x = np.array([[p[0], p[1], p[2]] for p in (b.state.pos for b in bodies)], dtype=float)
    r = np.array([b.shape.radius for b in bodies], dtype=float)
    return x, r


def exact_properties(clump_id, method=DEFAULT_METHOD):
    """The library's :class:`~clumpprops.MassProperties` of a clump's member spheres, where they are now."""
    cb = _body(clump_id, "clump")
    if not cb.isClump:
        raise ClumpAdapterError(f"body #{cb.id} is not a clump")
    spheres, _ = _split_members(cb)
    rho = _clump_density(f"clump #{cb.id}", spheres)
    x, r = _geometry(spheres)
    return mass_properties(x, r, density=rho[0], method=method)


def _targets(xs, rs, rhos, method):
    """Target properties of a ragged batch: mass (M,), com (M, 3), inertia (M, 3, 3) and the scale of
    each inertia tensor (largest |principal moment|), one library call per density; nested python
    lists instead of arrays for a small batch (M <= _SMALL).

    xs: list of (N_m, 3) arrays, or one (M, N, 3) array when every clump has N spheres; rs likewise;
    rhos: per clump, its spheres' densities (equal to 1e-12: the first one is used)."""
    M = len(xs)
    dens = [rho[0] for rho in rhos]
    d0 = dens[0]
    if all(d == d0 for d in dens):  # one density (the usual case): one call
        mp = mass_properties(xs, rs, density=d0, method=method)
        if M <= _SMALL:
            return (mp.mass.tolist(), mp.center_of_mass.tolist(), mp.inertia.tolist(),
                    [max(abs(a) for a in row) for row in mp.principal_moments.tolist()])
        return mp.mass, mp.center_of_mass, mp.inertia, np.max(np.abs(mp.principal_moments), axis=1)
    mass, com, inertia, scale = np.empty(M), np.empty((M, 3)), np.empty((M, 3, 3)), np.empty(M)
    dens = np.array(dens)
    for value in np.unique(dens):
        idx = np.flatnonzero(dens == value)
        mp = mass_properties([xs[i] for i in idx], [rs[i] for i in idx], density=value, method=method)
        mass[idx] = mp.mass
        com[idx] = mp.center_of_mass
        inertia[idx] = mp.inertia
        scale[idx] = np.max(np.abs(mp.principal_moments), axis=1)
    if M <= _SMALL:
        return mass.tolist(), com.tolist(), inertia.tolist(), scale.tolist()
    return mass, com, inertia, scale


_SMALL = 2  # batches up to this many clumps take the plain-float path (numpy's fixed cost per call dominates)


def _corrections(xs, rs, rhos, pts, radii, method):
    """Targets and correction terms of a batch, before anything in the scene changes.

    xs, rs: per clump (N_m, 3) and (N_m,) arrays (or stacked (M, N, 3), (M, N) when all N_m are
    equal; None for a small batch: made from pts and radii if needed); rhos: per clump lists of the
    spheres' densities; pts, radii: per clump lists of (x, y, z) and of radii (python floats).
    Returns (targets, terms): targets = (mass, com, inertia, scale) as from :func:`_targets` (lists
    for a small batch); terms = python lists (m_c [M], offset [M][3], moments [M][3]) and the axes,
    (M, 3, 3), a list of M (3, 3) arrays, or (small batch) nested lists.  A small batch with a core
    method takes one ``_core.adapter_clump`` call per clump (targets and terms together, the
    formulas of :func:`_correction_one`); anything it declines goes the general way, which raises."""
    strict = method in _STRICT
    M = len(rhos)
    if M <= _SMALL and method in _CORE:  # one core call per clump on the python lists: no numpy arrays
        code = _CORE[method]
        fast = [_adapter_clump(code, pts[k], radii[k], rhos[k], strict) for k in range(M)]
        if None not in fast:  # else the general path below raises the documented error
            return (([f[0] for f in fast], [list(f[1:4]) for f in fast], [[f[4:7], f[7:10], f[10:13]] for f in fast],
                     [f[13] for f in fast]),
                    ([f[14] for f in fast], [list(f[15:18]) for f in fast], [list(f[18:21]) for f in fast],
                     [[f[21:24], f[24:27], f[27:30]] for f in fast]))
    if xs is None:
        xs, rs = [np.array(p, dtype=float) for p in pts], [np.array(r, dtype=float) for r in radii]
    mass, com, inertia, scale = _targets(xs, rs, rhos, method)
    if M <= _SMALL:  # lists (see _targets)
        m_c, off, w, V = [], [], [], []
        for k in range(M):
            t = _correction_one(pts[k], radii[k], rhos[k], mass[k], com[k], inertia[k], strict, k)
            m_c.append(t[0])
            off.append(t[1])
            w.append(t[2])
            V.append(t[3])
        return (mass, com, inertia, scale), (m_c, off, w, V)
    counts = np.array([len(rho) for rho in rhos])
    x = np.asarray(xs, float).reshape(-1, 3) if isinstance(xs, np.ndarray) else np.concatenate(xs)
    r = np.asarray(rs, float).ravel() if isinstance(rs, np.ndarray) else np.concatenate(rs)
    rho = np.fromiter((p for rho in rhos for p in rho), float, int(counts.sum()))
    m_c, off, w, V = _correction_flat(x, r, rho, counts, mass, com, inertia, strict)
    return (mass, com, inertia, scale), (m_c.tolist(), off.tolist(), w.tolist(), V)


def _quaternions(V):
    """Unit quaternions (M, 4) as (w, x, y, z) of the rotations A = V^T (V (M, 3, 3): right-handed
    eigenvector columns): the ``ori`` that makes ``Clump::updateProperties`` add V diag(w) V^T
    (it adds R^T diag(w) R with R = ori.toRotationMatrix()).  Largest-component branch per row,
    as Eigen's Quaternion(Matrix3)."""
    A = np.swapaxes(V, 1, 2)
    a00, a11, a22 = A[:, 0, 0], A[:, 1, 1], A[:, 2, 2]
    tr = a00 + a11 + a22
    sq = np.stack([1.0 + tr, 1.0 + a00 - a11 - a22, 1.0 - a00 + a11 - a22, 1.0 - a00 - a11 + a22], axis=1)
    big = np.argmax(sq, axis=1)
    s = 2.0 * np.sqrt(np.maximum(sq[np.arange(len(A)), big], 0.5))  # the largest is >= 1 for a rotation
    d21, d02, d10 = A[:, 2, 1] - A[:, 1, 2], A[:, 0, 2] - A[:, 2, 0], A[:, 1, 0] - A[:, 0, 1]
    p01, p02, p12 = A[:, 0, 1] + A[:, 1, 0], A[:, 0, 2] + A[:, 2, 0], A[:, 1, 2] + A[:, 2, 1]
    q = np.stack([
        np.choose(big, [0.25 * s, d21 / s, d02 / s, d10 / s]),  # w
        np.choose(big, [d21 / s, 0.25 * s, p01 / s, p02 / s]),  # x
        np.choose(big, [d02 / s, p01 / s, 0.25 * s, p12 / s]),  # y
        np.choose(big, [d10 / s, p02 / s, p12 / s, 0.25 * s]),  # z
    ], axis=1)
    return q / np.linalg.norm(q, axis=1)[:, None]


def _state_row(st):
    """(mass, pos, inertia, ori as x, y, z, w) of a YADE state, as floats (indexing, not iteration:
    iterating minieigen objects goes through IndexError, which is slow)."""
    p, w, q = st.pos, st.inertia, st.ori
    return (st.mass, p[0], p[1], p[2], w[0], w[1], w[2], q[0], q[1], q[2], q[3])


def _state_errors(Y, cids, mass, com, inertia, scale=None, rows=None):
    """Relative errors (mass, centre of mass / radius of gyration, inertia / largest |moment|) of
    YADE's state of each clump against targets (M,), (M, 3), (M, 3, 3); arrays of shape (M,).

    ``scale``: the largest |principal moment| of each target (computed if not given); ``rows``:
    the clumps' states as read by :func:`_state_row` (read from the scene if not given)."""
    M = len(cids)
    if rows is None:
        bodies = Y.O.bodies
        rows = [_state_row(bodies[cid].state) for cid in cids]
    if scale is None:
        scale = np.max(np.abs(np.linalg.eigvalsh(inertia)), axis=1)
    if M <= _SMALL:
        errs = _errors_small(rows, mass, com, inertia, scale)
        return tuple(np.array(e, dtype=float) for e in zip(*errs))
    a = np.array(rows, dtype=float).reshape(M, 11)
    m_y, c_y, w_y = a[:, 0], a[:, 1:4], a[:, 4:7]
    R = _rotations(a[:, 7:11])
    I_y = np.einsum("kij,kj,klj->kil", R, w_y, R)
    mass = np.asarray(mass, float)
    scale = np.maximum(scale, 1e-300)
    tr = np.maximum(np.trace(inertia, axis1=1, axis2=2), 0.0)
    gyr = np.where(mass > 0, np.sqrt(tr / (2.0 * np.where(mass > 0, mass, 1.0))), 1.0)
    e_m = np.abs(m_y - mass) / np.abs(mass)
    e_c = np.linalg.norm(c_y - com, axis=1) / np.maximum(gyr, 1e-300)
    e_i = np.max(np.abs(I_y - inertia), axis=(1, 2)) / scale
    return e_m, e_c, e_i


def _errors_small(rows, mass, com, inertia, scale):
    """[(e_m, e_c, e_i), ...] of a small batch, one clump at a time in plain floats."""
    def lst(a):
        return a if isinstance(a, list) else np.asarray(a).tolist()

    return [_errors_one(*args) for args in zip(rows, lst(mass), lst(com), lst(inertia), lst(scale))]


def _errors_one(row, mass, com, inertia, scale):
    """:func:`_state_errors` of one clump in plain floats: row from :func:`_state_row`, targets as lists."""
    m, px, py, pz, w0, w1, w2, x, y, z, w = row
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    R = ((1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)),
         (2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)),
         (2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)))
    e_i = 0.0
    for Ri, Ti in zip(R, inertia):
        a, b, c = Ri[0] * w0, Ri[1] * w1, Ri[2] * w2
        for Rl, t in zip(R, Ti):
            e = abs(a * Rl[0] + b * Rl[1] + c * Rl[2] - t)
            if e > e_i or e != e:  # a NaN stays (and fails the check)
                e_i = e
    tr = max(inertia[0][0] + inertia[1][1] + inertia[2][2], 0.0)
    gyr = math.sqrt(tr / (2.0 * mass)) if mass > 0 else 1.0
    e_m = abs(m - mass) / abs(mass) if mass else math.inf
    e_c = math.sqrt((px - com[0]) ** 2 + (py - com[1]) ** 2 + (pz - com[2]) ** 2) / max(gyr, 1e-300)
    return e_m, e_c, e_i / max(scale, 1e-300)


def _correction_mask(spheres):
    """Bitwise OR of the spheres' masks.  Engines select a body by mask when ``mask & M != 0``
    (``GravityEngine`` and the other field appliers, which weigh clump members one by one): an engine
    that selects every sphere of the clump shares a bit with each of them, hence with their union,
    and so selects the correction too; an engine that selects none of the spheres shares no bit
    with the union and skips the correction.  (``NewtonIntegrator``'s mask looks at the clump body,
    ``VTKRecorder`` never exports the correction.)"""
    m = 0
    for b in spheres:
        m |= int(b.mask)
    return m


def _correction_shape(Y):
    """The bare ``Shape`` every correction body points to (one object: a bare Shape holds no data that
    matters to YADE, it has no bound, collision or rendering functor; sharing it saves a construction
    per clump)."""
    sh = getattr(Y, "corr_shape", None)
    if sh is None:
        sh = Y.corr_shape = Y.Shape()
    return sh


_PLAIN_STATE = {}  # material class -> True if its newAssocState() is a plain State (Body()'s own)


def _new_correction(Y, spheres, mat=None, mask=None):
    """A correction body for a clump of ``spheres``: bare ``Shape``, unbounded, the spheres' material
    with the state class that material expects (``material.newAssocState()``: CpmState for CpmMat,
    JCFpmState for JCFpmMat, ...), the union of the spheres' masks.  Its mass properties are set later.
    ``mat``, ``mask``: the first sphere's material and that mask, if already known."""
    if mat is None:
        mat = spheres[0].material
    b = Y.Body()
    b.shape = _correction_shape(Y)
    b.material = mat
    plain = _PLAIN_STATE.get(type(mat))
    if not plain:  # a new Body() has a plain State already
        st = mat.newAssocState()
        if plain is None:
            _PLAIN_STATE[type(mat)] = type(st) is Y.State
        b.state = st
    b.bounded = False
    b.mask = _correction_mask(spheres) if mask is None else mask
    return b


def _set_correction_state(Y, st, m, p, w, V):
    V3 = Y.Vector3
    st.mass = float(m)
    st.pos = V3(float(p[0]), float(p[1]), float(p[2]))
    st.inertia = V3(float(w[0]), float(w[1]), float(w[2]))
    # Clump::updateProperties adds R^T diag(w) R with R = ori.toRotationMatrix(); we want V diag(w) V^T
    q = Y.Quaternion(Y.Matrix3(*[float(a) for a in np.asarray(V).T.ravel()]))
    q.normalize()
    st.ori = q


def _neutralize(Y, corr):
    """Zero mass and inertia: YADE's next update of the clump sums its spheres only (positive mass,
    never the `M > 0` abort), whatever members it gains or loses."""
    if corr is not None:
        st = corr.state
        st.mass = 0.0
        st.inertia = Y.Vector3(0.0, 0.0, 0.0)


# --------------------------------------------------------------------------- registry (saved with the scene)
#
# Format 2 (this version): O.tags["clumpprops.corrections"] holds one header line
#     "#clumpprops registry v2 chunks=<n> token=<t>"
# and O.tags["clumpprops.corrections.<i>"] (i < n) hold the entries, at most _CHUNK each, one line
#     "<clump id> <correction id> <fingerprint> <method>"
# A build rewrites only the chunks it touched and the header: the cost of recording one clump does
# not grow with the number of clumps in the scene (format 1 rewrote every entry on every call).
# The header's token changes with every write, so comparing it with the cached one tells whether the
# scene (O.load, O.loadTmp, O.reset, another scene) still holds what this process last wrote.
# Format 1 (before): the entries themselves in O.tags["clumpprops.corrections"]; read as such and
# rewritten as format 2 on the next write.  Fingerprints carry their scheme: "b2:<16 hex>" (blake2b of
# the sphere records, format 2) or 16 hex digits (sha1 of their text, format 1).

_TAG = "clumpprops.corrections"
_HEADER = "#clumpprops registry v2"
_CHUNK = 256
_STRICT = ("exact", "pairwise", "sum")
_token = [os.urandom(6).hex(), 0]


class _Registry(dict):
    """{clump id: (correction id, fingerprint, method)} with its O.tags layout: the chunk of each
    entry, each chunk's entry lines and text, and which chunks must be written back."""

    def __init__(self):
        super().__init__()
        self.chunk_of = {}  # clump id -> chunk index
        self.chunks = []  # per chunk: {clump id: line}
        self.texts = []  # per chunk: its text as last written, or None (to be joined)
        self.tails = []  # per chunk: lines appended since (texts[k] + "".join(tails[k]) is current)
        self.dirty = set()  # chunks to write
        self.header = ""  # the header this object matches in O.tags
        self.changed = False  # mutated since read or written

    def _new_chunk(self):
        self.chunks.append({})
        self.texts.append("")
        self.tails.append([])
        return len(self.chunks) - 1

    def __setitem__(self, cid, rec):
        line = f"{cid} {rec[0]} {rec[1]} {rec[2]}\n"
        k = self.chunk_of.get(cid)
        if k is None:
            k = len(self.chunks) - 1
            if k < 0 or len(self.chunks[k]) >= _CHUNK:
                k = self._new_chunk()
            self.chunk_of[cid] = k
            if self.texts[k] is not None:
                self.tails[k].append(line)
        else:
            self.texts[k] = None
        self.chunks[k][cid] = line
        super().__setitem__(cid, rec)
        self.dirty.add(k)
        self.changed = True

    def set_many(self, cids, corr_ids, fps, method):
        """``self[cid] = (corr_id, fp, method)`` for many clumps; new ids (a build's) in bulk, chunk
        by chunk, ids already present (a reused id) one by one."""
        known = self.chunk_of
        if any(cid in known for cid in cids):
            for cid, corr_id, fp in zip(cids, corr_ids, fps):
                self[cid] = (corr_id, fp, method)
            return
        recs = [(c, f, method) for c, f in zip(corr_ids, fps)]
        lines = [f"{cid} {c} {f} {method}\n" for cid, c, f in zip(cids, corr_ids, fps)]
        dict.update(self, zip(cids, recs))
        a, n = 0, len(cids)
        while a < n:
            k = len(self.chunks) - 1
            if k < 0 or len(self.chunks[k]) >= _CHUNK:
                k = self._new_chunk()
            b = min(n, a + _CHUNK - len(self.chunks[k]))
            self.chunks[k].update(zip(cids[a:b], lines[a:b]))
            known.update(dict.fromkeys(cids[a:b], k))
            if self.texts[k] is not None:
                self.tails[k].extend(lines[a:b])
            self.dirty.add(k)
            a = b
        self.changed = True

    def pop(self, cid, *default):
        k = self.chunk_of.pop(cid, None)
        if k is not None:
            del self.chunks[k][cid]
            self.texts[k] = None
            self.dirty.add(k)
            self.changed = True
        return super().pop(cid, *default)

    def text(self, k):
        t = self.texts[k]
        if t is None:
            t = "".join(self.chunks[k].values())
        elif self.tails[k]:
            t += "".join(self.tails[k])
        self.texts[k] = t
        self.tails[k] = []
        return t

    def _add_parsed(self, text, k, what):
        for n, line in enumerate(text.splitlines(), 1):
            f = line.split()
            if not f or line.startswith("#"):
                continue
            if len(f) != 4:
                raise ClumpAdapterError(
                    f"the clumpprops registry in O.tags[{what!r}] is damaged (line {n}: {line!r}); "
                    "run cy.correct_all_clumps() to rebuild it"
                )
            cid = int(f[0])
            dict.__setitem__(self, cid, (int(f[1]), f[2], f[3]))
            self.chunk_of[cid] = k
            self.chunks[k][cid] = line + "\n"

    @classmethod
    def parse(cls, Y, head):
        """The registry of the current scene, whose header tag reads ``head``."""
        reg = cls()
        reg.header = head
        tags = Y.O.tags
        if head.startswith(_HEADER):
            fields = dict(f.split("=", 1) for f in head.split()[3:] if "=" in f)
            for k in range(int(fields.get("chunks", 0))):
                key = f"{_TAG}.{k}"
                try:
                    text = tags[key]
                except KeyError:
                    raise ClumpAdapterError(
                        f"the clumpprops registry in O.tags is damaged: {key!r} is missing; "
                        "run cy.correct_all_clumps() to rebuild it"
                    ) from None
                reg._add_parsed(text, reg._new_chunk(), key)
                reg.texts[k] = text
        elif head.startswith("#clumpprops registry"):
            raise ClumpAdapterError(
                f"the clumpprops registry in O.tags has an unknown format ({head.split(chr(10))[0]!r}): "
                "the scene was saved by a newer clumpprops"
            )
        elif head:  # format 1: every entry in the one tag; rewritten as format 2 on the next write
            old = _Registry()
            old._add_parsed(head, old._new_chunk(), _TAG)
            for cid, rec in old.items():
                reg[cid] = rec
            reg.changed = False
        return reg


_cache = {"reg": _Registry()}


def _registry():
    """The scene's registry, parsed from ``O.tags`` (cached while the header is the one last seen).

    Returns the cached object itself: mutate it and call :func:`_save_registry`."""
    Y = _Y.load()
    tags = Y.O.tags
    try:
        head = tags[_TAG]
    except KeyError:
        head = ""
    reg = _cache["reg"]
    if head != reg.header or reg.changed:
        reg = _cache["reg"] = _Registry.parse(Y, head)
    return reg


def _save_registry(reg):
    """Write the chunks ``reg`` changed and a new header to ``O.tags``."""
    Y = _Y.load()
    tags = Y.O.tags
    for k in sorted(reg.dirty):
        tags[f"{_TAG}.{k}"] = reg.text(k)
    _token[1] += 1
    head = f"{_HEADER} chunks={len(reg.chunks)} token={_token[0]}.{_token[1]}\n"
    tags[_TAG] = head
    reg.header = head
    reg.dirty.clear()
    reg.changed = False
    _cache["reg"] = reg


_FP_RECORD = np.dtype([("id", "<i8"), ("radius", "<f8"), ("density", "<f8")])


def _fp(ids, radii, rhos):
    """Fingerprint (format 2) of a sphere set: blake2b (8 bytes) of its (id, radius, density) records,
    little-endian int64 and float64, sorted by id; written "b2:<16 hex digits>"."""
    recs = zip(ids, radii, rhos)
    if any(a > b for a, b in zip(ids, ids[1:])):
        recs = sorted(recs)
    return "b2:" + _blake2b(struct.pack("<" + "qdd" * len(ids), *[v for rec in recs for v in rec]),
                            digest_size=8).hexdigest()


def _fps(ids, radii, rhos, counts):
    """:func:`_fp` of many sphere sets at once: flat (S,) ids, radii, densities and the (M,) counts."""
    counts = np.asarray(counts)
    rec = np.empty(len(ids), _FP_RECORD)
    rec["id"], rec["radius"], rec["density"] = ids, radii, rhos
    rec = rec[np.lexsort((rec["id"], np.repeat(np.arange(len(counts)), counts)))]  # by id within each set
    buf = memoryview(rec.tobytes())
    ends = (np.cumsum(counts) * _FP_RECORD.itemsize).tolist()
    out, a = [], 0
    for e in ends:
        out.append("b2:" + _blake2b(buf[a:e], digest_size=8).hexdigest())
        a = e
    return out


def _fingerprint(spheres):
    """Identity of a clump's sphere set: ids, radii, densities (not positions: the clump moves)."""
    return _fp([b.id for b in spheres], [float(b.shape.radius) for b in spheres],
               [float(b.material.density) for b in spheres])


def _fingerprint_v1(spheres):
    """The format-1 fingerprint (scenes saved before format 2): sha1 of the spheres' text."""
    h = hashlib.sha1()
    for b in sorted(spheres, key=lambda b: b.id):
        h.update(f"{b.id}:{float(b.shape.radius).hex()}:{float(b.material.density).hex()};".encode())
    return h.hexdigest()[:16]


def _fingerprint_matches(fp, spheres):
    return fp == (_fingerprint(spheres) if fp.startswith("b2:") else _fingerprint_v1(spheres))


# --------------------------------------------------------------------------- building


def _place(Y, bodies, positions):
    V3 = Y.Vector3
    for b, x in zip(bodies, np.asarray(positions, dtype=float).tolist()):
        b.state.pos = V3(*x)


def _restore(Y, clump, spheres, positions, corr, offset, origin):
    """Move a clump built around the origin back to ``origin``; spheres to their exact positions.

    ``Clump::updateProperties`` sums inertia about the WORLD origin and then subtracts
    M (|c|^2 1 - c c^T): a clump at distance |c| from the origin loses about
    eps (|c| / size)^2 of its inertia to cancellation (2e-10 for a 0.13 m dimer 30 m away).
    So the clump is built with its member spheres shifted by -origin (origin = the exact
    centre of mass), where the sums are exact to eps, then translated back: member offsets
    and orientations relative to the clump are translation-invariant, so they stay valid.
    The spheres get back their original coordinates bit for bit.
    """
    c = clump.state.pos
    clump.state.pos = Y.Vector3(float(origin[0]) + float(c[0]), float(origin[1]) + float(c[1]), float(origin[2]) + float(c[2]))
    _place(Y, spheres, positions)
    _place(Y, [corr], [origin + offset])




def _raw(Y, name, *args, what, **kw):
    """Call YADE's own ``O.bodies.<name>`` (not the guard) and turn a refusal into an error.

    YADE reports a refused release/add as a Python warning ("Body 3 not released from clump 2,
    because ...", "... Body was not added.") and carries on; here that raises
    :class:`ClumpAdapterError` naming ``what``.
    """
    fn = _RAW.get(name) or getattr(type(Y.O.bodies), name)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ret = fn(Y.O.bodies, *args, **kw)
    for w in caught:
        msg = str(w.message)
        if msg.startswith("Warning") or "not released" in msg or "not added" in msg:
            raise ClumpAdapterError(f"{what}: YADE refused O.bodies.{name}: {msg}")
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return ret


def _rotations(q):
    """Rotation matrices (M, 3, 3) of quaternions (M, 4) given as (x, y, z, w), as minieigen's
    ``toRotationMatrix`` computes them (normalised first)."""
    q = q / np.linalg.norm(q, axis=1)[:, None]
    x, y, z, w = q.T
    R = np.empty((len(q), 3, 3))
    R[:, 0, 0] = 1 - 2 * (y * y + z * z)
    R[:, 0, 1] = 2 * (x * y - z * w)
    R[:, 0, 2] = 2 * (x * z + y * w)
    R[:, 1, 0] = 2 * (x * y + z * w)
    R[:, 1, 1] = 1 - 2 * (x * x + z * z)
    R[:, 1, 2] = 2 * (y * z - x * w)
    R[:, 2, 0] = 2 * (x * z - y * w)
    R[:, 2, 1] = 2 * (y * z + x * w)
    R[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return R


_VERIFY_RTOL = 1e-10  # YADE's state after a build against the target (relative; round-off is ~1e-15)


def _verify(Y, cids, mass, com, inertia, rtol=_VERIFY_RTOL, scale=None, rows=None):
    """YADE's state of each clump equals the target (mass, COM, inertia tensor), else raise
    (``scale``, ``rows``: see :func:`_state_errors`)."""
    if len(cids) <= _SMALL and scale is not None and rows is not None:
        e_m, e_c, e_i = zip(*_errors_small(rows, mass, com, inertia, scale))
        bad = [k for k in range(len(cids)) if not (e_m[k] <= rtol and e_c[k] <= rtol and e_i[k] <= rtol)]
    else:
        e_m, e_c, e_i = _state_errors(Y, cids, mass, com, inertia, scale, rows)
        bad = np.flatnonzero(~((e_m <= rtol) & (e_c <= rtol) & (e_i <= rtol)))
    if len(bad):
        k = int(bad[0])
        raise _mismatch(cids[k], e_m[k], e_c[k], e_i[k], rtol)


def _mismatch(cid, e_m, e_c, e_i, rtol):
    return ClumpAdapterError(
        f"clump #{cid}: YADE's state after the build differs from the target (relative errors: mass "
        f"{e_m:.2g}, centre of mass {e_c:.2g}, inertia {e_i:.2g}; tolerance {rtol:g})"
    )


def _apply(plan, method):
    """Make the clumps of ``plan`` [(clump body, sphere bodies, correction body or None), ...] exact.

    Computes every target first (raises before any change), then per clump: builds around the
    origin, updates YADE's clump with the correction in place, moves it back, restores the
    rigid-body velocity field, and finally compares YADE's state with the target and records the
    corrections in the registry.  Returns the correction ids.
    """
    Y = _Y.load()
    if not plan:
        return []
    xs, rs, rhos = [], [], []
    for _, spheres, _ in plan:
        x, r = _geometry(spheres)
        xs.append(x)
        rs.append(r)
        rhos.append(_clump_density(f"clump #{plan[len(xs) - 1][0].id}", spheres))
    try:
        (mass, com, inertia, scale), (m_c, off, w_c, V_c) = _corrections(xs, rs, rhos, [x.tolist() for x in xs],
                                                                      [r.tolist() for r in rs], method)
    except ClumpAdapterError as exc:
        k, what = _batch_index(str(exc))
        raise ClumpAdapterError(f"clump #{plan[k][0].id}: {what}" if k is not None else what) from exc
    except ValueError as exc:
        raise ClumpAdapterError(f"clump properties could not be computed: {exc}") from exc
    # ---- from here on the scene is modified
    reg = _registry()
    out = []
    for k, (cb, spheres, corr) in enumerate(plan):
        cid = cb.id
        c_old, v_old, w_old = _velocity_field(cb)
        o = np.asarray(com[k], dtype=float)
        _place(Y, spheres, xs[k] - o)  # update around the origin, then move back (see _restore)
        if corr is None:
            corr = _new_correction(Y, spheres)
            _set_correction_state(Y, corr.state, m_c[k], off[k], w_c[k], V_c[k])
            (corr_id,) = Y.O.bodies.append([corr])
            corr = Y.O.bodies[corr_id]
            _raw(Y, "addToClump", [corr_id], cid, discretization=0, what=f"clump #{cid}")
        else:
            corr.bounded = False
            corr.mask = _correction_mask(spheres)
            _set_correction_state(Y, corr.state, m_c[k], off[k], w_c[k], V_c[k])
            if len(spheres) >= 2:  # release and re-add: YADE updates this clump only
                _raw(Y, "releaseFromClump", corr.id, cid, discretization=0, what=f"clump #{cid}")
                _set_correction_state(Y, corr.state, m_c[k], off[k], w_c[k], V_c[k])
                _raw(Y, "addToClump", [corr.id], cid, discretization=0, what=f"clump #{cid}")
            else:  # YADE refuses to release from a clump of < 2 members: update this clump alone
                others = [b.id for b in Y.O.bodies if b is not None and b.isClump and b.id != cid]
                _raw(Y, "updateClumpProperties", excludeList=others, discretization=0, what=f"clump #{cid}")
        _restore(Y, cb, spheres, xs[k], corr, np.asarray(off[k]), o)
        # updateProperties zeroes vel and angVel (not angMom): restore the rigid-body velocity
        # field, with angMom consistent with the new tensor
        c_new = _vec(cb.state.pos)
        set_clump_velocity(cid, v_old + np.cross(w_old, c_new - c_old), w_old)
        reg[cid] = (corr.id, _fingerprint(spheres), method)
        out.append(corr.id)
    _save_registry(reg)
    _verify(Y, [cb.id for cb, _, _ in plan], mass, com, inertia, scale=scale)
    return out


def _batch_index(message):
    """(k, the rest of the message) of an error naming "clump k of the batch: ...", else (None, message)."""
    import re

    m = re.match(r"clump (\d+) of the batch: ", message)
    return (int(m.group(1)), message[m.end():]) if m else (None, message)


def _check_new_spheres(Y, k, spheres, seen):
    """Validate one input clump; returns (bodies, positions [(x, y, z)], radii, densities, material of
    the first sphere, union of the masks, the bodies' states).  ``seen``: ids of the Body objects of
    the clumps checked before (a Body given twice is refused)."""
    try:
        spheres = list(spheres)
    except TypeError:
        raise ClumpAdapterError(f"clump {k} of the input is not a list of bodies") from None
    if not spheres:
        raise ClumpAdapterError(f"clump {k} of the input is empty")
    Body, Sphere = Y.Body, Y.Sphere
    xs, rs, rho, states = [], [], [], []
    mask = 0
    mat0 = None
    inf = math.inf
    for j, b in enumerate(spheres):
        if not isinstance(b, Body):
            raise ClumpAdapterError(f"clump {k} of the input, item {j}: not a yade Body ({type(b).__name__})")
        if b.id >= 0:
            raise ClumpAdapterError(f"clump {k} of the input, item {j}: body #{b.id} is already in a scene")
        shape = b.shape
        if not isinstance(shape, Sphere):
            kind = type(shape).__name__ if shape is not None else "no shape"
            raise ClumpAdapterError(f"clump {k} of the input, item {j}: not a sphere ({kind})")
        mat = b.material
        if mat is None:
            raise ClumpAdapterError(f"clump {k} of the input, item {j}: sphere has no material (density unknown)")
        r = shape.radius
        if not 0.0 < r < inf:  # NaN fails too
            raise ClumpAdapterError(f"clump {k} of the input, item {j}: radius {r} is not positive")
        n_seen = len(seen)
        seen.add(id(b))
        if len(seen) == n_seen:
            raise ClumpAdapterError(f"clump {k} of the input, item {j}: the same Body object is given twice")
        st = b.state
        states.append(st)
        p = st.pos
        xs.append((p[0], p[1], p[2]))
        rs.append(r)
        rho.append(mat.density)
        mask |= b.mask
        if mat0 is None:
            mat0 = mat
    r0 = rho[0]
    if not 0.0 < r0 < inf or rho.count(r0) != len(rho):
        _clump_density(f"clump {k} of the input", spheres)  # raises with the details (or accepts a 1e-12 spread)
    return spheres, xs, rs, rho, mat0, mask, states


def _quaternion_one(V):
    """(w, x, y, z) of the rotation A = V^T, V a (3, 3) array of right-handed columns: the scalar
    twin of :func:`_quaternions` (same branches, same formulas)."""
    (a00, a10, a20), (a01, a11, a21), (a02, a12, a22) = V.tolist() if isinstance(V, np.ndarray) else V  # rows of V = columns of A
    sq = (1.0 + (a00 + a11 + a22), 1.0 + a00 - a11 - a22, 1.0 - a00 + a11 - a22, 1.0 - a00 - a11 + a22)
    big = max(range(4), key=sq.__getitem__)
    s = 2.0 * math.sqrt(max(sq[big], 0.5))
    if big == 0:
        q = (0.25 * s, (a21 - a12) / s, (a02 - a20) / s, (a10 - a01) / s)
    elif big == 1:
        q = ((a21 - a12) / s, 0.25 * s, (a01 + a10) / s, (a02 + a20) / s)
    elif big == 2:
        q = ((a02 - a20) / s, (a01 + a10) / s, 0.25 * s, (a12 + a21) / s)
    else:
        q = ((a10 - a01) / s, (a02 + a20) / s, (a12 + a21) / s, 0.25 * s)
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def _orientations(V):
    """(w, x, y, z) of the ``ori`` of each correction, axes V ((M, 3, 3) or a list of (3, 3)): the
    rotation that makes ``Clump::updateProperties`` add V diag(w) V^T; vectorised for a large batch."""
    if len(V) <= _SMALL:
        return [_quaternion_one(v) for v in V]
    return _quaternions(np.asarray(V)).tolist()


@contextlib.contextmanager
def _no_gc(n):
    """Python's cyclic garbage collector paused while a batch of ``n`` > _SMALL clumps is built: the
    build allocates only acyclic objects (lists, tuples, floats, YADE wrappers), so collections
    during it find nothing to free, yet each full collection walks every object of the process
    (the user's sphere lists included: about 25 % of a 10^4-dimer build).  Reference counting
    still frees everything as usual; the collector's state is restored afterwards."""
    if n <= _SMALL or not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.enable()


def append_clumps(clumps, method=DEFAULT_METHOD):
    """Append many clumps at once (one library call); returns ``[(clump_id, member_ids), ...]``.

    ``clumps`` is a list of lists of sphere bodies (as made by ``utils.sphere``), one list per
    clump.  ``member_ids`` are the sphere members only (the correction member of each clump is
    ``correction_id(clump_id)``).  Validates everything before the scene is touched.
    """
    clumps = list(clumps)
    with _no_gc(len(clumps)):
        return _append_clumps(clumps, method)


def _build_one(Y, checked, com, m_c, off, w, q):
    """Append one clump and its correction member (the scene changes here).  ``checked``: the tuple
    of :func:`_check_new_spheres`; com (3): the target centre of mass; m_c, off (3), w (3), q (4, as
    w, x, y, z): the correction's mass, offset from ``com``, principal moments and orientation.
    The clump is built around the origin and moved back (see :func:`_restore`).  Returns (clump id,
    sphere member ids, correction id, YADE's resulting state as read by :func:`_state_row`)."""
    spheres, pos, _, _, mat, mask, states = checked
    ox, oy, oz = com
    for sb, (x, y, z) in zip(states, pos):  # build near the origin
        sb.pos = (x - ox, y - oy, z - oz)
    corr = _new_correction(Y, spheres, mat, mask)
    st = corr.state
    dx, dy, dz = off
    st.mass = m_c
    st.pos = (dx, dy, dz)
    st.inertia = (w[0], w[1], w[2])
    st.ori = Y.Quaternion(q[0], q[1], q[2], q[3])
    cid, mids = _RAW["appendClumped"](Y.O.bodies, spheres + [corr], 0)
    c = Y.O.bodies[cid].state
    p = c.pos
    cx, cy, cz = ox + p[0], oy + p[1], oz + p[2]
    c.pos = (cx, cy, cz)
    for sb, xyz in zip(states, pos):  # the spheres' own coordinates, bit for bit
        sb.pos = xyz
    st.pos = (ox + dx, oy + dy, oz + dz)
    w, q = c.inertia, c.ori  # YADE's result (and the position just set), verified by the caller
    return cid, mids[: len(spheres)], corr.id, (c.mass, cx, cy, cz, w[0], w[1], w[2], q[0], q[1], q[2], q[3])


def _append_clumps(clumps, method):
    Y = _Y.load()
    seen = set()
    checked = [_check_new_spheres(Y, k, s, seen) for k, s in enumerate(clumps)]
    if not checked:
        return []
    M = len(checked)
    n0 = len(checked[0][2])
    pts = [c[1] for c in checked]
    if M <= _SMALL:
        xs = rs = None  # the core reads pts and radii (see _corrections)
    elif all(len(c[2]) == n0 for c in checked):  # one (M, N, 3) array: no per-clump arrays
        xs = np.array([p for c in pts for p in c], dtype=float).reshape(M, n0, 3)
        rs = np.array([r for c in checked for r in c[2]], dtype=float).reshape(M, n0)
    else:
        xs = [np.array(c, dtype=float) for c in pts]
        rs = [np.array(c[2], dtype=float) for c in checked]
    try:
        (mass, com, inertia, scale), (m_l, off_l, w_l, V_c) = _corrections(xs, rs, [c[3] for c in checked], pts,
                                                                          [c[2] for c in checked], method)
    except ClumpAdapterError as exc:
        k, what = _batch_index(str(exc))
        raise ClumpAdapterError(f"clump {k} of the input: {what}" if k is not None else what) from exc
    except ValueError as exc:
        raise ClumpAdapterError(f"clump properties could not be computed: {exc}") from exc
    oris = _orientations(V_c)
    # ---- from here on the scene is modified; python floats and YADE objects only
    com_l = com if isinstance(com, list) else com.tolist()
    out, rows, corr_ids = [], [], []
    for k, c in enumerate(checked):
        cid, mids, corr_id, row = _build_one(Y, c, com_l[k], m_l[k], off_l[k], w_l[k], oris[k])
        rows.append(row)
        corr_ids.append(corr_id)
        out.append((cid, mids))
    if M <= _SMALL:
        fps = [_fp(mids, c[2], c[3]) for (_, mids), c in zip(out, checked)]
    else:
        fps = _fps([i for _, mids in out for i in mids], [r for c in checked for r in c[2]],
                   [p for c in checked for p in c[3]], [len(c[2]) for c in checked])
    reg = _registry()
    reg.set_many([cid for cid, _ in out], corr_ids, fps, method)
    _save_registry(reg)
    _verify(Y, [cid for cid, _ in out], mass, com, inertia, scale=scale, rows=rows)
    return out


def append_clump(spheres, method=DEFAULT_METHOD):
    """Drop-in for ``O.bodies.appendClumped(spheres)``: returns ``(clump_id, member_ids)``.

    The clump's ``state.mass``, ``state.pos`` and inertia (``state.inertia``, ``state.ori``)
    are the library's values for the union of the spheres (``method``, default exact).
    ``member_ids`` lists the spheres; the clump also holds one collision-free correction
    member (see the module docstring).
    """
    Y = _Y.load()
    checked = _check_new_spheres(Y, 0, spheres, set())
    f = None
    if method in _CORE:  # the one-clump path: one core call, plain floats (the same steps as a batch)
        f = _adapter_clump(_CORE[method], checked[1], checked[2], checked[3], method in _STRICT)
    if f is None:  # the general path raises the documented error (or computes a baseline method)
        return append_clumps([checked[0]], method=method)[0]
    cid, mids, corr_id, row = _build_one(Y, checked, f[1:4], f[14], f[15:18], f[18:21], f[30:34])
    reg = _registry()
    reg[cid] = (corr_id, _fp(mids, checked[2], checked[3]), method)
    _save_registry(reg)
    e_m, e_c, e_i = _core.state_errors(row, f)  # _errors_one's compiled twin
    if not (e_m <= _VERIFY_RTOL and e_c <= _VERIFY_RTOL and e_i <= _VERIFY_RTOL):  # NaN fails too
        raise _mismatch(cid, e_m, e_c, e_i, _VERIFY_RTOL)
    return cid, mids


# --------------------------------------------------------------------------- correcting existing clumps


def _velocity_field(cb):
    st = cb.state
    return _vec(st.pos), _vec(st.vel), _vec(st.angVel)


def set_clump_velocity(clump_id, vel=None, ang_vel=None):
    """Set a clump's linear and angular velocity (world frame), consistently for YADE 2023 and 2025.

    Sets ``state.vel``, ``state.angVel`` and ``state.angMom = R diag(I) R^T angVel`` (YADE 2023
    integrates ``angMom`` for aspherical bodies, YADE 2025 integrates ``angVel``).
    """
    Y = _Y.load()
    b = _body(clump_id)
    st = b.state
    if vel is not None:
        st.vel = Y.Vector3(*[float(a) for a in vel])
    if ang_vel is not None:
        w = np.asarray(ang_vel, float).reshape(3)
        R = _rotation(st.ori)
        L = R @ (_vec(st.inertia) * (R.T @ w))
        st.angVel = Y.Vector3(*w.tolist())
        st.angMom = Y.Vector3(*L.tolist())


def _plan_entry(cid, what="clump"):
    """(clump body, sphere members, correction or None) of an existing clump; raises on bad input."""
    cb = _body(cid, what)
    if not cb.isClump:
        kind = f"a member of clump #{cb.clumpId}" if cb.isClumpMember else "standalone"
        raise ClumpAdapterError(f"body #{cb.id} is not a clump ({kind})")
    spheres, corr = _split_members(cb)
    _clump_density(f"clump #{cb.id}", spheres)
    return cb, spheres, corr


def _method_of(cid, method):
    """The method a clump was corrected with (registry), unless one is given."""
    if method is not None:
        return method
    rec = _registry().get(int(cid))
    return rec[2] if rec is not None else DEFAULT_METHOD


def correct_clumps(clump_ids, method=DEFAULT_METHOD):
    """Make existing clumps exact (built by ``clump``, ``appendClumped``, ``replaceByClumps``, ...).

    Idempotent: a clump already corrected gets its correction recomputed for the spheres'
    current positions.  The rigid-body velocity field is kept (members keep their velocities;
    the clump's velocity is re-referred to the new centre of mass).  Returns the correction
    member ids.  Every id is checked before anything is modified.
    """
    ids = [clump_ids] if np.ndim(clump_ids) == 0 else list(clump_ids)
    plan, seen = [], set()
    for cid in ids:
        entry = _plan_entry(cid)
        if entry[0].id not in seen:
            seen.add(entry[0].id)
            plan.append(entry)
    return _apply(plan, method)


def correct_clump(clump_id, method=DEFAULT_METHOD):
    """Make one existing clump exact; returns the id of its correction member."""
    return correct_clumps([clump_id], method=method)[0]


def correct_all_clumps(method=DEFAULT_METHOD):
    """Correct every clump in the scene (all must be clumps of spheres); returns their ids."""
    Y = _Y.load()
    ids = [b.id for b in Y.O.bodies if b is not None and b.isClump]
    correct_clumps(ids, method=method)
    return ids


def replace_by_clumps(templates, amounts, discretization=0, method=DEFAULT_METHOD):
    """Drop-in for ``O.bodies.replaceByClumps(templates, amounts, discretization)``, producing exact clumps.

    YADE places the clumps (same rules, same return value ``[(clump_id, [member_ids]), ...]``);
    each new clump is then corrected (``discretization`` is irrelevant for them: the result is
    the library's).  Clumps already in the scene are not touched.
    """
    Y = _Y.load()
    before = {b.id for b in Y.O.bodies if b is not None and b.isClump}
    ret = _raw(Y, "replaceByClumps", templates, amounts, discretization=0, what="replaceByClumps")
    new = [int(c) for c, _ in ret if int(c) not in before]
    correct_clumps(new, method=method)
    return [(int(c), [int(m) for m in mids]) for c, mids in ret]


def text_clumps(fileName, shift=None, discretization=0, orientation=None, scale=1.0, method=DEFAULT_METHOD, **kw):
    """Drop-in for ``ymport.textClumps(fileName, shift, discretization, orientation, scale, **kw)``: exact clumps.

    Same arguments in the same order (``discretization`` is accepted for compatibility and
    irrelevant: the clumps get the library's values), same grouping (a new clump whenever the
    id column changes), same return value ``[(clump_id, [member_ids]), ...]`` and the clump's mask
    set to its first member's; ``**kw`` go to ``utils.sphere`` (material, color, mask, ...).
    The file is read by the project's own parser (:mod:`clumpprops.textclumps`), so a malformed
    line raises :class:`~clumpprops.textclumps.TextClumpsError` with its line number before
    anything is added.
    """
    Y = _Y.load()
    from yade import utils

    from .textclumps import read_text_clumps

    q = Y.Quaternion((0, 1, 0), 0.0) if orientation is None else orientation
    sh = Y.Vector3(0, 0, 0) if shift is None else Y.Vector3(*[float(a) for a in shift])
    clumps = read_text_clumps(fileName)  # file coordinates; YADE's transform below
    R = _rotation(q)
    shift_np = _vec(sh)
    groups = []
    for c in clumps:
        pos = shift_np + scale * (c.centers @ R.T)  # shift + scale * (orientation * x)
        groups.append([utils.sphere(tuple(p), scale * float(r), **kw) for p, r in zip(pos.tolist(), c.radii.tolist())])
    ret = append_clumps(groups, method=method)
    for cid, mids in ret:
        Y.O.bodies[cid].mask = Y.O.bodies[mids[0]].mask
    return ret


def export_text_clumps(filename, comment="", mask=-1):
    """``export.textClumps`` that can be read back: ids as integers, coordinates to the last bit.

    YADE's writer uses ``%g``: 6 significant digits for positions and radii, and ids >= 10**6 in
    exponent form (``1.23457e+06``), rounded, so neighbouring clumps can merge and
    ``ymport.textClumps`` cannot read the file.  This writes the same format
    (``#format x_y_z_r_clumpId``, one sphere member per line, correction members skipped) with
    ``%.17g`` and ``%d``.  Returns ``(number of clumps, number of spheres)`` like YADE's.
    """
    Y = _Y.load()
    out = ["#format x_y_z_r_clumpId\n"]
    if comment:
        out.append("# " + comment + "\n")
    n_clumps = n = 0
    for b in Y.O.bodies:
        if b is None or not b.isClump:
            continue
        n_clumps += 1
        for mid in b.shape.members.keys():
            m = Y.O.bodies[int(mid)]
            if m is not None and isinstance(m.shape, Y.Sphere) and (mask < 0 or (mask & m.mask) > 0):
                p = m.state.pos
                out.append(f"{float(p[0])!r}\t{float(p[1])!r}\t{float(p[2])!r}\t{float(m.shape.radius)!r}\t{b.id:d}\n")
                n += 1
    with open(filename, "w") as f:
        f.write("".join(out))
    return n_clumps, n


# --------------------------------------------------------------------------- the clump's life: release, add, erase, update


def release(body_id, clump_id, discretization=0):
    """``O.bodies.releaseFromClump(body_id, clump_id)`` that keeps the clump exact.

    The released sphere becomes a free body moving with the clump's rigid-body velocity field;
    the clump is corrected for its remaining spheres.  Raises :class:`ClumpAdapterError`
    (nothing changed) where YADE would refuse (the body is not a member; fewer than two spheres
    would remain) or for the correction member itself.  ``discretization`` is ignored for a
    corrected clump (exact) and passed to YADE for an uncorrected one.
    """
    Y = _Y.load()
    bid = _body(body_id).id
    cb, spheres, corr = _plan_entry(clump_id)
    cid = cb.id
    if bid not in [b.id for b in spheres]:
        if corr is not None and bid == corr.id:
            raise ClumpAdapterError(f"clump #{cid}: body #{bid} is its correction member and cannot be released")
        raise ClumpAdapterError(f"clump #{cid}: body #{bid} is not a member; nothing released")
    if len(spheres) - 1 < 2:
        raise ClumpAdapterError(
            f"clump #{cid}: releasing body #{bid} would leave {len(spheres) - 1} sphere (YADE keeps at least 2); nothing released"
        )
    if corr is None:
        return _raw(Y, "releaseFromClump", bid, cid, discretization=discretization, what=f"clump #{cid}")
    method = _method_of(cid, None)
    c0, v0, w0 = _velocity_field(cb)
    x = _vec(Y.O.bodies[bid].state.pos)
    _neutralize(Y, corr)
    _raw(Y, "releaseFromClump", bid, cid, discretization=0, what=f"clump #{cid}")
    b = Y.O.bodies[bid]
    b.state.vel = Y.Vector3(*(v0 + np.cross(w0, x - c0)).tolist())
    b.state.angVel = Y.Vector3(*w0.tolist())
    cb.state.vel, cb.state.angVel = Y.Vector3(*v0.tolist()), Y.Vector3(*w0.tolist())
    _keep_field(Y, cb, c0, v0, w0)
    _apply([_plan_entry(cid)], method)


def _keep_field(Y, cb, c0, v0, w0):
    """Set a clump's velocity to the rigid field (c0, v0, w0) re-referred to its current centre."""
    c = _vec(cb.state.pos)
    cb.state.vel = Y.Vector3(*(v0 + np.cross(w0, c - c0)).tolist())
    cb.state.angVel = Y.Vector3(*w0.tolist())


def add_to_clump(body_ids, clump_id, discretization=0, method=None):
    """``O.bodies.addToClump(body_ids, clump_id)`` with an exact result.

    ``body_ids``: standalone spheres and/or clumps of spheres (a clump's spheres join, its body is
    erased as YADE does; its correction is dropped).  All spheres must share the clump's density.
    The clump keeps its rigid-body velocity field (the added bodies adopt it) and is corrected for
    all its spheres (``method``: the clump's own, default exact).  Raises (nothing changed) for a
    body that does not exist, is already in this clump, is a member of another clump, is not a
    sphere, or has another density.
    """
    Y = _Y.load()
    cb, spheres, corr = _plan_entry(clump_id)
    cid = cb.id
    ids = [body_ids] if np.ndim(body_ids) == 0 else list(body_ids)
    if not ids:
        raise ClumpAdapterError(f"clump #{cid}: no bodies to add")
    added = []
    for i in ids:
        b = _body(i)
        if b.id == cid or b.clumpId == cid:
            raise ClumpAdapterError(f"clump #{cid}: body #{b.id} is already part of it; nothing added")
        if b.isClumpMember:
            raise ClumpAdapterError(f"clump #{cid}: body #{b.id} is a member of clump #{b.clumpId}; add that clump instead")
        if b.isClump:
            sph, c2 = _split_members(b)
        elif isinstance(b.shape, Y.Sphere) and b.material is not None:
            sph = [b]
        else:
            kind = type(b.shape).__name__ if b.shape is not None else "no shape"
            raise ClumpAdapterError(f"clump #{cid}: body #{b.id} is not a sphere or a clump of spheres ({kind})")
        _clump_density(f"clump #{cid} with body #{b.id}", spheres[:1] + sph)
        added.append(b.id)
    method = _method_of(cid, method)
    c0, v0, w0 = _velocity_field(cb)
    _neutralize(Y, corr)
    reg = _registry()
    # clumps to add are dissolved first and their spheres added one by one: YADE's own
    # addToClump(clump) leaves the merged members with clumpId -1 (seen in 2023.02a), after which
    # erasing one of them leaves a dangling entry in the clump's member list
    sphere_ids = []
    for i in added:
        b = Y.O.bodies[i]
        if b.isClump:
            sph, c2 = _split_members(b)
            _neutralize(Y, c2)
            _raw(Y, "erase", i, False, what=f"clump #{i}")
            if c2 is not None and Y.O.bodies[c2.id] is not None:
                _raw(Y, "erase", c2.id, False, what=f"clump #{i}")
            reg.pop(i, None)
            sphere_ids += [s.id for s in sph]
        else:
            sphere_ids.append(i)
    _save_registry(reg)
    _raw(Y, "addToClump", sphere_ids, cid, discretization=0, what=f"clump #{cid}")
    _keep_field(Y, cb, c0, v0, w0)
    _apply([_plan_entry(cid)], method)
    for b in sphere_member_ids(cid):  # the members adopt the clump's field (YADE leaves them as they were)
        st = Y.O.bodies[b].state
        st.vel = Y.Vector3(*(v0 + np.cross(w0, _vec(st.pos) - c0)).tolist())
        st.angVel = Y.Vector3(*w0.tolist())


def erase(body_id, eraseClumpMembers=False):
    """``O.bodies.erase(body_id, eraseClumpMembers)`` that never leaves a correction behind.

    * a corrected clump: its correction is erased with it; its spheres become free bodies (or
      are erased too with ``eraseClumpMembers=True``), as in YADE;
    * a sphere of a corrected clump: erased, and the clump is corrected for the spheres left
      (the clump goes when its last sphere goes);
    * the correction member itself: refused (erase the clump, or release spheres instead);
    * anything else: YADE's erase.
    Returns YADE's return value (True).
    """
    Y = _Y.load()
    b = _body(body_id)
    bid = b.id
    if is_correction(b) or (type(b.shape) is Y.Shape and not b.bounded and not b.isClump):
        raise ClumpAdapterError(
            f"body #{bid} is a clumpprops correction{f' of clump #{b.clumpId}' if b.isClumpMember else ''}: "
            "erase its clump or its spheres instead"
        )
    reg = _registry()
    if b.isClump:
        spheres, corr = _split_members(b)
        if corr is None:
            return _raw(Y, "erase", bid, eraseClumpMembers, what=f"clump #{bid}")
        _neutralize(Y, corr)
        ret = _erase_clump(Y, bid, [s.id for s in spheres] if eraseClumpMembers else [], corr.id)
        reg.pop(bid, None)
        _save_registry(reg)
        return ret
    if b.isClumpMember:
        cb = Y.O.bodies[b.clumpId]
        spheres, corr = _split_members(cb)
        if corr is None:
            return _raw(Y, "erase", bid, eraseClumpMembers, what=f"clump #{cb.id}")
        cid = cb.id
        method = _method_of(cid, None)
        c0, v0, w0 = _velocity_field(cb)
        if len(spheres) == 1:  # the last sphere: the clump and its correction go too
            _neutralize(Y, corr)
            ret = _erase_clump(Y, cid, [s.id for s in spheres], corr.id)
            reg.pop(cid, None)
            _save_registry(reg)
            return ret
        _neutralize(Y, corr)
        ret = _raw(Y, "erase", bid, eraseClumpMembers, what=f"clump #{cid}")
        _keep_field(Y, cb, c0, v0, w0)
        _apply([_plan_entry(cid)], method)
        return ret
    return _raw(Y, "erase", bid, eraseClumpMembers, what=f"body #{bid}")


def _erase_clump(Y, cid, sphere_ids, corr_id):
    """Erase a corrected clump, its correction and the spheres ``sphere_ids`` (the other members become
    free).  YADE's own ``erase(clump, eraseClumpMembers=True)`` erases the clump body a second time from
    inside its loop over the members (when the last member goes) and crashed a test process with a
    segmentation fault (2023.02a; only after some other tests had run).  So the clump is erased alone
    (its members become standalone) and then each body by itself."""
    ret = _raw(Y, "erase", cid, False, what=f"clump #{cid}")
    for i in [*sphere_ids, corr_id]:
        if Y.O.bodies[i] is not None:
            _raw(Y, "erase", i, False, what=f"clump #{cid}")
    return ret


def update_clump_properties(excludeList=(), discretization=5):
    """``O.bodies.updateClumpProperties(excludeList, discretization)`` that keeps corrected clumps exact.

    Corrected clumps (not in ``excludeList``) are recomputed exactly for where their spheres are
    (``discretization`` is irrelevant for them); every other clump gets YADE's own update with
    ``discretization``, as before.
    """
    Y = _Y.load()
    excl = {int(i) for i in excludeList}
    corrected, plain_excl = [], set(excl)
    for b in Y.O.bodies:
        if b is None or not b.isClump or b.id in excl:
            continue
        entry = _plan_entry(b.id) if _has_correction(Y, b) else None
        if entry is not None:
            corrected.append(entry)
            plain_excl.add(b.id)
    _raw(Y, "updateClumpProperties", excludeList=sorted(plain_excl), discretization=discretization,
         what="updateClumpProperties")
    by_method = {}
    for e in corrected:
        by_method.setdefault(_method_of(e[0].id, None), []).append(e)
    for m, plan in by_method.items():
        _apply(plan, m)


def _has_correction(Y, cb):
    for mid in cb.shape.members.keys():
        mb = Y.O.bodies[int(mid)]
        if mb is not None and type(mb.shape) is Y.Shape and not mb.bounded:
            return True
    return False


# --------------------------------------------------------------------------- guards on O.bodies

_RAW = {}
_GUARDED = ("releaseFromClump", "addToClump", "erase", "updateClumpProperties",
            "clump", "appendClumped", "deleteClumpMember", "deleteClumpBody", "clear", "replace")
_bypass = [0]


@contextlib.contextmanager
def unguarded():
    """YADE's own ``O.bodies`` methods inside the block, as if the adapter were not loaded (tests, debugging)."""
    _bypass[0] += 1
    try:
        yield
    finally:
        _bypass[0] -= 1


def _corrected_clump_of(Y, bid):
    """The corrected clump that body ``bid`` is (or is a member of), else None."""
    try:
        b = Y.O.bodies[int(bid)]
    except Exception:
        return None
    if b is None:
        return None
    if b.isClumpMember:
        b = Y.O.bodies[b.clumpId]
    return b if (b is not None and b.isClump and _has_correction(Y, b)) else None


def _install_guards(Y):
    """Replace the ``O.bodies`` methods that change clump membership or mass (``_GUARDED``) by guards:
    a call touching a corrected clump is routed through the adapter or refused before YADE sees it
    (:func:`_refuse_clump_ids`, :func:`_refuse_corrections`); anything else goes straight to YADE."""
    BC = type(Y.O.bodies)
    if _RAW:
        return
    for name in _GUARDED:
        _RAW[name] = getattr(BC, name)

    def releaseFromClump(self, bid, cid, discretization=0):
        if _bypass[0] or _corrected_clump_of(Y, cid) is None:
            return _RAW["releaseFromClump"](self, bid, cid, discretization)
        return release(bid, cid, discretization)

    def addToClump(self, ids, cid, discretization=0):
        lst = [ids] if np.ndim(ids) == 0 else list(ids)
        if not _bypass[0]:
            _refuse_correction_ids(Y, lst, "O.bodies.addToClump")
        if _bypass[0] or all(_corrected_clump_of(Y, i) is None for i in [cid] + lst):
            return _RAW["addToClump"](self, ids, cid, discretization)
        return add_to_clump(lst, cid, discretization)

    def erase(self, bid, eraseClumpMembers=False):
        if _bypass[0] or _corrected_clump_of(Y, bid) is None:
            return _RAW["erase"](self, bid, eraseClumpMembers)
        return globals()["erase"](bid, eraseClumpMembers)

    def updateClumpProperties(self, excludeList=[], discretization=5):
        if _bypass[0]:
            return _RAW["updateClumpProperties"](self, excludeList, discretization)
        return update_clump_properties(excludeList, discretization)

    for f in (releaseFromClump, addToClump, erase, updateClumpProperties, *_membership_guards(Y)):
        f.__doc__ = (_RAW[f.__name__].__doc__ or "") + "\n\n[clumpprops] routed through clumpprops.yade for corrected clumps."
        setattr(BC, f.__name__, f)


def _looks_like_correction(Y, b):
    """A body made as a clumpprops correction (bare ``Shape``, unbounded), inside a clump or not."""
    return b is not None and type(b.shape) is Y.Shape and not b.bounded and not b.isClump


def _refuse_clump_ids(Y, ids, call):
    """Raise (nothing changed) if ``O.bodies.clump(ids)`` would touch a corrected clump.

    YADE's ``clump`` takes each body out of its old clump without updating that clump, then sums
    the new one: a correction in the list can make a clump of negative or zero mass (``Clump.cpp``
    ``Assertion 'M > 0' failed``: the process aborts), a sphere of a corrected clump leaves that
    clump with a stale correction, a corrected clump brings its correction into the new one."""
    for i in ids:
        b = _body(i)
        if _looks_like_correction(Y, b):
            where = f" of clump #{b.clumpId}" if b.isClumpMember else ""
            raise ClumpAdapterError(
                f"{call}: body #{b.id} is a clumpprops correction{where} and cannot be clumped "
                "(its mass is negative); clump spheres only, or add them with O.bodies.addToClump"
            )
        cb = _corrected_clump_of(Y, b.id)
        if cb is None:
            continue
        if b.isClump:
            raise ClumpAdapterError(
                f"{call}: body #{b.id} is a corrected clump; join clumps with O.bodies.addToClump([...], {b.id}) "
                "(exact) instead"
            )
        raise ClumpAdapterError(
            f"{call}: body #{b.id} is a sphere of corrected clump #{cb.id}; release it first with "
            f"O.bodies.releaseFromClump({b.id}, {cb.id}) (or cy.release)"
        )


def _refuse_correction_ids(Y, ids, call):
    """Raise if one of ``ids`` is a correction body (in a clump or left over, e.g. by YADE's own erase):
    added to a clump, its negative mass is summed with the clump's (YADE can abort on ``M > 0``)."""
    for i in ids:
        try:
            b = Y.O.bodies[int(i)]
        except Exception:
            continue  # YADE reports a bad id itself
        if _looks_like_correction(Y, b):
            where = f" of clump #{b.clumpId}" if b.isClumpMember else " (outside any clump)"
            raise ClumpAdapterError(f"{call}: body #{b.id} is a clumpprops correction{where}; it cannot join a clump")


def _refuse_corrections(Y, bodies, call):
    """Raise if a body to be appended is a correction body: only the adapter builds those."""
    for j, b in enumerate(bodies):
        if isinstance(b, Y.Body) and _looks_like_correction(Y, b):
            raise ClumpAdapterError(
                f"{call}: item {j} is a clumpprops correction body (bare Shape, bounded=False); "
                "corrections are made by cy.append_clump / cy.correct_clump only"
            )


def _forget_registry(Y):
    """Empty the scene's registry (after ``O.bodies.clear()`` / ``replace()``: every clump is gone)."""
    tags = Y.O.tags
    for k in range(len(_registry().chunks)):
        try:
            del tags[f"{_TAG}.{k}"]
        except (KeyError, TypeError, AttributeError):
            tags[f"{_TAG}.{k}"] = ""
    _save_registry(_Registry())


def _membership_guards(Y):
    """Guards for ``clump``, ``appendClumped``, ``deleteClumpMember``, ``deleteClumpBody``, ``clear`` and
    ``replace`` (same names and keywords as YADE's methods)."""

    def clump(self, ids, discretization=0):
        if not _bypass[0]:
            _refuse_clump_ids(Y, [ids] if np.ndim(ids) == 0 else list(ids), "O.bodies.clump")
        return _RAW["clump"](self, ids, discretization)

    def appendClumped(self, bodies, discretization=0):
        if not _bypass[0]:
            bodies = list(bodies)
            _refuse_corrections(Y, bodies, "O.bodies.appendClumped")
        return _RAW["appendClumped"](self, bodies, discretization)

    def deleteClumpMember(self, clumpBody, memberBody):
        if _bypass[0] or clumpBody is None or _corrected_clump_of(Y, clumpBody.id) is None:
            return _RAW["deleteClumpMember"](self, clumpBody, memberBody)
        if memberBody is None or memberBody.clumpId != clumpBody.id or not memberBody.isClumpMember:
            mid = None if memberBody is None else memberBody.id
            raise ClumpAdapterError(f"O.bodies.deleteClumpMember: body #{mid} is not a member of clump #{clumpBody.id}")
        globals()["erase"](memberBody.id)  # erasing the correction itself is refused there

    def deleteClumpBody(self, clumpBody):
        if _bypass[0] or clumpBody is None or _corrected_clump_of(Y, clumpBody.id) is None:
            return _RAW["deleteClumpBody"](self, clumpBody)
        globals()["erase"](clumpBody.id, True)

    def clear(self):
        ret = _RAW["clear"](self)
        if not _bypass[0]:
            _forget_registry(Y)
        return ret

    def replace(self, bodies):
        ret = _RAW["replace"](self, bodies)
        if not _bypass[0]:
            _forget_registry(Y)
        return ret

    return clump, appendClumped, deleteClumpMember, deleteClumpBody, clear, replace


# --------------------------------------------------------------------------- checking the scene


@dataclass
class CheckReport:
    """Result of :func:`check`.

    ``exact``: corrected clumps whose YADE state equals the library's (within ``rtol``);
    ``uncorrected``: clumps without a correction and without a registry entry (YADE's own, not an
    error); ``stale``: [(clump id, reason)] corrected clumps that no longer match (state off, sphere
    set changed since the correction, correction lost); ``orphaned``: [(body id, reason)] corrections
    without their clump (a free correction body, a registry entry for a missing clump);
    ``invalid``: [(body id, reason)] dynamic bodies that are not clump members with a mass or a
    principal moment that is not positive (YADE divides by them; a correction left free by YADE's
    own erase is one); ``masks``: [(clump id, reason)] corrections whose mask is not the union of
    their spheres' masks (a mask changed after the build: ``cy.correct_clump`` sets it again);
    ``max_error``: the largest relative error found over the exact and stale clumps.
    """

    exact: list = field(default_factory=list)
    uncorrected: list = field(default_factory=list)
    stale: list = field(default_factory=list)
    orphaned: list = field(default_factory=list)
    invalid: list = field(default_factory=list)
    masks: list = field(default_factory=list)
    max_error: float = 0.0

    @property
    def ok(self) -> bool:
        return not (self.stale or self.orphaned or self.invalid or self.masks)

    def __str__(self):
        lines = [f"clumpprops check: {len(self.exact)} exact, {len(self.uncorrected)} uncorrected, "
                 f"{len(self.stale)} stale, {len(self.orphaned)} orphaned, {len(self.invalid)} invalid, "
                 f"{len(self.masks)} mask mismatches (max relative error {self.max_error:.2g})"]
        lines += [f"  stale clump #{c}: {why}" for c, why in self.stale]
        lines += [f"  orphaned #{c}: {why}" for c, why in self.orphaned]
        lines += [f"  invalid body #{c}: {why}" for c, why in self.invalid]
        lines += [f"  mask of clump #{c}: {why}" for c, why in self.masks]
        return "\n".join(lines)


def check(rtol=1e-9, raise_on_error=False):
    """Verify every clump of the scene against its exact properties; report stale or orphaned corrections.

    For each corrected clump: the correction is the one recorded in the registry
    (``O.tags["clumpprops.corrections*"]``, saved with the scene), the sphere set has the recorded
    fingerprint (ids, radii, densities), and YADE's mass, centre of mass and inertia tensor equal
    the library's for the spheres where they are now (relative ``rtol``; clumps corrected with
    ``montecarlo`` are checked for their fingerprint only).  Also reports correction bodies that
    are not in a clump (e.g. left by YADE's own ``erase`` of a corrected clump: a free body of
    negative mass), registry entries whose clump is gone or has lost its correction, clumps that
    hold a correction with no sphere or with a non-sphere member (stale), dynamic bodies outside
    clumps with a mass or principal moment that is not positive (``invalid``) and corrections whose
    mask is not the union of their spheres' masks (``masks``).
    ``raise_on_error=True`` raises :class:`ClumpAdapterError` listing them.
    """
    Y = _Y.load()
    reg = _registry()
    rep = CheckReport()
    seen = set()
    pending = []  # corrected clumps with a registry entry: (id, spheres, method, reasons)
    for b in Y.O.bodies:
        if b is None:
            continue
        if type(b.shape) is Y.Shape and not b.bounded and not b.isClump and not b.isClumpMember:
            rep.orphaned.append((b.id, f"correction body outside any clump (free body, mass {float(b.state.mass):.6g} kg)"))
            continue
        if not b.isClump:
            continue
        cid = b.id
        seen.add(cid)
        rec = reg.get(cid)
        try:
            spheres, corr = _split_members(b)
        except ClumpAdapterError as exc:
            if rec is not None or _has_correction(Y, b):  # e.g. a correction clumped alone or with other shapes
                rep.stale.append((cid, str(exc)))
            else:
                rep.uncorrected.append(cid)
            continue
        if corr is None:
            if rec is not None:
                rep.stale.append((cid, f"the registry records correction #{rec[0]} but the clump has none (YADE's summed values)"))
            else:
                rep.uncorrected.append(cid)
            continue
        if rec is None:
            rep.stale.append((cid, f"correction #{corr.id} is not in the registry"))
            continue
        why = []
        if rec[0] != corr.id:
            why.append(f"correction is #{corr.id}, the registry records #{rec[0]}")
        if not _fingerprint_matches(rec[1], spheres):
            why.append("its sphere set changed since it was corrected (fingerprint differs)")
        _check_mask(rep, cid, spheres, corr)
        pending.append((cid, spheres, rec[2], why))
    # YADE's state against the library, one batch per method
    by_method = {}
    for item in pending:
        by_method.setdefault(item[2], []).append(item)
    for method, items in by_method.items():
        if method != "montecarlo":
            try:
                xs, rs, rhos = [], [], []
                for _, spheres, _, _ in items:
                    x, r = _geometry(spheres)
                    xs.append(x)
                    rs.append(r)
                    rhos.append(_clump_density(f"clump #{items[len(xs) - 1][0]}", spheres))
                mass, com, inertia, scale = _targets(xs, rs, rhos, method)
            except (ValueError, ImportError) as exc:
                for _, _, _, why in items:
                    why.append(f"exact properties could not be computed: {exc}")
            else:
                e_m, e_c, e_i = _state_errors(Y, [it[0] for it in items], mass, com, inertia, scale)
                for k, (_, _, _, why) in enumerate(items):
                    e = max(e_m[k], e_c[k], e_i[k])
                    rep.max_error = max(rep.max_error, float(e))
                    if not e <= rtol:
                        why.append(
                            f"YADE's state differs from the exact properties (relative: mass {e_m[k]:.2g}, "
                            f"centre of mass {e_c[k]:.2g}, inertia {e_i[k]:.2g})"
                        )
        for cid, _, _, why in items:
            if why:
                rep.stale.append((cid, "; ".join(why)))
            else:
                rep.exact.append(cid)
    for cid, rec in reg.items():
        if cid not in seen:
            rep.orphaned.append((cid, f"registry entry for clump #{cid} (correction #{rec[0]}), which no longer exists"))
    _check_dynamic_mass(Y, rep)
    rep.exact.sort()
    rep.stale.sort()
    if raise_on_error and not rep.ok:
        raise ClumpAdapterError(str(rep))
    return rep


def _check_mask(rep, cid, spheres, corr):
    """Report a correction whose mask is not the union of its spheres' (see :func:`_correction_mask`)."""
    want = _correction_mask(spheres)
    if int(corr.mask) != want:
        rep.masks.append((cid, f"correction #{corr.id} has mask {int(corr.mask):#x}, its spheres' union is {want:#x} "
                               f"(a mask-selected engine would weigh the clump wrongly); run cy.correct_clump({cid})"))


def _check_dynamic_mass(Y, rep):
    """Report every dynamic body outside clumps (clumps and free bodies: what NewtonIntegrator moves)
    whose mass or a principal moment is not positive and finite."""
    for b in Y.O.bodies:
        if b is None or b.isClumpMember or not b.dynamic:
            continue
        st = b.state
        m = float(st.mass)
        inertia = [float(st.inertia[k]) for k in range(3)]
        if not (0.0 < m < math.inf and all(0.0 < i < math.inf for i in inertia)):
            kind = "clump" if b.isClump else type(b.shape).__name__ if b.shape is not None else "no shape"
            rep.invalid.append((b.id, f"dynamic {kind} with mass {m:.6g} kg and principal moments "
                                      f"{', '.join(f'{i:.6g}' for i in inertia)} (must be positive)"))
    rep.invalid.sort()


# --------------------------------------------------------------------------- inspection


def correction_id(clump_id):
    """Id of the clump's correction member, or None if the clump is not corrected."""
    cb = _body(clump_id, "clump")
    if not cb.isClump:
        raise ClumpAdapterError(f"body #{cb.id} is not a clump")
    _, corr = _split_members(cb)
    return None if corr is None else corr.id


def sphere_member_ids(clump_id):
    """Ids of the clump's sphere members (ascending), without the correction member."""
    cb = _body(clump_id, "clump")
    if not cb.isClump:
        raise ClumpAdapterError(f"body #{cb.id} is not a clump")
    spheres, _ = _split_members(cb)
    return [b.id for b in spheres]


def clump_errors(clump_id, method=DEFAULT_METHOD):
    """Relative differences between the clump's YADE state and the library, for checking.

    Returns a dict: ``mass`` |dm|/m; ``center_of_mass`` |dc| / clump radius of gyration;
    ``inertia`` max-abs of (R diag(state.inertia) R^T - I_exact) / max principal moment.
    """
    mp = exact_properties(clump_id, method=method)
    st = _body(clump_id).state
    R = _rotation(st.ori)
    I_y = R @ np.diag(_vec(st.inertia)) @ R.T
    scale = float(np.max(mp.principal_moments))
    gyr = math.sqrt(float(np.trace(mp.inertia)) / (2.0 * mp.mass))
    return {
        "mass": abs(float(st.mass) - mp.mass) / mp.mass,
        "center_of_mass": float(np.linalg.norm(_vec(st.pos) - mp.center_of_mass)) / gyr,
        "inertia": float(np.max(np.abs(I_y - mp.inertia))) / scale,
    }
