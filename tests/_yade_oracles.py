"""Oracles for the YADE adapter's compiled routines (``_core.adapter_clump``,
``_core.adapter_correction``, ``_core.state_errors``): the same formulas written independently in
numpy (vectorised over a batch) and in plain Python floats.  Tests compare the compiled results with
these; the adapter itself never calls them.
"""
import math

import numpy as np

from clumpprops.yade.correction import _heavy_error, _outside_error

_EPS = float(np.finfo(float).eps)
_FOUR_THIRDS_PI = (4.0 / 3.0) * math.pi


def sphere_moments(centers, radii, densities):
    """Mass (N,) and own inertia (N,) of member spheres exactly as YADE sums them."""
    vol = (4.0 / 3.0) * math.pi * radii**3.0
    m = densities * vol
    return m, 0.4 * m * radii**2



def pax(d):
    """Parallel-axis matrices |d|^2 1 - d d^T for d (..., 3)."""
    P = -d[..., :, None] * d[..., None, :]
    sq = np.einsum("...i,...i->...", d, d)
    for k in range(3):
        P[..., k, k] += sq
    return P



def correction_flat(x, r, rho, counts, mass, com, inertia, strict=True):
    """``clumpprops.yade.correction_terms`` in vectorised numpy on flat arrays: x (S, 3), r (S,), rho (S,),
    counts (M,) spheres per clump; LAPACK for the axes.  Same checks and messages (``k``: index in the batch)."""
    M = len(counts)
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    mass = np.asarray(mass, float).reshape(M)
    com = np.asarray(com, float).reshape(M, 3)
    inertia = np.asarray(inertia, float).reshape(M, 3, 3)
    m_i, j_i = sphere_moments(x, r, rho)
    d = x - np.repeat(com, counts, axis=0)  # sphere centres relative to the exact COM
    m_s = np.add.reduceat(m_i, starts)
    S = np.add.reduceat(m_i[:, None] * d, starts, axis=0)  # first moment of the spheres about the COM
    I_s = np.add.reduceat(m_i[:, None, None] * pax(d) + j_i[:, None, None] * np.eye(3), starts, axis=0)
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
    J = inertia - I_s - m_c[:, None, None] * pax(off)
    J = 0.5 * (J + np.swapaxes(J, 1, 2))
    w, V = np.linalg.eigh(J)
    flip = np.linalg.det(V) < 0
    V[flip, :, 2] *= -1.0
    return m_c, off, w, V



def correction_one(pts, radii, rhos, mass, com, inertia, strict=True, k=0):
    """``clumpprops.yade.correction_terms`` for ONE clump in plain Python floats, LAPACK for the axes.
    pts: [(x, y, z), ...], radii, rhos: lists; mass, com (3,), inertia (3, 3) nested lists.  Same
    formulas, checks and messages (``k``: index in the batch); returns (m_c, offset [3], moments [3],
    axes (3, 3) ndarray, right-handed columns)."""
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
        if di != d0:  # a density spread (see clumpprops.yade.correction_terms)
            spread = mi * abs(di - d0) / di
            sp += spread
            spd += spread * dist
        if dist > reach:
            reach = dist
    m_c = mass - m_s
    s_noise = 64.0 * _EPS * smd + spd
    if abs(m_c) * reach <= s_noise:  # round-off: no offset (see clumpprops.yade.correction_terms)
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



def quaternions(V):
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



def quaternion_one(V):
    """(w, x, y, z) of the rotation A = V^T, V a (3, 3) array of right-handed columns: the scalar
    counterpart of :func:`quaternions` (same branches, same formulas)."""
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



def rotations(q):
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



def errors_small(rows, mass, com, inertia, scale):
    """[(e_m, e_c, e_i), ...] of a small batch, one clump at a time in plain floats."""
    def lst(a):
        return a if isinstance(a, list) else np.asarray(a).tolist()

    return [errors_one(*args) for args in zip(rows, lst(mass), lst(com), lst(inertia), lst(scale))]



def errors_one(row, mass, com, inertia, scale):
    """:func:`state_errors_np` of one clump in plain floats: row (mass, pos, moments, ori as x, y, z, w),
    targets as lists."""
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



def state_errors_np(rows, mass, com, inertia, scale):
    """Relative errors (mass, centre of mass / radius of gyration, inertia / largest |moment|) of
    clump states ``rows`` (mass, pos (3), moments (3), ori as x, y, z, w) against targets (M,),
    (M, 3), (M, 3, 3), scale (M,): vectorised numpy, three arrays of shape (M,)."""
    M = len(rows)
    a = np.array(rows, dtype=float).reshape(M, 11)
    m_y, c_y, w_y = a[:, 0], a[:, 1:4], a[:, 4:7]
    R = rotations(a[:, 7:11])
    I_y = np.einsum("kij,kj,klj->kil", R, w_y, R)
    mass = np.asarray(mass, float)
    inertia = np.asarray(inertia, float)
    scale = np.maximum(np.asarray(scale, float), 1e-300)
    tr = np.maximum(np.trace(inertia, axis1=1, axis2=2), 0.0)
    gyr = np.where(mass > 0, np.sqrt(tr / (2.0 * np.where(mass > 0, mass, 1.0))), 1.0)
    e_m = np.abs(m_y - mass) / np.abs(mass)
    e_c = np.linalg.norm(c_y - np.asarray(com, float), axis=1) / np.maximum(gyr, 1e-300)
    e_i = np.max(np.abs(I_y - inertia), axis=(1, 2)) / scale
    return e_m, e_c, e_i
