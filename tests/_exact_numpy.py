"""The numpy implementation of the exact method: a TEST ORACLE only (not used by the library).

``method="exact"`` runs the compiled core (clumpprops/core/clumpprops.hpp).  This is a
vectorised numpy implementation of the same mathematics with an independent
arc classification (per-arc sign tests instead of coverage depth); tests compare the
core with it on thousands of random and near-degenerate clumps.  It also keeps
another form of rule S (touching circles: a sagitta threshold, where the core decides and
locates nearly touching crossings in double-double); the two differ on spheres through one
point with nearly coplanar centres, which no test compares (docs/exact_method.md, 2a).

Exact volume moments of a union of spheres with any overlap pattern.

The paper's eqs. (1)-(7) subtract pairwise lenses and are exact only where no point
lies in three spheres.  This module computes the same quantities (volume, centre of
mass, inertia tensor; eqs. 4-7 are the final assembly, done in ``_properties.finish``)
for the union of any number of spheres, from the boundary of the union:

1. Divergence theorem.  With F = x/3, x x_a/4 and x x_a x_b/5 (divergences 1, x_a and
   x_a x_b), every volume moment of the union U is a surface integral over its
   boundary, which is the union of the *exposed* parts E_i of the sphere surfaces.
   On sphere i (centre c, radius r, x = c + r u) the integrands are polynomials of
   degree <= 3 in the unit normal u, so each sphere needs only the moments
   a = int_E 1, m1 = int_E u, m2 = int_E u u^T, m3 = int_E u u u  (dOmega)
   of its exposed region E on the unit sphere.
2. E is the unit sphere minus a union of caps, one per overlapping neighbour
   (u.n_j > h_j).  Its boundary is a set of arcs of the cap circles, found exactly:
   circle-circle intersection points split each circle into arcs, and each arc is
   kept if no other cap covers it (decided at the arc's point farthest from that
   cap's circle, so the decision is robust to round-off).
3. Stokes on the sphere turns each moment into closed-form integrals over the arcs:
   for the zero-mean (spherical-harmonic degree l >= 1) parts, int_R Y dOmega =
   -1/(l(l+1)) oint grad(Y).nu ds, a trigonometric polynomial along each arc; for the
   area (degree 0) the 1-form (1 - cos theta) dphi about a pole q gives
   -h dt + 2 sgn(h + q.n) d[atan(k tan((t - delta)/2))] per arc, with the pole chosen
   far from every circle.  No quadrature, no sampling: the result is exact up to
   round-off.

Design note with derivations and limits: docs/exact_method.md.
"""
from __future__ import annotations

import numpy as np

from clumpprops._input import Spheres
from clumpprops._pairs import overlapping_pairs
from clumpprops.pairwise import sphere_moments

_FOUR_PI = 4.0 * np.pi
# candidate poles: 6 axes, 12 edge and 8 corner directions of a cube, and 6 more
_POLES = None
_CHUNK_ELEMENTS = 2_000_000  # max elements of the (spheres, K, 2K, K) arc-coverage arrays
_RHO_TANGENT = 1e-6  # caps of pairs closer than this to tangency are dropped (see _caps)
# a sphere protruding from another by at most this fraction of the smaller radius is
# inside it (see _buried_spheres and docs/exact_method.md, section 2a)
_TAU_NESTED = 1e-13
# two cap circles on one unit sphere closer than this everywhere are one circle (see
# _coincident_caps, _uncovered_caps and docs/exact_method.md, section 2a)
_COINCIDENT = 1e-13
# two circles of one unit sphere touch (do not cross) when the sagittas rho (1 - |cos alpha|) of
# the arcs between their crossing points are both at most this (the earlier rule S; the core now
# decides nearly touching pairs in double-double, docs/exact_method.md, 2a: the per-arc sign tests
# below need the snapping, they evaluate f_kj in double at points where it is at the round-off level)
_TOUCHING = 1e-13


