"""Numerical baselines users compare with: Monte Carlo sampling and YADE's voxel grid.

Both estimate the same volume moments as the exact methods (V, S, Q about the
per-clump origin; see ``_properties``), so their results are directly comparable.

* ``montecarlo_moments``: uniform samples in each clump's bounding box (the approach
  of LIGGGHTS' multisphere templates, ref. [5] of the paper).  Two passes over the
  same random stream: the first gives the estimates, the second the per-sample
  variances, from which the one-sigma standard errors of mass, volume, centre of
  mass and inertia follow (delta method for the ratio estimators; the inertia about
  the estimated centre of mass has zero first-order sensitivity to that centre).
* ``voxel_moments``: the regular-grid scheme of YADE 2023.02a's
  ``Clump::updateProperties(clump, discretization)``, mirrored exactly: if no pair
  overlaps by more than 0.001 min(r_i, r_j) YADE sums the spheres instead; else cells
  of edge dx = min(AABB extent) / discretization, centred at aabb.min + dx/2 + k dx
  (< aabb.max), count when strictly inside a sphere, and each counted cell adds the
  moment of inertia of a cube, m dx^2 / 6 per axis.  (YADE 2023.02a adds dv dx^2 / 6,
  without the density factor; that term is below the grid error and not mirrored.)
"""
from __future__ import annotations

import numpy as np

from ._input import Spheres
from ._properties import StandardError, finish
from .methods import MAX_DISCRETIZATION, MAX_SAMPLES, MAX_VOXEL_CELLS, check_count
from .pairwise import sphere_moments


def _padded(sph: Spheres):
    """Spheres as padded (M, Nmax, 3), (M, Nmax) arrays; padding has radius 0 (never contains a point)."""
    M = sph.n_clumps
    Nmax = int(sph.counts.max())
    c = np.zeros((M, Nmax, 3))
    r = np.zeros((M, Nmax))
    c[sph.clump, sph.local] = sph.centers
    r[sph.clump, sph.local] = sph.radii
    return c, r


def _inside(x, c, r):
    """x (M, n, 3) -> (M, n) bool: strictly inside any sphere of the clump."""
    d2 = np.sum((x[:, :, None, :] - c[:, None, :, :]) ** 2, axis=-1)
    return np.any(d2 < (r * r)[:, None, :], axis=-1)


