"""The paper's pairwise overlap correction (Parteli, eqs. 1-7) and the summed baseline.

``method="pairwise"`` removes each sphere-sphere overlap (a lens made of two
spherical caps) from the summed spheres:

* cap heights l_k = R_k - t_k (Fig. 1), written as l_1 = delta (R_2 - R_1 + D) / (2D)
  with the overlap depth delta = R_1 + R_2 - D, which has no cancellation for tiny
  overlaps;
* cap volume, eq. (1): V_cap = pi/3 (3 R l^2 - l^3);
* cap axial moment, eq. (3), and transverse moment, eq. (2).  Eq. (2) is the moment
  about the sphere centre shifted to the cap centroid; we evaluate the same quantity
  as (transverse second moment) + (axial variance about the cap centroid), each a
  polynomial in l without the large-minus-large shift of eq. (2);
* the lens tensor rotated from the z axis onto e_D (the paper's R I R^-1);
* body mass, centre of mass and inertia, eqs. (4)-(7).

A pair where one sphere lies inside the other (D + r_small <= r_big, duplicates
included) removes the smaller sphere.  The equations are exact only if no point
lies in three or more spheres; :func:`check_no_triple_overlap` decides that
geometrically and raises :class:`ClumpGeometryError` naming the spheres.

``method="sum"`` ignores the overlaps (YADE's ``appendClumped`` with
discretization=0, LAMMPS ``fix rigid``).
"""
from __future__ import annotations

import numpy as np

from ._input import Spheres, _rowsum, segment_sum
from ._pairs import distance_and_axis, overlapping_pairs


class ClumpGeometryError(ValueError):
    """The clump's geometry is outside what the chosen method can compute exactly.

    A :class:`ValueError`: raised by :func:`clumpprops.mass_properties` with
    ``method="pairwise"`` where three spheres of a clump share a region (the message names
    them); ``method="exact"`` computes such clumps.
    """


def sphere_moments(sph: Spheres):
    """Volume moments of the summed spheres, overlaps counted twice (``method="sum"``).

    Parameters
    ----------
    sph : clumpprops._input.Spheres
        The checked, flattened spheres of M clumps (centres in m relative to each clump's
        origin, radii in m).

    Returns
    -------
    V : numpy.ndarray, shape (M,)
        Volume of each clump, in m^3.
    S : numpy.ndarray, shape (M, 3)
        First moment about the clump's origin, in m^4.
    Q : numpy.ndarray, shape (M, 3, 3)
        Second moment about the clump's origin, in m^5.
    """
    r, c = sph.radii, sph.centers
    v = (4.0 / 3.0) * np.pi * r * r * r
    V = segment_sum(v, sph)
    vc = v[:, None] * c
    S = segment_sum(vc, sph)
    Q = np.empty((sph.n_clumps, 3, 3))
    iso = segment_sum(v * r * r, sph) / 5.0
    for x in range(3):
        for y in range(x, 3):
            Q[:, x, y] = Q[:, y, x] = segment_sum(vc[:, x] * c[:, y], sph)
        Q[:, x, x] += iso
    return V, S, Q


