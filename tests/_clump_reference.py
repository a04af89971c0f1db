"""Independent reference computations for the tests (no clumpprops code is used here).

Bodies of revolution about an axis e (two spheres on the axis: their union or their
intersection) are integrated slice by slice: the cross-section perpendicular to the
axis at height z is a single disc of squared radius q(z) = max(q1, q2) (union) or
min(q1, q2) (intersection, where both are > 0), with q_k(z) = R_k^2 - (z - z_k)^2.
Between the breakpoints (sphere poles, and the rim plane z* where q1 = q2) q is one
polynomial, so

    V = int pi q dz,  S_z = int z pi q dz,  S_zz = int z^2 pi q dz,
    Q_t = int x^2 dV = int pi q^2 / 4 dz      (second moment of a disc),

are integrated exactly piece by piece: with ``scipy.integrate.quad`` (float) or with
exact polynomial antiderivatives in ``mpmath`` (any precision).

A body is returned as (V, centroid (3,), central second moment Qc (3,3)) with
Qc = int (x - c)(x - c)^T dV; :func:`combine` adds bodies with signs (inclusion-
exclusion) and :func:`inertia` turns Qc into I = rho (tr Qc 1 - Qc).
"""
from __future__ import annotations

import math
import warnings

import mpmath
import numpy as np
from scipy.integrate import IntegrationWarning, quad


# ---------------------------------------------------------------- float / quad
def _breakpoints(R1, R2, D):
    pts = {-R1, R1, D - R2, D + R2}
    if D > 0:
        pts.add((R1 * R1 - R2 * R2 + D * D) / (2 * D))
    lo, hi = min(-R1, D - R2), max(R1, D + R2)
    return sorted(p for p in pts if lo <= p <= hi)


def axisym_moments_quad(R1, R2, D, kind="union"):
    """V, S_z, S_zz, Q_t (unit density) of two spheres at z=0 (R1) and z=D (R2), by quad.

    kind: "union" or "intersection".  Lengths in m, results in m^3, m^4, m^5, m^5.
    """

    def q(z):
        q1 = R1 * R1 - z * z
        q2 = R2 * R2 - (z - D) * (z - D)
        if kind == "union":
            return max(q1, q2, 0.0)
        return min(q1, q2) if (q1 > 0 and q2 > 0) else 0.0

    pts = _breakpoints(R1, R2, D)
    out = np.zeros(4)
    with warnings.catch_warnings():
        # each piece is a polynomial of degree <= 4, integrated exactly by the 21-point
        # Gauss-Kronrod rule; quad's error estimate cannot certify 1e-13 and warns
        warnings.simplefilter("ignore", IntegrationWarning)
        for a, b in _pieces(pts):
            _accumulate(out, q, a, b)
    return tuple(out)


def _pieces(pts):
    return [(a, b) for a, b in zip(pts[:-1], pts[1:]) if b > a]


def _accumulate(out, q, a, b):
    integrands = (
        lambda z: math.pi * q(z),
        lambda z: math.pi * z * q(z),
        lambda z: math.pi * z * z * q(z),
        lambda z: math.pi * q(z) ** 2 / 4.0,
    )
    for k, f in enumerate(integrands):
        val, _ = quad(f, a, b, epsabs=0.0, epsrel=1e-13, limit=200)
        out[k] += val


def body_from_axisym(V, Sz, Szz, Qt, c1, e):
    """(V, centroid, Qc) in world axes of an axisymmetric body on axis e through c1 (z = 0 at c1)."""
    e = np.asarray(e, float) / np.linalg.norm(e)
    zc = Sz / V
    Qzz = Szz - Sz * zc
    P = np.outer(e, e)
    Qc = Qt * (np.eye(3) - P) + Qzz * P
    return V, np.asarray(c1, float) + zc * e, Qc


def sphere_body(c, R):
    """A solid sphere: V = 4/3 pi R^3, Qc = V R^2 / 5 * 1."""
    V = 4.0 / 3.0 * math.pi * R**3
    return V, np.asarray(c, float), V * R * R / 5.0 * np.eye(3)


def pair_body(c1, R1, c2, R2, kind="union"):
    """Union or intersection (lens) of two spheres, integrated with quad."""
    c1, c2 = np.asarray(c1, float), np.asarray(c2, float)
    d = c2 - c1
    D = float(np.linalg.norm(d))
    e = d / D if D > 0 else np.array([0.0, 0.0, 1.0])
    V, Sz, Szz, Qt = axisym_moments_quad(R1, R2, D, kind)
    return body_from_axisym(V, Sz, Szz, Qt, c1, e)