def montecarlo_moments(sph: Spheres, density, n_samples=1_000_000, seed=None, chunk=None):
    """Monte Carlo mass properties with one-sigma standard errors.

    Parameters
    ----------
    sph : clumpprops._input.Spheres
        The checked, flattened spheres of M clumps (centres in m relative to each clump's
        origin, radii in m).
    density : float
        Solid density of the spheres, in kg/m^3.
    n_samples : int, optional
        Samples per clump, 100 to 10^9.
    seed : int or None, optional
        Seed of numpy's random generator; None draws fresh entropy.
    chunk : int or None, optional
        Samples per clump drawn at once (memory use); None chooses one.

    Returns
    -------
    MassProperties
        The estimates (``method="montecarlo"``) with their :class:`~clumpprops.StandardError`.

    Raises
    ------
    ValueError
        If ``n_samples`` is not an integer in [100, 10^9].
    ArithmeticError
        If no sample of some clump falls inside it (too few samples).
    """
    n_samples = check_count(n_samples, "n_samples", 100, MAX_SAMPLES)
    c, r = _padded(sph)
    M, Nmax = r.shape
    lo = np.min(np.where(r[..., None] > 0, c - r[..., None], np.inf), axis=1)
    hi = np.max(np.where(r[..., None] > 0, c + r[..., None], -np.inf), axis=1)
    box = hi - lo
    vbox = np.prod(box, axis=1)
    if chunk is None:
        chunk = max(1000, min(n_samples, 4_000_000 // max(1, M * Nmax)))
    seed_seq = np.random.SeedSequence(seed)
    state = seed_seq.generate_state(4)

    def stream():
        rng = np.random.default_rng(state)
        done = 0
        while done < n_samples:
            k = min(chunk, n_samples - done)
            x = lo[:, None, :] + box[:, None, :] * rng.random((M, k, 3))
            yield x, _inside(x, c, r)
            done += k

    # pass 1: moments
    n_in = np.zeros(M)
    s1 = np.zeros((M, 3))
    s2 = np.zeros((M, 3, 3))
    for x, ins in stream():
        w = ins.astype(float)
        n_in += w.sum(axis=1)
        xw = x * w[..., None]
        s1 += xw.sum(axis=1)
        s2 += np.einsum("mkx,mky->mxy", xw, x)
    if np.any(n_in == 0):
        raise ArithmeticError("a Monte Carlo estimate found no sample inside the clump; increase n_samples")
    V = vbox * n_in / n_samples
    S = vbox[:, None] * s1 / n_samples
    Q = vbox[:, None, None] * s2 / n_samples
    com_rel = S / V[:, None]
    # pass 2: per-sample variances about the final estimates
    g2 = np.zeros((M, 3))
    g1 = np.zeros((M, 3))
    h1 = np.zeros((M, 3, 3))
    h2 = np.zeros((M, 3, 3))
    for x, ins in stream():
        w = ins.astype(float)
        d = (x - com_rel[:, None, :]) * w[..., None]
        g1 += d.sum(axis=1)
        g2 += (d * d).sum(axis=1)
        dd = np.einsum("mkx,mky->mkxy", d, d)
        h = -dd
        tr = np.einsum("mkxx->mk", dd)
        for k in range(3):
            h[..., k, k] += tr
        h1 += h.sum(axis=1)
        h2 += (h * h).sum(axis=1)
    n = float(n_samples)

    def se(sum1, sum2, scale):
        var = np.clip(sum2 / n - (sum1 / n) ** 2, 0.0, None)
        return scale * np.sqrt(var / n)

    p = n_in / n
    se_V = vbox * np.sqrt(np.clip(p * (1 - p), 0.0, None) / n)
    se_com = se(g1, g2, (vbox / V)[:, None])
    se_I = se(h1, h2, (density * vbox)[:, None, None])
    err = StandardError(mass=density * se_V, volume=se_V, center_of_mass=se_com, inertia=se_I)
    return finish(V, S, Q, sph.origin, density, "montecarlo", sph.batched, err)


def voxel_moments(sph: Spheres, discretization=10):
    """Volume moments by YADE 2023.02a's regular-grid scheme (see the module docstring).

    Parameters
    ----------
    sph : clumpprops._input.Spheres
        The spheres of M clumps, as for :func:`montecarlo_moments`.
    discretization : int, optional
        Cells along the smallest extent of a clump's bounding box, 1 to 1000.

    Returns
    -------
    V, S, Q : numpy.ndarray, shapes (M,), (M, 3), (M, 3, 3)
        As :func:`~clumpprops.pairwise.sphere_moments` returns them, for the voxel estimate.

    Raises
    ------
    ValueError
        If ``discretization`` is not an integer in [1, 1000], or a clump's grid would have
        more than 10^9 cells.
    """
    d = check_count(discretization, "discretization", 1, MAX_DISCRETIZATION)
    V, S, Q = sphere_moments(sph)  # YADE's path for clumps without a real overlap
    c, r = _padded(sph)
    M, Nmax = r.shape
    # YADE's intersection test: some pair overlaps by more than 0.001 min(r_i, r_j)
    dist = np.linalg.norm(c[:, :, None, :] - c[:, None, :, :], axis=-1)
    un = r[:, :, None] + r[:, None, :] - dist
    real = (r[:, :, None] > 0) & (r[:, None, :] > 0) & ~np.eye(Nmax, dtype=bool)[None]
    inter = np.any(real & (un > 0.001 * np.minimum(r[:, :, None], r[:, None, :])), axis=(1, 2))
    idx = np.flatnonzero(inter)
    if len(idx) == 0:
        return V, S, Q
    cm, rm = c[idx], r[idx]
    real_s = rm > 0
    lo = np.min(np.where(real_s[..., None], cm - rm[..., None], np.inf), axis=1)  # (Mi, 3)
    hi = np.max(np.where(real_s[..., None], cm + rm[..., None], -np.inf), axis=1)
    dx = (hi - lo).min(axis=1) / d  # (Mi,)
    # cell centres lo + dx/2 + k dx < hi, k = 0, 1, ...
    cells = np.prod(np.ceil((hi - lo) / dx[:, None]), axis=1)
    if np.max(cells) > MAX_VOXEL_CELLS:
        raise ValueError(f"the voxel grid is too large: {np.max(cells):.3g} cells for one clump, at most "
                         f"{MAX_VOXEL_CELLS:.0e} (a stated limit; lower discretization)")
    kmax = int(np.max(np.ceil((hi - lo) / dx[:, None]))) + 1
    k = np.arange(kmax)
    ax = lo[:, :, None] + dx[:, None, None] * (0.5 + k)  # (Mi, 3, kmax)
    ok = ax < hi[:, :, None]
    # slab by slab along x, vectorised over clumps and (y, z) cells; memory bounded by chunks
    per = max(1, 4_000_000 // (kmax * kmax * Nmax))
    n_in = np.zeros(len(idx))
    s1 = np.zeros((len(idx), 3))
    s2 = np.zeros((len(idx), 3, 3))
    for g0 in range(0, len(idx), per):
        g = slice(g0, g0 + per)
        Y = np.broadcast_to(ax[g, 1, :, None], ax[g, 1].shape + (kmax,))
        Z = np.broadcast_to(ax[g, 2, None, :], ax[g, 2].shape[:1] + (kmax, kmax))
        yz_ok = (ok[g, 1, :, None] & ok[g, 2, None, :]).reshape(len(Y), -1)
        yz = np.stack([Y.reshape(len(Y), -1), Z.reshape(len(Y), -1)], axis=-1)  # (Mc, kmax^2, 2)
        cc, rr = cm[g], rm[g]
        block = max(1, 4_000_000 // (len(Y) * Nmax))  # (y, z) cells per step: memory bounded
        for i in range(kmax):
            xi = ax[g, 0, i]
            for q in range(0, yz.shape[1], block):
                yzq = yz[:, q : q + block]
                pts = np.concatenate([np.broadcast_to(xi[:, None, None], yzq.shape[:2] + (1,)), yzq], axis=-1)
                d2 = np.sum((pts[:, :, None, :] - cc[:, None, :, :]) ** 2, axis=-1)
                ins = np.any(d2 < (rr * rr)[:, None, :], axis=-1) & yz_ok[:, q : q + block] & ok[g, 0, i][:, None]
                w = ins.astype(float)
                n_in[g] += w.sum(axis=1)
                pw = pts * w[..., None]
                s1[g] += pw.sum(axis=1)
                s2[g] += np.einsum("mpx,mpy->mxy", pw, pts)
    cell = dx**3
    V[idx] = n_in * cell
    S[idx] = cell[:, None] * s1
    # each cell's own second moment dv dx^2/12 per axis (inertia m dx^2/6 per axis)
    Q[idx] = cell[:, None, None] * s2 + np.eye(3)[None] * (n_in * cell * dx * dx / 12.0)[:, None, None]
    return V, S, Q