def cap_moments(R, l):
    """Moments of a spherical cap, per unit density.

    Parameters
    ----------
    R : float or numpy.ndarray
        Radius of the sphere, in m.
    l : float or numpy.ndarray
        Height of the cap, in m, 0 <= l <= 2 R (broadcasts with ``R``).

    Returns
    -------
    V : numpy.ndarray
        Volume, in m^3 (eq. 1 divided by the density).
    b : numpy.ndarray
        Distance of the centroid from the cap's base plane, towards the apex, in m.
    sigma_a : numpy.ndarray
        Axial variance ``int (s - s_bar)^2 dV``, in m^5.
    sigma_t : numpy.ndarray
        Transverse second moment ``int x^2 dV``, in m^5 (the axial moment of inertia, eq. 3,
        is ``2 rho sigma_t``).
    """
    V = np.pi * l * l * (3.0 * R - l) / 3.0
    b = l * (4.0 * R - l) / (4.0 * (3.0 * R - l))
    # moments in s (distance from the apex): M0 = V, M1, M2
    l2 = l * l
    l3 = l2 * l
    M1 = np.pi * l3 * (2.0 * R / 3.0 - l / 4.0)
    M2 = np.pi * l3 * l * (R / 2.0 - l / 5.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        sa = np.where(V > 0, M2 - M1 * M1 / np.where(V > 0, V, 1.0), 0.0)
    st = 0.25 * np.pi * l3 * (4.0 * R * R / 3.0 - R * l + l2 / 5.0)
    return V, b, sa, st


def lens_moments(ra, rb, ca, cb, D, e):
    """Moments of the overlap region of each pair of spheres.

    The region is a lens, or the smaller sphere where one sphere contains the other.

    Parameters
    ----------
    ra, rb : numpy.ndarray, shape (P,)
        Radii of the two spheres of each pair, in m.
    ca, cb : numpy.ndarray, shape (P, 3)
        Their centres relative to the clump origin, in m.
    D : numpy.ndarray, shape (P,)
        Distance between the centres, in m.
    e : numpy.ndarray, shape (P, 3)
        Unit axis ``(cb - ca) / D``.

    Returns
    -------
    volume : numpy.ndarray, shape (P,)
        Volume of each region, in m^3.
    centroid : numpy.ndarray, shape (P, 3)
        Its centroid relative to the clump origin, in m.
    sigma_t, sigma_ax : numpy.ndarray, shape (P,)
        Its central second moment ``C = sigma_t 1 + sigma_ax e e^T``, in m^5.
    """
    big_a = ra >= rb
    r_small = np.where(big_a, rb, ra)
    r_big = np.where(big_a, ra, rb)
    contained = D + r_small <= r_big
    lens = ~contained
    # caps: cap 1 on sphere a (apex towards b), cap 2 on sphere b (apex towards a)
    Dl = np.where(lens, D, 1.0)
    delta = ra + rb - D
    l1 = np.where(lens, delta * (rb - ra + D) / (2.0 * Dl), 0.0)
    l2 = np.where(lens, delta * (ra - rb + D) / (2.0 * Dl), 0.0)
    V1, b1, sa1, st1 = cap_moments(ra, l1)
    V2, b2, sa2, st2 = cap_moments(rb, l2)
    Vl = V1 + V2
    Vsafe = np.where(Vl > 0, Vl, 1.0)
    zL = (V1 * b1 - V2 * b2) / Vsafe  # lens centroid from the base plane, along e
    sig_a = sa1 + V1 * (b1 - zL) ** 2 + sa2 + V2 * (b2 + zL) ** 2
    sig_t = st1 + st2
    base = ca + (ra - l1)[:, None] * e
    pos = base + zL[:, None] * e
    if np.any(contained):
        # the overlap is the smaller sphere
        small_c = np.where(big_a[:, None], cb, ca)
        Vs = (4.0 / 3.0) * np.pi * r_small * r_small * r_small
        Vl = np.where(contained, Vs, Vl)
        pos = np.where(contained[:, None], small_c, pos)
        sig_t = np.where(contained, Vs * r_small**2 / 5.0, sig_t)
        sig_a = np.where(contained, sig_t, sig_a)
    return Vl, pos, sig_t, sig_a - sig_t


def check_no_triple_overlap(sph: Spheres, a, b, D, e):
    """Raise if any three spheres of a clump share an interior point.

    Parameters
    ----------
    sph : clumpprops._input.Spheres
        The checked, flattened spheres of M clumps (centres in m relative to each clump's
        origin, radii in m).
    a, b : numpy.ndarray of int, shape (P,)
        Global indices (into ``sph``) of the two spheres of each overlapping pair, ``a < b``.
    D : numpy.ndarray, shape (P,)
        Distance between their centres, in m.
    e : numpy.ndarray, shape (P, 3)
        Unit axis from sphere ``a`` to sphere ``b``.

    Raises
    ------
    ClumpGeometryError
        Naming the first triple found (and the clump, for a batch) and the number of triples.

    Notes
    -----
    For every triangle (i, j, k) of mutually overlapping spheres and each of its three
    balls, say i, the distance from c_i to the overlap region L_jk (a convex lens, or the
    smaller ball if one contains the other) is computed from its candidate closest points
    (projection onto either ball if it lies in the other one, or the nearest point of the
    rim circle; the smaller ball itself for a contained pair); the triple overlap has
    volume iff that distance is < r_i.  Asking all three balls makes the decision
    independent of the order of the spheres.  Three spheres overlapping pairwise around a
    hole pass.
    """
    if len(a) < 3 or sph.counts.max() < 3:
        return
    S = len(sph.radii)
    # adjacency as sorted global keys; triangles i<j<k with (i,j), (i,k), (j,k) all overlapping
    key = a * S + b
    order = np.argsort(key)
    key_sorted = key[order]
    # neighbours j>i of each i
    by_a = np.argsort(a, kind="stable")
    a_s, b_s = a[by_a], b[by_a]
    starts = np.searchsorted(a_s, np.arange(S))
    ends = np.searchsorted(a_s, np.arange(S), side="right")
    deg = ends - starts
    # pairs of neighbours (j, k) of i, j < k
    ii, jj, kk = [], [], []
    for d in np.unique(deg):
        if d < 2:
            continue
        nodes = np.flatnonzero(deg == d)
        nb = b_s[starts[nodes][:, None] + np.arange(d)]  # (n, d) sorted? make sure
        nb.sort(axis=1)
        u, v = np.triu_indices(d, 1)
        ii.append(np.repeat(nodes, len(u)))
        jj.append(nb[:, u].ravel())
        kk.append(nb[:, v].ravel())
    if not ii:
        return
    ii, jj, kk = np.concatenate(ii), np.concatenate(jj), np.concatenate(kk)
    kq = jj * S + kk
    pos = np.searchsorted(key_sorted, kq)
    pos = np.minimum(pos, len(key_sorted) - 1)
    tri = key_sorted[pos] == kq
    if not np.any(tri):
        return
    ii, jj, kk = ii[tri], jj[tri], kk[tri]
    bad = _shares_region(sph, ii, jj, kk)
    if np.any(bad):
        t = np.flatnonzero(bad)[0]
        m = int(sph.clump[ii[t]]) + sph.first_clump
        idx = sorted(int(sph.local[x]) for x in (ii[t], jj[t], kk[t]))
        where = f" of clump {m}" if sph.batched else ""
        n_bad = int(np.count_nonzero(bad))
        raise ClumpGeometryError(
            f"spheres {tuple(idx)}{where} share a common region (a triple overlap; {n_bad} such triple(s) in all): "
            "the pairwise method (paper eqs. 1-7) would be wrong there; use method='exact'"
        )


def _shares_region(sph: Spheres, i, j, k):
    """(T,) bool: balls i, j, k share a region of positive volume.

    Asks all three balls whether they reach the overlap region of the other two (each test
    is exact in exact arithmetic), so the answer does not depend on the order in which the
    spheres are listed, and a round-off miss seen from one ball cannot decide alone.
    """
    bad = np.zeros(len(i), dtype=bool)
    for p, a, b in ((i, j, k), (j, i, k), (k, i, j)):
        D, e = distance_and_axis(sph.centers[b] - sph.centers[a])
        bad |= _distance_to_overlap(sph, sph.centers[p], a, b, D, e) < sph.radii[p]
    return bad


def _distance_to_overlap(sph: Spheres, p, j, k, D, e):
    """Distance from points p (T,3) to the overlap region of balls j, k (T,).

    Where one ball lies in the other (identical and coincident balls included) the region is the
    smaller ball, whatever the order of j and k.  Otherwise the nearest point is that of one ball
    if it lies in the other ball (up to a relative 1e-12 of the radius: two balls that differ by
    round-off count as each other's region, so the check errs towards a refusal), else on the rim."""
    cj, ck = sph.centers[j], sph.centers[k]
    rj, rk = sph.radii[j], sph.radii[k]

    def proj_in_other(cx, rx, cy, ry):
        v = p - cx
        n = np.sqrt(np.einsum("ij,ij->i", v, v))
        outside = n > rx
        q = np.where(outside[:, None], cx + v * (rx / np.where(n > 0, n, 1.0))[:, None], p)
        w = q - cy
        ok = np.sqrt(np.einsum("ij,ij->i", w, w)) <= ry * (1.0 + 1e-12)
        dist = np.where(outside, n - rx, 0.0)
        return np.where(ok, dist, np.inf)

    big = np.maximum(rj, rk)
    small = np.minimum(rj, rk)
    nested = D + small <= big
    cs = np.where((rj <= rk)[:, None], cj, ck)
    d0 = np.maximum(np.sqrt(np.einsum("ij,ij->i", p - cs, p - cs)) - small, 0.0)
    d1 = proj_in_other(cj, rj, ck, rk)
    d2 = proj_in_other(ck, rk, cj, rj)
    # rim circle (only for a proper lens)
    lens = ~nested
    Dl = np.where(lens, D, 1.0)
    delta = rj + rk - D
    l1 = delta * (rk - rj + D) / (2.0 * Dl)
    rho = np.sqrt(np.clip(l1 * (2.0 * rj - l1), 0.0, None))
    m = cj + (rj - l1)[:, None] * e
    v = p - m
    vpar = np.einsum("ij,ij->i", v, e)
    vperp = v - vpar[:, None] * e
    npp = np.sqrt(np.einsum("ij,ij->i", vperp, vperp))
    d3 = np.sqrt(vpar**2 + (npp - rho) ** 2)
    d3 = np.where(lens, d3, np.inf)
    return np.where(nested, d0, np.minimum(np.minimum(d1, d2), d3))


def pairwise_moments(sph: Spheres, check=True):
    """Volume moments of the union by the paper's eqs. (4)-(7) (``method="pairwise"``).

    Parameters
    ----------
    sph : clumpprops._input.Spheres
        The checked, flattened spheres of M clumps (centres in m relative to each clump's
        origin, radii in m).
    check : bool, optional
        Run :func:`check_no_triple_overlap` (the equations are exact only without triple
        overlaps).

    Returns
    -------
    V, S, Q : numpy.ndarray, shapes (M,), (M, 3), (M, 3, 3)
        As :func:`sphere_moments` returns them, for the union.

    Raises
    ------
    ClumpGeometryError
        With ``check``, where three spheres of a clump share a region.
    """
    V, S, Q = sphere_moments(sph)
    if sph.regular and 2 <= sph.regular <= 16 and (not check or sph.regular == 2):
        # regular batch of small clumps: every pair in a fixed (M, P) layout, no gathers by
        # clump id; pairs that do not overlap are masked out
        M, N = sph.n_clumps, sph.regular
        iu, ju = np.triu_indices(N, 1)
        c3 = sph.centers.reshape(M, N, 3)
        r2 = sph.radii.reshape(M, N)
        ca, cb = c3[:, iu].reshape(-1, 3), c3[:, ju].reshape(-1, 3)
        ra, rb = r2[:, iu].ravel(), r2[:, ju].ravel()
        D, e = distance_and_axis(cb - ca)
        ov = D < ra + rb
        Vl, pos, sig_t, sig_ax = lens_moments(ra, rb, ca, cb, np.where(ov, D, ra + rb), e)
        Vl = np.where(ov, Vl, 0.0)
        sig_t = np.where(ov, sig_t, 0.0)
        sig_ax = np.where(ov, sig_ax, 0.0)
        P = len(iu)

        def ssum(w):
            return _rowsum(w.reshape(M, P))
    else:
        a, b, D, e = overlapping_pairs(sph)
        if check:
            check_no_triple_overlap(sph, a, b, D, e)
        if not len(a):
            return V, S, Q
        Vl, pos, sig_t, sig_ax = lens_moments(sph.radii[a], sph.radii[b], sph.centers[a], sph.centers[b], D, e)
        m = sph.clump[a]
        M = sph.n_clumps

        def ssum(w):
            return np.bincount(m, weights=w, minlength=M)

    V = V - ssum(Vl)
    Vp = Vl[:, None] * pos
    iso = ssum(sig_t)
    for x in range(3):
        S[:, x] -= ssum(Vp[:, x])
        Q[:, x, x] -= iso
        for y in range(x, 3):
            q = ssum(Vp[:, x] * pos[:, y] + sig_ax * e[:, x] * e[:, y])
            Q[:, x, y] -= q
            if y != x:
                Q[:, y, x] -= q
    return V, S, Q
