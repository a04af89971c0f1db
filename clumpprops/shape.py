"""Exact shape descriptors of sphere clumps (unions of spheres): :func:`shape_descriptors`.

Every descriptor is exact for the union of the spheres, to round-off:

* the volume ``V`` and the surface area ``A`` come from the exact method's arrangement of caps
  in one pass of the compiled core (the area is the sum over spheres of ``r^2`` times the solid
  angle of the sphere's exposed region, which the volume needs anyway);
* the extents along the principal axes are max/min over the spheres of ``c.a +- r``;
* the smallest bounding sphere is the minimal enclosing ball of the balls (not of their
  centres), found by convex optimisation and polished on its support set (:func:`bounding_ball`).

Definitions (docs/shape.md): volume-equivalent diameter ``d_v = (6 V / pi)^(1/3)``; Wadell
sphericity ``psi = pi^(1/3) (6 V)^(2/3) / A`` (1 for a sphere, below 1 otherwise); reduced
moment of inertia ``kappa = 4 I / (m sigma^2)`` per principal moment ``I`` (2/5 for a sphere
with ``sigma = d_v``); Zingg elongation ``I/L`` and flatness ``S/I`` from the sorted extents
``L >= I >= S``.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
import numpy as np

from . import _input
from .api import _compiled


@dataclass(frozen=True, eq=False)
class ShapeDescriptors:
    """Exact shape descriptors of a clump, or of a batch (a leading axis M on every array).

    Parameters
    ----------
    volume : float or ndarray (M,)
        Volume of the union, m^3.
    surface_area : float or ndarray (M,)
        Surface area of the union, m^2.
    diameter : float or ndarray (M,)
        Volume-equivalent diameter ``d_v = (6 V / pi)^(1/3)``, m.
    sphericity : float or ndarray (M,)
        Wadell sphericity ``pi^(1/3) (6 V)^(2/3) / A``: the area of the sphere of equal volume over
        the area of the body; 1 for a sphere.
    kappa : ndarray (3,) or (M, 3)
        Reduced moments of inertia ``4 I_k / (m d_v^2)`` for the ascending principal moments ``I_k``;
        2/5 for a solid sphere.
    kappa_bounding : ndarray (3,) or (M, 3)
        ``4 I_k / (m (2 R_b)^2)`` with ``R_b`` the radius of the smallest bounding sphere (the
        contact diameter of rough-sphere kinetic theory).
    moment_ratios : ndarray (2,) or (M, 2)
        ``I_1 / I_3`` and ``I_2 / I_3`` (ascending principal moments); both 1 for a sphere.
    principal_axes : ndarray (3, 3) or (M, 3, 3)
        Columns are the principal axes, as :attr:`MassProperties.principal_axes`.
    extent_min, extent_max : ndarray (3,) or (M, 3)
        The least and largest coordinate of the union along each principal axis, measured from
        the centre of mass, m (``min / max`` over spheres of ``(c - com).a -+ r``).
    extents : ndarray (3,) or (M, 3)
        ``extent_max - extent_min``: the body's length along each principal axis, m.
    elongation : float or ndarray (M,)
        Zingg elongation ``I / L`` of the sorted extents ``L >= I >= S``.
    flatness : float or ndarray (M,)
        Zingg flatness ``S / I``.
    bounding_center : ndarray (3,) or (M, 3)
        Centre of the smallest sphere containing every member sphere, m.
    bounding_radius : float or ndarray (M,)
        Its radius, m.
    """

    volume: object
    surface_area: object
    diameter: object
    sphericity: object
    kappa: np.ndarray
    kappa_bounding: np.ndarray
    moment_ratios: np.ndarray
    principal_axes: np.ndarray
    extent_min: np.ndarray
    extent_max: np.ndarray
    extents: np.ndarray
    elongation: object
    flatness: object
    bounding_center: np.ndarray
    bounding_radius: object

    @property
    def batched(self) -> bool:
        """True where the descriptors hold a batch (a leading axis M)."""
        return np.ndim(self.volume) == 1

    def __len__(self):
        if not self.batched:
            raise TypeError("ShapeDescriptors of one clump has no len(); index a batch")
        return len(self.volume)

    def __getitem__(self, idx) -> "ShapeDescriptors":
        if not self.batched:
            raise TypeError("ShapeDescriptors of one clump cannot be indexed")
        return ShapeDescriptors(**{f.name: _item(getattr(self, f.name), idx) for f in fields(self)})

    def to_dict(self) -> dict:
        """The descriptors as plain Python numbers and lists (JSON-ready), SI units.

        Returns
        -------
        dict
            One entry per attribute.
        """
        return {f.name: np.asarray(getattr(self, f.name)).tolist() for f in fields(self)}


def _item(a, idx):
    v = np.asarray(a)[idx]
    return float(v) if np.ndim(v) == 0 else v


def shape_descriptors(centers, radii) -> ShapeDescriptors:
    """Exact shape descriptors of the union of spheres, for one clump or a batch.

    Parameters
    ----------
    centers : array_like, shape (N, 3), (M, N, 3), or a list of M arrays (N_m, 3)
        Sphere centres, m, as for :func:`clumpprops.mass_properties`.
    radii : array_like, shape (N,), (M, N), or a list of M arrays (N_m,)
        Sphere radii, m; all > 0.

    Returns
    -------
    ShapeDescriptors
        With a leading axis M for batch input.

    Raises
    ------
    ValueError
        For bad input, as :func:`clumpprops.mass_properties`.
    """
    mp, area = _compiled(centers, radii, 1.0, "exact", with_area=True)
    c, r, starts, N, M, batched = _input.flatten(centers, radii)
    if starts is None:
        starts = np.arange(M + 1) * N
    per = [_one_clump(c[starts[m]:starts[m + 1]], r[starts[m]:starts[m + 1]], mp[m] if batched else mp,
                      float(area[m])) for m in range(M)]
    stacked = {k: np.array([p[k] for p in per]) for k in per[0]}
    for a in stacked.values():
        a.flags.writeable = False
    if batched:
        return ShapeDescriptors(**stacked)
    return ShapeDescriptors(**{k: _item(v, 0) for k, v in stacked.items()})


def _one_clump(c, r, mp, area) -> dict:
    """The descriptors of one clump (c (N, 3), r (N,)) from its exact mass properties (density 1)."""
    V, I, axes = float(mp.volume), np.asarray(mp.principal_moments), np.asarray(mp.principal_axes)
    d_v = np.cbrt(6.0 * V / np.pi)
    proj = (c - np.asarray(mp.center_of_mass)) @ axes
    lo, hi = (proj - r[:, None]).min(axis=0), (proj + r[:, None]).max(axis=0)
    ext = hi - lo
    big, mid, small = np.sort(ext)[::-1]
    centre, R = bounding_ball(c, r)
    m = float(mp.mass)
    return {
        "volume": V, "surface_area": area, "diameter": d_v,
        "sphericity": np.cbrt(np.pi) * np.cbrt(6.0 * V) ** 2 / area,
        "kappa": 4.0 * I / (m * d_v**2), "kappa_bounding": 4.0 * I / (m * (2.0 * R) ** 2),
        "moment_ratios": I[:2] / I[2], "principal_axes": axes,
        "extent_min": lo, "extent_max": hi, "extents": ext,
        "elongation": mid / big, "flatness": small / mid,
        "bounding_center": centre, "bounding_radius": R,
    }


# ------------------------------------------------------------------ smallest enclosing ball of balls
def bounding_ball(centers, radii):
    """The smallest ball containing every ball ``(centers[i], radii[i])``.

    It minimises the convex function ``f(x) = max_i (|x - c_i| + r_i)``; its centre lies in
    the convex hull of the support balls (those touching it from inside: at most 4 in 3-D
    in general position). The minimum is found in two steps: the second-order cone program
    ``min t  s.t.  |x - c_i| <= t - r_i`` solved by SLSQP (scipy) in units of the clump, then
    Newton's method on the support set ``|x - c_i| + r_i = t``, ``x`` in the affine hull of the
    support centres, which converges quadratically to round-off. The radius returned is
    ``f(centre)``, so the ball contains every ball whatever the centre's last digits.

    Parameters
    ----------
    centers : array_like (N, 3)
        Ball centres, m.
    radii : array_like (N,)
        Ball radii, m; all >= 0.

    Returns
    -------
    centre : ndarray (3,)
        Centre of the smallest enclosing ball, m.
    radius : float
        Its radius, m.

    Raises
    ------
    ValueError
        For shapes other than (N, 3) and (N,), non-finite values or negative radii.
    """
    c, r = np.asarray(centers, dtype=float), np.asarray(radii, dtype=float)
    if c.ndim != 2 or c.shape[1] != 3 or r.shape != (len(c),) or not len(r):
        raise ValueError(f"bounding_ball needs centers (N, 3) and radii (N,), N >= 1; got {c.shape} and {r.shape}")
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(r)) and np.all(r >= 0)):
        raise ValueError("bounding_ball needs finite centres and finite radii >= 0")
    origin = 0.5 * ((c - r[:, None]).min(axis=0) + (c + r[:, None]).max(axis=0))
    unit = max(float(np.max(np.linalg.norm(c - origin, axis=1) + r)), np.finfo(float).tiny)
    cu, ru = (c - origin) / unit, r / unit  # the clump in units of its size, about the box centre
    x = _cone_program(cu, ru)
    x = _polish_on_support(cu, ru, x)
    centre = origin + unit * x
    return centre, float(np.max(np.linalg.norm(c - centre, axis=1) + r))


def _reach(c, r, x):
    return np.linalg.norm(c - x, axis=1) + r


def _cone_program(c, r):
    """Centre minimising max(|x - c_i| + r_i): SLSQP on t with (t - r_i)^2 >= |x - c_i|^2, t >= r_i."""
    if len(r) == 1:
        return c[0].copy()
    from scipy.optimize import minimize

    x0 = np.zeros(3)
    z0 = np.append(x0, _reach(c, r, x0).max())
    cons = [{"type": "ineq",
             "fun": lambda z: (z[3] - r) ** 2 - ((c - z[:3]) ** 2).sum(axis=1),
             "jac": lambda z: np.column_stack([2.0 * (c - z[:3]), 2.0 * (z[3] - r)])},
            {"type": "ineq", "fun": lambda z: z[3] - r,
             "jac": lambda z: np.column_stack([np.zeros((len(r), 3)), np.ones(len(r))])}]
    res = minimize(lambda z: z[3], z0, jac=lambda z: np.array([0.0, 0.0, 0.0, 1.0]), constraints=cons,
                   method="SLSQP", options={"ftol": 1e-14, "maxiter": 500})
    x = res.x[:3] if np.all(np.isfinite(res.x)) else x0
    return x if _reach(c, r, x).max() <= _reach(c, r, x0).max() else x0


def _polish_on_support(c, r, x, tol=1e-6):
    """Newton on the support set: |x - c_i| + r_i = t for the balls within tol of the farthest, x in their hull."""
    f = _reach(c, r, x)
    support = np.flatnonzero(f >= f.max() - tol)
    cs, rs = c[support], r[support]
    base = cs[0]
    u, s, vt = np.linalg.svd(cs[1:] - base) if len(support) > 1 else (None, np.zeros(0), np.zeros((0, 3)))
    B = vt[: int(np.sum(s > 1e-9))].T  # (3, k): the affine hull of the support centres
    y = B.T @ (x - base)
    t = float(f.max())
    best = x
    for _ in range(50):
        p = base + B @ y
        d = p - cs
        dist = np.linalg.norm(d, axis=1)
        if np.any(dist == 0.0):
            break
        resid = dist + rs - t
        J = np.column_stack([(d / dist[:, None]) @ B, -np.ones(len(rs))])
        step = np.linalg.lstsq(J, -resid, rcond=None)[0]
        y, t = y + step[:-1], t + step[-1]
        if np.max(np.abs(step)) < 1e-15:
            break
    cand = base + B @ y
    if np.all(np.isfinite(cand)) and _reach(c, r, cand).max() <= _reach(c, r, best).max():
        return cand
    return best