def _poles():
    global _POLES
    if _POLES is None:
        g = np.array([(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if (x, y, z) != (0, 0, 0)], float)
        g /= np.linalg.norm(g, axis=1)[:, None]
        # a few irrational directions so no candidate sits on a symmetry plane of a regular clump
        rng = np.random.default_rng(12345)
        extra = rng.normal(size=(6, 3))
        extra /= np.linalg.norm(extra, axis=1)[:, None]
        _POLES = np.concatenate([g, extra])
    return _POLES


def _buried_spheres(a, b, D, ra, rb, S):
    """(S,) bool: spheres removed whole because they lie inside another sphere, up to tau.

    Sphere a counts as inside sphere b when its protrusion p_ab = (r_a - r_b) + D (how far
    ball a reaches out of ball b) is at most _TAU_NESTED * min(r_a, r_b): scale-aware, so
    a configuration and its image scaled by any factor get the same decision.  The part
    of ball a outside ball b then has volume < 4 pi r_a^2 p_ab (docs/exact_method.md,
    section 2a).  When both spheres of a pair count as inside each other (near-identical
    spheres), exactly one is removed: the one later in the strict order (larger radius
    first, then lower index), so every removal goes up that order, no cycle can remove
    both, and the first sphere of the order in each group of near-identical spheres stays.
    """
    s = np.minimum(ra, rb)
    tol = _TAU_NESTED * s
    a_in_b = (ra - rb) + D <= tol
    b_in_a = (rb - ra) + D <= tol
    # a precedes b in the order: larger radius, or the same radius and a < b (always, a < b)
    a_first = ra >= rb
    buried = np.zeros(S, bool)
    buried[a[a_in_b & ~(b_in_a & a_first)]] = True
    buried[b[b_in_a & ~(a_in_b & ~a_first)]] = True
    return buried


def _caps(sph: Spheres):
    """Caps cut on each sphere by its overlapping neighbours, and the buried spheres.

    Returns (owner (C,), n (C,3), h (C,), rho (C,)) for every cap u.n > h on the unit
    sphere of sphere ``owner``, and a boolean (S,) of spheres inside another sphere.
    """
    S = len(sph.radii)
    a, b, D, e = overlapping_pairs(sph)
    ra, rb = sph.radii[a], sph.radii[b]
    # containment, scale-aware, with one sphere of each near-identical group kept
    buried = _buried_spheres(a, b, D, ra, rb, S)
    keep = ~buried[a] & ~buried[b]
    a, b, D, e, ra, rb = a[keep], b[keep], D[keep], e[keep], ra[keep], rb[keep]
    delta = ra + rb - D  # > 0
    # cap on a (towards b): 1 - h_a = l_a / r_a, 1 + h_a = (r_a + D - r_b)(r_a + D + r_b) / (2 r_a D)
    omh_a = delta * ((rb - ra) + D) / (2.0 * ra * D)
    oph_a = ((ra - rb) + D) * (ra + D + rb) / (2.0 * ra * D)  # (ra - rb) first: exact for close radii
    omh_b = delta * ((ra - rb) + D) / (2.0 * rb * D)
    oph_b = ((rb - ra) + D) * (rb + D + ra) / (2.0 * rb * D)
    owner = np.concatenate([a, b])
    n = np.concatenate([e, -e])
    omh = np.concatenate([omh_a, omh_b])
    oph = np.concatenate([oph_a, oph_b])
    # h directly (accurate near 0, e.g. nearly coincident spheres); rho from the factored
    # 1 - h and 1 + h (accurate for tiny caps and nearly buried spheres)
    dr = (ra - rb) * (ra + rb)
    h = np.concatenate([(D * D + dr) / (2.0 * ra * D), (D * D - dr) / (2.0 * rb * D)])
    rho = np.sqrt(np.clip(omh * oph, 0.0, None))
    other = np.concatenate([b, a])
    # Near-tangent pairs (rim circle radius < _RHO_TANGENT of both spheres; round-off near
    # a tangency makes circles of radius ~sqrt(eps)): treat as tangent.  Externally: no
    # caps; internally: the inner sphere is buried.  Decided once per pair, for both
    # spheres.  The change is the lens volume, ~ pi/4 rho^4 r^3 < 1e-24 r^3, when no third
    # sphere meets the lens (otherwise see docs/exact_method.md, section 2a, rule T).
    P = len(a)
    tiny = np.maximum(rho[:P], rho[P:]) < _RHO_TANGENT
    if np.any(tiny):
        inner_a = tiny & (h[:P] < 0)
        inner_b = tiny & (h[P:] < 0)
        buried[a[inner_a]] = True
        buried[b[inner_b]] = True
        drop = np.concatenate([tiny, tiny])
        drop |= buried[owner] | buried[other]
        owner, other, n, h, rho = owner[~drop], other[~drop], n[~drop], h[~drop], rho[~drop]
    return owner, other, n, h, rho, buried


_EINSUM_PATHS: dict = {}


def _einsum(subscripts, *operands):
    """np.einsum with the contraction order computed once per subscripts (it does not depend on sizes)."""
    path = _EINSUM_PATHS.get(subscripts)
    if path is None:
        probe = [np.ones(tuple(4 if ch in "ck" else 3 for ch in sub)) for sub in subscripts.split("->")[0].split(",")]
        path = _EINSUM_PATHS[subscripts] = np.einsum_path(subscripts, *probe, optimize="greedy")[0]
    return np.einsum(subscripts, *operands, optimize=path)


def _basis(n):
    """Orthonormal e1, e2 with (e1, e2, n) right-handed; n (..., 3) unit."""
    ax = np.where((np.abs(n[..., 0]) < 0.9)[..., None], np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    e1 = ax - np.sum(ax * n, axis=-1)[..., None] * n
    e1 /= np.linalg.norm(e1, axis=-1)[..., None]
    e2 = np.cross(n, e1)
    return e1, e2


def _sphere_surface_moments(n, h, rho):
    """Moments a, m1, m2, m3 of the exposed region of unit spheres, chunk of C spheres with K caps each.

    n (C,K,3), h (C,K), rho (C,K); no two of a sphere's circles coincide (``_uncovered_caps``).
    Returns a (C,), m1 (C,3), m2 (C,3,3), m3 (C,3,3,3).
    """
    C, K = h.shape
    e1, e2 = _basis(n)
    # --- circle k against cap j: f_kj(t) = u_k(t).n_j - h_j = m_kj + R_kj cos(t - phi_kj)
    # without cancellation (docs/exact_method.md, section 2a, rule X): with s = sgn(g) and
    # d = n_j - s n_k, A, B = rho_k e1.d, rho_k e2.d and m = (s h_k - h_j) - s h_k |d|^2 / 2,
    # s h_k - h_j from the accurate 1 - h = rho^2 / (1 + h) and 1 + h = rho^2 / (1 - h) where it cancels
    g = np.einsum("ckx,cjx->ckj", n, n)
    s = np.where(g >= 0.0, 1.0, -1.0)
    d = n[:, None, :, :] - s[..., None] * n[:, :, None, :]  # [c, k, j]: n_j - s n_k
    half_d2 = 0.5 * np.einsum("ckjx,ckjx->ckj", d, d)
    A = rho[:, :, None] * np.einsum("ckx,ckjx->ckj", e1, d)
    B = rho[:, :, None] * np.einsum("ckx,ckjx->ckj", e2, d)
    R = np.hypot(A, B)
    phi = np.arctan2(B, A)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(h > 0.0, rho * rho / (1.0 + h), 1.0 - h)  # 1 - h
        v = np.where(h < 0.0, rho * rho / (1.0 - h), 1.0 + h)  # 1 + h
    hk, hj, wk, wj, vk, vj = h[:, :, None], h[:, None, :], w[:, :, None], w[:, None, :], v[:, :, None], v[:, None, :]
    dh_same = np.where((hk > 0) & (hj > 0), wj - wk, np.where((hk < 0) & (hj < 0), vk - vj, hk - hj))
    dh_opp = np.where((hk > 0) & (hj < 0), wk - vj, np.where((hk < 0) & (hj > 0), wj - vk, -(hk + hj)))
    m = np.where(s > 0, dh_same, dh_opp) - s * hk * half_d2
    pair = np.broadcast_to(~np.eye(K, dtype=bool), (C, K, K))
    with np.errstate(divide="ignore", invalid="ignore"):
        cosarg = -m / R
    crosses = pair & (R > 0) & (np.abs(cosarg) < 1.0)
    # rule S: touching circles (sagitta rho (1 - |cos alpha|) of the arcs between the two crossing
    # points at most _TOUCHING on both circles) do not cross
    with np.errstate(invalid="ignore"):
        sag = rho[:, :, None] * (1.0 - np.abs(cosarg))
        touching = (sag <= _TOUCHING) & (np.swapaxes(sag, 1, 2) <= _TOUCHING)
    crosses &= ~touching
    ac = np.arccos(np.clip(cosarg, -1.0, 1.0))
    two_pi = 2.0 * np.pi
    t_a = phi + ac
    t_b = phi - ac
    # Each crossing point is computed once, on the circle of the pair with the smaller radius
    # (the lower slot on a tie: the better-conditioned one, docs/exact_method.md, 2a, rule S),
    # and located on the other circle from that same 3-D point: the boundary of the union of
    # caps then closes exactly even where two circles nearly coincide (crossing angles
    # ill-conditioned).  upper[c, k, j]: computed on k.
    rk, rj = rho[:, :, None], rho[:, None, :]
    upper = (rk < rj) | ((rk == rj) & np.triu(np.ones((K, K), dtype=bool), 1)[None])
    crosses = np.where(upper, crosses, np.swapaxes(crosses, 1, 2))
    # (no two circles here coincide: _uncovered_caps removed such caps, see _coincident_caps)

    def on_other_circle(t):
        ct, st = np.cos(t), np.sin(t)
        P = (h[:, :, None, None] * n[:, :, None, :] + rho[:, :, None, None]
             * (ct[..., None] * e1[:, :, None, :] + st[..., None] * e2[:, :, None, :]))
        P = np.swapaxes(P, 1, 2)  # [c, j, k]: point computed on circle k, seen from circle j
        return np.arctan2(np.einsum("cjkx,cjx->cjk", P, e2), np.einsum("cjkx,cjx->cjk", P, e1))

    t_a = np.mod(np.where(upper, t_a, on_other_circle(t_a)), two_pi)
    t_b = np.mod(np.where(upper, t_b, on_other_circle(t_b)), two_pi)
    pts = np.concatenate([np.where(crosses, t_a, np.inf), np.where(crosses, t_b, np.inf)], axis=2)  # (C,K,2K)
    # which cap each split point crosses, and whether circle k enters it there (+1) or
    # leaves it (-1): at t = phi + ac, f_kj decreases (leaves), at phi - ac it increases;
    # on the other circle of a shared crossing point the direction is the opposite one
    jj = np.broadcast_to(np.concatenate([np.arange(K), np.arange(K)]), pts.shape)
    up2 = np.concatenate([np.broadcast_to(upper, (C, K, K)), np.broadcast_to(upper, (C, K, K))], axis=2)
    typ = np.where(up2, 1, -1) * np.concatenate([-np.ones(K, int), np.ones(K, int)])
    order = np.argsort(pts, axis=2)
    pts = np.take_along_axis(pts, order, axis=2)
    P = np.count_nonzero(np.isfinite(pts), axis=2)  # (C,K)
    Q = max(int(P.max()), 1)  # most circles meet few others: drop the all-padding tail
    order = order[:, :, :Q]
    pts = pts[:, :, :Q]
    jq = np.take_along_axis(jj, order, axis=2)
    tq = np.take_along_axis(typ, order, axis=2)
    idx = np.arange(Q)
    t1 = np.where(P[:, :, None] > 0, pts, 0.0)
    nxt = np.where(idx[None, None, :] + 1 < P[:, :, None], idx + 1, 0)
    t2 = np.take_along_axis(pts, np.broadcast_to(nxt, pts.shape), axis=2)
    wrap = idx[None, None, :] + 1 >= P[:, :, None]
    t2 = np.where(wrap, t2 + two_pi, t2)
    full = P == 0
    t1 = np.where(full[:, :, None], 0.0, t1)
    t2 = np.where(full[:, :, None], two_pi, t2)
    arc_ok = (idx[None, None, :] < P[:, :, None]) | (full[:, :, None] & (idx == 0))
    t1 = np.where(arc_ok, t1, 0.0)
    t2 = np.where(arc_ok, t2, 0.0)
    # --- coverage of each arc by each other cap j.  f_j has no zero inside the arc (its
    # crossings are split points), so the sign of f_j at the arc point of largest |f_j|
    # (an end point, or the extremum of f_j if it lies inside the arc) decides robustly.
    # Most (arc, cap) pairs are decided at the arc's midpoint: |f(t) - f(t_mid)| <= R |t - t_mid|,
    # so f(t_mid) beyond R * span / 2 fixes the sign on the whole arc.  The rest get the
    # robust test below, on the gathered subset only.
    tm = 0.5 * (t1 + t2)
    half = (0.5 * (t2 - t1))[..., None]
    fm = m[:, :, None, :] + A[:, :, None, :] * np.cos(tm)[..., None] + B[:, :, None, :] * np.sin(tm)[..., None]
    bound = R[:, :, None, :] * half
    covered = fm > bound
    unsure = np.abs(fm) <= bound
    # the caps crossed at the arc's ends are decided combinatorially below: not here
    has_split = (P > 0)[:, :, None] & arc_ok
    jn = np.take_along_axis(jq, np.broadcast_to(nxt, jq.shape), axis=2)
    tn = np.take_along_axis(tq, np.broadcast_to(nxt, tq.shape), axis=2)
    for jsel in (jq, jn):
        cur = np.take_along_axis(unsure, jsel[..., None], axis=3)[..., 0]
        np.put_along_axis(unsure, jsel[..., None], (cur & ~has_split)[..., None], axis=3)
    if np.any(unsure):
        ci, ki, qi, ji = np.nonzero(unsure)
        mm, AA, BB, RR, ph = m[ci, ki, ji], A[ci, ki, ji], B[ci, ki, ji], R[ci, ki, ji], phi[ci, ki, ji]
        T1, T2 = t1[ci, ki, qi], t2[ci, ki, qi]
        f1 = mm + AA * np.cos(T1) + BB * np.sin(T1)
        f2 = mm + AA * np.cos(T2) + BB * np.sin(T2)
        span = T2 - T1
        fhi = np.maximum(f1, f2)
        fhi = np.where(np.mod(ph - T1, two_pi) < span, np.maximum(fhi, mm + RR), fhi)
        flo = np.minimum(f1, f2)
        flo = np.where(np.mod(ph + np.pi - T1, two_pi) < span, np.minimum(flo, mm - RR), flo)
        covered[ci, ki, qi, ji] = fhi + flo > 0  # the value of largest magnitude is positive
    # the caps crossed at the arc's two ends are decided by the crossing directions, the
    # same way on both circles of each crossing point, so the boundary of the union of caps
    # closes even where several circles pass (nearly) through one point
    for jsel, dec in ((jn, tn == -1), (jq, tq == 1)):
        cur = np.take_along_axis(covered, jsel[..., None], axis=3)[..., 0]
        np.put_along_axis(covered, jsel[..., None], np.where(has_split, dec, cur)[..., None], axis=3)
    covered &= pair[:, :, None, :]
    exposed = arc_ok & ~np.any(covered, axis=3)  # (C,K,Q)
    # --- closed-form arc integrals, summed over each circle's exposed arcs
    t1 = np.where(exposed, t1, 0.0)
    t2 = np.where(exposed, t2, 0.0)
    dt = t2 - t1
    s1, s2, c1, c2 = np.sin(t1), np.sin(t2), np.cos(t1), np.cos(t2)
    sin2 = np.sin(2 * t2) - np.sin(2 * t1)
    sm = lambda x: x.sum(axis=2)  # noqa: E731
    Dt = sm(dt)
    Ic = sm(s2 - s1)
    Is = sm(c1 - c2)
    Icc = 0.5 * Dt + 0.25 * sm(sin2)
    Iss = 0.5 * Dt - 0.25 * sm(sin2)
    Ics = 0.5 * sm(s2 * s2 - s1 * s1)
    s1c, s2c, c1c, c2c = s1 * s1 * s1, s2 * s2 * s2, c1 * c1 * c1, c2 * c2 * c2
    Iccc = sm((s2 - s2c / 3.0) - (s1 - s1c / 3.0))
    Isss = sm((-c2 + c2c / 3.0) - (-c1 + c1c / 3.0))
    Iccs = -sm(c2c - c1c) / 3.0
    Icss = sm(s2c - s1c) / 3.0
    W1s = np.stack([Dt, Ic, Is], axis=-1)  # (C,K,3)
    W2s = np.stack([np.stack([Dt, Ic, Is], -1), np.stack([Ic, Icc, Ics], -1), np.stack([Is, Ics, Iss], -1)], -2)
    W3s = np.empty((C, K, 3, 3, 3))
    vals = {
        (0, 0, 0): Dt, (0, 0, 1): Ic, (0, 0, 2): Is, (0, 1, 1): Icc, (0, 1, 2): Ics,
        (0, 2, 2): Iss, (1, 1, 1): Iccc, (1, 1, 2): Iccs, (1, 2, 2): Icss, (2, 2, 2): Isss,
    }
    for (p, q_, r_), v in vals.items():
        for perm in {(p, q_, r_), (p, r_, q_), (q_, p, r_), (q_, r_, p), (r_, p, q_), (r_, q_, p)}:
            W3s[..., perm[0], perm[1], perm[2]] = v
    # vector coefficients of u(t) = U0 + U1 cos t + U2 sin t and nu = u' x u = N0 + N1 cos t + N2 sin t
    U = np.stack([h[..., None] * n, rho[..., None] * e1, rho[..., None] * e2], axis=2)  # (C,K,3 basis,3 xyz)
    N = np.stack([-(rho**2)[..., None] * n, (h * rho)[..., None] * e1, (h * rho)[..., None] * e2], axis=2)
    J1 = np.einsum("ckp,ckpx->cx", W1s, N)
    J2 = _einsum("ckpq,ckpx,ckqy->cxy", W2s, N, U)
    J3 = _einsum("ckpqr,ckpx,ckqy,ckrz->cxyz", W3s, N, U, U)
    # --- area of the union of caps, with the pole q far from every circle
    poles = _poles()
    qn = np.einsum("px,ckx->cpk", poles, n)  # (C,P,K)
    alpha = np.arctan2(rho, h)  # angular radius of each cap
    dist = np.abs(np.arccos(np.clip(-qn, -1.0, 1.0)) - alpha[:, None, :])
    best_pole = np.argmax(dist.min(axis=2), axis=1)
    q = poles[best_pole]  # (C,3)
    qn = np.einsum("cx,ckx->ck", q, n)
    qe1 = np.einsum("cx,ckx->ck", q, e1)
    qe2 = np.einsum("cx,ckx->ck", q, e2)
    Dd = 1.0 + h * qn
    Rr = rho * np.hypot(qe1, qe2)
    kk = np.abs(h + qn) / (Dd + Rr)
    sg = np.sign(h + qn)
    dl = np.arctan2(qe2, qe1)

    def G(t):
        x = 0.5 * (t - dl[..., None])
        sx, cx = np.sin(x), np.cos(x)
        k = kk[..., None]
        return x + np.arctan2((k - 1.0) * sx * cx, cx * cx + k * sx * sx)

    arcA = -h[..., None] * dt + 2.0 * sg[..., None] * np.where(exposed, G(t2) - G(t1), 0.0)
    in_U = np.any(-qn > h, axis=1)
    area_U = arcA.sum(axis=(1, 2)) + _FOUR_PI * in_U
    a = _FOUR_PI - area_U
    m1 = 0.5 * J1
    eye = np.eye(3)
    m2 = a[:, None, None] / 3.0 * eye + (J2 + np.swapaxes(J2, 1, 2)) / 6.0
    sym3 = J3 + np.transpose(J3, (0, 2, 1, 3)) + np.transpose(J3, (0, 2, 3, 1))
    T = (
        eye[None, :, :, None] * J1[:, None, None, :]
        + eye[None, :, None, :] * J1[:, None, :, None]
        + eye[None, None, :, :] * J1[:, :, None, None]
    )
    m3 = (sym3 + T) / 12.0
    return a, m1, m2, m3


def _single_cap_moments(n, h, rho):
    """a, m1, m2, m3 of the unit sphere minus one cap u.n > h, in closed form (C spheres).

    With z = u.n and P = 1 - n n^T, the cap's moments are: area 2 pi w, int u = pi (1 - h^2) n,
    int u u^T = 2 pi (1 - h^3)/3 n n^T + pi [w - (1 - h^3)/3] P and
    int u u u = alpha n n n + beta sym(n P), alpha = pi (1 - h^4)/2,
    beta = pi [(1 - h^2)/2 - (1 - h^4)/4], where w = 1 - h is taken as rho^2 / (1 + h)
    for h > 0 so that tiny caps keep their digits.
    """
    w = np.where(h > 0, rho * rho / (1.0 + h), 1.0 - h)  # 1 - h
    oph = 2.0 - w  # 1 + h
    one_m_h2 = w * oph
    one_m_h3 = w * (1.0 + h + h * h)
    one_m_h4 = one_m_h2 * (1.0 + h * h)
    pi = np.pi
    nn = n[:, :, None] * n[:, None, :]
    Pp = np.eye(3)[None] - nn
    a = _FOUR_PI - 2.0 * pi * w
    m1 = -(pi * one_m_h2)[:, None] * n
    cap2 = (2.0 * pi * one_m_h3 / 3.0)[:, None, None] * nn + (pi * (w - one_m_h3 / 3.0))[:, None, None] * Pp
    m2 = (_FOUR_PI / 3.0) * np.eye(3)[None] - cap2
    alpha = 0.5 * pi * one_m_h4
    beta = pi * (0.5 * one_m_h2 - 0.25 * one_m_h4)
    nP = n[:, :, None, None] * Pp[:, None, :, :]
    sym = nP + np.transpose(nP, (0, 2, 1, 3)) + np.transpose(nP, (0, 2, 3, 1))
    m3 = -(alpha[:, None, None, None] * n[:, :, None, None] * nn[:, None, :, :] + beta[:, None, None, None] * sym)
    return a, m1, m2, m3


def _volume_moments_from_surface(c, r, a, m1, m2, m3):
    """Per-sphere V, S, Q contributions (divergence theorem) from unit-sphere moments of E."""
    cm1 = np.einsum("sx,sx->s", c, m1)
    base = r * a + cm1
    r2 = r * r
    V = r2 / 3.0 * base
    m2c = np.einsum("sxy,sy->sx", m2, c)
    S = (r2 / 4.0)[:, None] * (c * base[:, None] + r2[:, None] * m1 + r[:, None] * m2c)
    m3c = np.einsum("sxyz,sz->sxy", m3, c)
    cc = c[:, :, None] * c[:, None, :]
    cm = c[:, :, None] * m1[:, None, :]
    cq = c[:, :, None] * m2c[:, None, :]
    Q = (r2 / 5.0)[:, None, None] * (
        cc * base[:, None, None]
        + r2[:, None, None] * (cm + np.swapaxes(cm, 1, 2))
        + r[:, None, None] * (cq + np.swapaxes(cq, 1, 2))
        + (r2 * r)[:, None, None] * m2
        + r2[:, None, None] * m3c
    )
    return V, S, Q


def _grouped(owner, other, per_sphere_cost):
    """Yield (C, K) row-index arrays of caps: C spheres with exactly K caps each, chunked in memory."""
    order = np.lexsort((other, owner))
    _, start, counts = np.unique(owner[order], return_index=True, return_counts=True)
    for K in np.unique(counts):
        grp = np.flatnonzero(counts == K)
        per = max(1, _CHUNK_ELEMENTS // per_sphere_cost(int(K)))
        for g0 in range(0, len(grp), per):
            gs = grp[g0 : g0 + per]
            yield order[start[gs][:, None] + np.arange(K)[None, :]]


def _coincident_caps(n, h, rho):
    """[c, k, j] bool: circles k and j of one sphere coincide (within _COINCIDENT); g = n_k.n_j, |n_k x n_j|.

    On circle k, f_kj = u.n_j - h_j = m_kj + R_kj cos(t - phi) with m_kj = h_k g - h_j and
    R_kj = rho_k |n_k x n_j|; the circles coincide when |f| <= tol all along both of them,
    |m_kj| + R_kj <= tol and |m_jk| + R_jk <= tol (symmetric, and in units of the sphere's
    radius: scale-free).  g > 0: the same cap twice; g < 0: complementary caps.
    """
    K = h.shape[1]
    g = np.einsum("ckx,cjx->ckj", n, n)
    sin_kj = np.linalg.norm(np.cross(n[:, :, None, :], n[:, None, :, :]), axis=-1)
    dev = np.abs(h[:, :, None] * g - h[:, None, :]) + rho[:, :, None] * sin_kj
    near = dev <= _COINCIDENT
    return near & np.swapaxes(near, 1, 2) & ~np.eye(K, dtype=bool)[None], g, sin_kj


def _uncovered_caps(n, h, rho, rank):
    """Caps that matter: (C,K) bool of caps to keep, and (C,) bool of spheres covered entirely.

    1. Coincident circles (``_coincident_caps``) are one circle, decided once here so that
       every other circle of the sphere sees a single circle (two copies a round-off apart
       would each be crossed by a third circle, at points a round-off apart, and a piece
       of arc between them would be left without the rest of its boundary).  Of equally
       oriented coincident caps the lowest-ranked is kept; two oppositely oriented ones
       (complementary caps, e.g. on the middle one of three spheres through one circle)
       cover the whole sphere up to a band narrower than _COINCIDENT: the sphere is
       covered entirely and contributes nothing.
    2. Of the remaining caps, cap j lying in cap k (angle(n_j, n_k) + alpha_j <= alpha_k)
       is dropped: it changes nothing.  No two remaining caps coincide, so the relation
       has no cycle and every dropped cap lies in a kept one.
    """
    C, K = h.shape
    if K == 1:
        return np.ones(h.shape, bool), np.zeros(C, bool)
    coincident, g, sin_kj = _coincident_caps(n, h, rho)
    covered_all = np.any(coincident & (g < 0), axis=(1, 2))
    lower = rank[:, None, :] < rank[:, :, None]  # [c, k, j]: j ranks before k
    keep = ~np.any(coincident & (g > 0) & lower, axis=2)
    alpha = np.arctan2(rho, h)
    theta = np.arctan2(sin_kj, g)
    inside = theta + alpha[:, :, None] <= alpha[:, None, :]  # [c, j, k]: cap j within cap k
    inside &= ~coincident & keep[:, None, :] & ~np.eye(K, dtype=bool)[None]
    keep &= ~np.any(inside, axis=2)
    keep &= ~covered_all[:, None]
    return keep, covered_all


def exact_moments(sph: Spheres):
    """Per-clump volume V (M,), first moment S (M,3) and second moment Q (M,3,3) of each union."""
    S_n = len(sph.radii)
    M = sph.n_clumps
    owner, other, n, h, rho, buried = _caps(sph)
    # spheres untouched by any cap and not buried: whole balls
    has_cap = np.zeros(S_n, bool)
    has_cap[owner] = True
    whole = ~has_cap & ~buried
    V = np.zeros(M)
    Sm = np.zeros((M, 3))
    Qm = np.zeros((M, 3, 3))
    if np.any(whole):
        sub = np.flatnonzero(whole)
        rs = sph.radii[sub]
        v = (4.0 / 3.0) * np.pi * rs * rs * rs  # as in sphere_moments, to the last bit
        c = sph.centers[sub]
        cl = sph.clump[sub]
        V += np.bincount(cl, weights=v, minlength=M)
        for x in range(3):
            Sm[:, x] += np.bincount(cl, weights=v * c[:, x], minlength=M)
            for y in range(3):
                w = v * c[:, x] * c[:, y] + (v * sph.radii[sub] ** 2 / 5.0 if x == y else 0.0)
                Qm[:, x, y] += np.bincount(cl, weights=w, minlength=M)
    if len(owner):
        keep = np.zeros(len(owner), bool)
        for rows in _grouped(owner, other, per_sphere_cost=lambda K: K * K + 8):
            keep[rows], _ = _uncovered_caps(n[rows], h[rows], rho[rows], other[rows])
        owner, other, n, h, rho = owner[keep], other[keep], n[keep], h[keep], rho[keep]
        for rows in _grouped(owner, other, per_sphere_cost=lambda K: 2 * K * K * K + 64):
            if rows.shape[1] == 1:
                a, m1, m2, m3 = _single_cap_moments(n[rows[:, 0]], h[rows[:, 0]], rho[rows[:, 0]])
            else:
                a, m1, m2, m3 = _sphere_surface_moments(n[rows], h[rows], rho[rows])
            ids = owner[rows[:, 0]]
            v, s, q = _volume_moments_from_surface(sph.centers[ids], sph.radii[ids], a, m1, m2, m3)
            cl = sph.clump[ids]
            V += np.bincount(cl, weights=v, minlength=M)
            for x in range(3):
                Sm[:, x] += np.bincount(cl, weights=s[:, x], minlength=M)
                for y in range(3):
                    Qm[:, x, y] += np.bincount(cl, weights=q[:, x, y], minlength=M)
    return V, Sm, Qm
