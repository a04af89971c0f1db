"""A watertight triangulation of the union of a clump's spheres: :func:`union_mesh`.

The union is a boolean union of sphere polyhedra, computed by ``manifold3d`` (the Manifold
library: exact, robust booleans whose output is always a closed 2-manifold), so the mesh is
one surface with no internal faces or overlapping sphere shells.

Tolerance rule
--------------
Each sphere is Manifold's geodesic sphere with ``n`` segments around, scaled so that its
volume equals the sphere's.  ``n`` starts at the smallest multiple of 4 for which the scaled
polyhedron's relative area error is at most `tolerance` (its volume error is zero by
construction); :func:`union_mesh` then measures the union mesh's volume and area against the
exact ones (:func:`clumpprops.shape_descriptors`' volume and surface area, from the same pass
of the compiled core) and raises ``n`` by a quarter until both relative errors are at most
`tolerance`.  The returned mesh therefore meets the tolerance on volume and area by
measurement, not by an estimate.

``manifold3d`` is an optional dependency (``pip install clumpprops[mesh]``); the library
imports without it.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

__all__ = ["UnionMesh", "union_mesh", "segments_for"]

#: Default relative tolerance on the mesh's volume and area.
DEFAULT_TOLERANCE = 1e-3
_MAX_SEGMENTS = 1024


def _manifold():
    """The ``manifold3d`` module, or an ImportError naming the extra that installs it."""
    try:
        import manifold3d
    except ImportError:
        raise ImportError("the union mesh needs manifold3d: pip install clumpprops[mesh]") from None
    return manifold3d


@dataclass(frozen=True, eq=False)
class UnionMesh:
    """A closed triangle mesh of the union of a clump's spheres.

    Attributes
    ----------
    vertices : ndarray (V, 3)
        Vertex positions, in the clump's input frame and units.
    faces : ndarray (F, 3) of int
        Vertex indices of each triangle, counter-clockwise seen from outside.
    volume : float
        The mesh's enclosed volume.
    area : float
        The mesh's surface area.
    segments : int
        The number of segments around each sphere polyhedron.
    tolerance : float
        The relative tolerance the mesh was made for.
    """

    vertices: np.ndarray
    faces: np.ndarray
    volume: float
    area: float
    segments: int
    tolerance: float


@lru_cache(maxsize=64)
def _unit_sphere(segments: int):
    """Manifold's unit geodesic sphere with `segments` segments: (radius factor, relative area error).

    The radius factor scales the polyhedron to the unit sphere's volume; the area error is the
    scaled polyhedron's area over 4 pi, minus 1.
    """
    s = _manifold().Manifold.sphere(1.0, segments)
    k = np.cbrt(4.0 / 3.0 * np.pi / s.volume())
    return float(k), float(s.surface_area() * k * k / (4.0 * np.pi) - 1.0)


def segments_for(tolerance: float) -> int:
    """The fewest segments (a multiple of 4) whose volume-matched sphere has area error <= `tolerance`.

    Parameters
    ----------
    tolerance : float
        Relative tolerance, > 0.

    Returns
    -------
    int
        The number of segments around each sphere.

    Raises
    ------
    ValueError
        If `tolerance` is not positive and finite, or needs more than 1024 segments.
    """
    if not (np.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"tolerance must be positive and finite, got {tolerance}")
    n = max(8, 4 * int(np.ceil(np.sqrt(2.9 / tolerance) / 4)))  # area error ~ 2.9 / n^2
    while abs(_unit_sphere(n)[1]) > tolerance:
        n += 4
        if n > _MAX_SEGMENTS:
            raise ValueError(f"tolerance {tolerance} needs more than {_MAX_SEGMENTS} segments per sphere")
    while n > 8 and abs(_unit_sphere(n - 4)[1]) <= tolerance:
        n -= 4
    return n


def _union(centers, radii, segments):
    """The Manifold union of the volume-matched sphere polyhedra."""
    m3 = _manifold()
    k = _unit_sphere(segments)[0]
    parts = [m3.Manifold.sphere(float(r) * k, segments).translate(tuple(map(float, c)))
             for c, r in zip(centers, radii)]
    return m3.Manifold.batch_boolean(parts, m3.OpType.Add)


def union_mesh(centers, radii, tolerance: float = DEFAULT_TOLERANCE) -> UnionMesh:
    """A watertight triangulation of the union of spheres, within `tolerance` of its exact volume and area.

    Parameters
    ----------
    centers : array_like, shape (N, 3)
        Sphere centres.
    radii : array_like, shape (N,)
        Sphere radii, all > 0.
    tolerance : float, optional
        Relative tolerance on the mesh's volume and area (see the module's tolerance rule).

    Returns
    -------
    UnionMesh
        Vertices and faces of the closed mesh, with its volume, area and resolution.  If even
        1024 segments miss the tolerance (spheres of very different sizes), the mesh at 1024.

    Raises
    ------
    ValueError
        For bad spheres (as :func:`clumpprops.mass_properties`) or a bad `tolerance`.
    ImportError
        If ``manifold3d`` is not installed (``pip install clumpprops[mesh]``).
    """
    from .api import _compiled

    c = np.asarray(centers, dtype=np.float64).reshape(-1, 3)
    r = np.asarray(radii, dtype=np.float64).reshape(-1)
    mp, area = _compiled(c, r, 1.0, "exact", with_area=True)
    exact_volume, exact_area = float(mp.volume), float(area[0])
    n = segments_for(tolerance)
    while True:
        u = _union(c, r, n)
        error = max(abs(u.volume() / exact_volume - 1.0), abs(u.surface_area() / exact_area - 1.0))
        if error <= tolerance or n >= _MAX_SEGMENTS:
            break
        n = min(4 * int(np.ceil(1.25 * n / 4)), _MAX_SEGMENTS)
    mesh = u.to_mesh64() if hasattr(u, "to_mesh64") else u.to_mesh()
    vertices = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3].copy()
    faces = np.asarray(mesh.tri_verts, dtype=np.int64).copy()
    return UnionMesh(vertices, faces, float(u.volume()), float(u.surface_area()), n, float(tolerance))


def principal_extents(centers, radii, center_of_mass, principal_axes):
    """The union's least and largest coordinate along each principal axis, from the centre of mass.

    Parameters
    ----------
    centers : array_like, shape (N, 3)
        Sphere centres.
    radii : array_like, shape (N,)
        Sphere radii.
    center_of_mass : array_like, shape (3,)
        The clump's centre of mass.
    principal_axes : array_like, shape (3, 3)
        Columns are the principal axes (unit vectors).

    Returns
    -------
    lo, hi : ndarray (3,)
        ``min`` and ``max`` over the spheres of ``(c - com) . a_k -+ r`` for each axis ``a_k``;
        ``lo < 0 < hi`` whenever the centre of mass lies inside the union.
    """
    c = np.asarray(centers, dtype=np.float64).reshape(-1, 3)
    r = np.asarray(radii, dtype=np.float64).reshape(-1)
    proj = (c - np.asarray(center_of_mass, dtype=np.float64)) @ np.asarray(principal_axes, dtype=np.float64)
    return (proj - r[:, None]).min(axis=0), (proj + r[:, None]).max(axis=0)