def combine(bodies, signs=None):
    """Signed sum of bodies: total (V, centroid, Qc)."""
    if signs is None:
        signs = [1.0] * len(bodies)
    V = sum(s * b[0] for s, b in zip(signs, bodies))
    com = sum(s * b[0] * b[1] for s, b in zip(signs, bodies)) / V
    Qc = np.zeros((3, 3))
    for s, (v, c, q) in zip(signs, bodies):
        r = c - com
        Qc += s * (q + v * np.outer(r, r))
    return V, com, Qc


def inertia(Qc, rho):
    """Inertia tensor (kg m^2) from central second moment (m^5) and density (kg/m^3)."""
    return rho * (np.trace(Qc) * np.eye(3) - Qc)


def lens_volume_closed_form(R1, R2, D):
    """Volume of the intersection of two spheres, pi (R1+R2-D)^2 (D^2 + 2D(R1+R2) - 3(R1-R2)^2) / (12 D)."""
    return math.pi * (R1 + R2 - D) ** 2 * (D * D + 2 * D * (R1 + R2) - 3 * (R1 - R2) ** 2) / (12 * D)


# ---------------------------------------------------------------- mpmath, exact polynomials
def _pmul(p, q):
    out = [mpmath.mpf(0)] * (len(p) + len(q) - 1)
    for i, a in enumerate(p):
        for j, b in enumerate(q):
            out[i + j] += a * b
    return out


def _pint(p, a, b):
    return sum(c * (b ** (k + 1) - a ** (k + 1)) / (k + 1) for k, c in enumerate(p))


def dimer_moments_mp(R1, R2, D, kind="union", dps=60):
    """Exact V, S_z, S_zz, Q_t (unit density, mpf) of two spheres at z=0 (R1), z=D (R2).

    Inputs may be floats (taken exactly) or mpf.  Piecewise polynomial integration.
    """
    with mpmath.workdps(dps):
        R1, R2, D = mpmath.mpf(R1), mpmath.mpf(R2), mpmath.mpf(D)
        polys = [
            [R1 * R1, mpmath.mpf(0), mpmath.mpf(-1)],
            [R2 * R2 - D * D, 2 * D, mpmath.mpf(-1)],
        ]
        pts = {-R1, R1, D - R2, D + R2}
        if D > 0:
            pts.add((R1 * R1 - R2 * R2 + D * D) / (2 * D))
        lo, hi = min(-R1, D - R2), max(R1, D + R2)
        pts = sorted(p for p in pts if lo <= p <= hi)
        V = Sz = Szz = Qt = mpmath.mpf(0)
        for a, b in zip(pts[:-1], pts[1:]):
            if b <= a:
                continue
            m = (a + b) / 2
            vals = [p[0] + p[1] * m + p[2] * m * m for p in polys]
            if kind == "union":
                k = 0 if vals[0] >= vals[1] else 1
                if vals[k] <= 0:
                    continue
            else:
                if vals[0] <= 0 or vals[1] <= 0:
                    continue
                k = 0 if vals[0] <= vals[1] else 1
            p = polys[k]
            V += mpmath.pi * _pint(p, a, b)
            Sz += mpmath.pi * _pint(_pmul(p, [0, 1]), a, b)
            Szz += mpmath.pi * _pint(_pmul(p, [0, 0, 1]), a, b)
            Qt += mpmath.pi * _pint(_pmul(p, p), a, b) / 4
        return V, Sz, Szz, Qt


def dimer_reference_mp(c1, R1, c2, R2, rho, dps=60):
    """Mass (kg), COM (3,) m, inertia (3,3) kg m^2 of the union of two spheres, in mpmath.

    Returns plain floats (rounded once from the high-precision values).
    """
    with mpmath.workdps(dps):
        c1 = [mpmath.mpf(float(x)) for x in c1]
        c2 = [mpmath.mpf(float(x)) for x in c2]
        d = [b - a for a, b in zip(c1, c2)]
        D = mpmath.sqrt(sum(x * x for x in d))
        e = [x / D for x in d] if D > 0 else [mpmath.mpf(0), mpmath.mpf(0), mpmath.mpf(1)]
        V, Sz, Szz, Qt = dimer_moments_mp(R1, R2, D, "union", dps)
        zc = Sz / V
        Qzz = Szz - Sz * zc
        rho = mpmath.mpf(rho)
        mass = rho * V
        com = [a + zc * x for a, x in zip(c1, e)]
        # I = rho [(Qt + Qzz) 1 + (Qt - Qzz) e e^T]
        I = [[rho * ((Qt + Qzz) * (1 if i == j else 0) + (Qt - Qzz) * e[i] * e[j]) for j in range(3)] for i in range(3)]
        return float(mass), np.array([float(x) for x in com]), np.array([[float(x) for x in row] for row in I])
