"""VTK: each clump's spheres, centre of mass and principal axes, for ParaView.

One VTK XML unstructured-grid file per clump, ``NAME.vtu``, in metres, in the input frame,
written by ``meshio`` (``pip install clumpprops[mesh]``).  Its points are, in order:

* the N sphere centres, as ``vertex`` cells, with the point arrays ``radius`` and ``diameter``
  (ParaView: Glyph filter, glyph type Sphere, scale array ``diameter``, scale factor 1);
* the centre of mass, a ``vertex`` cell;
* two end points per principal axis, joined by a ``line`` cell from the union's least to its
  largest coordinate along that axis (:func:`clumpprops.mesh.principal_extents`).

``radius`` and ``diameter`` are 0 on the last 7 points; the point array ``kind`` is 0 for a
sphere, 1 for the centre of mass, 2 for an axis end.  The cell arrays are ``axis`` (0, 1, 2
for the axes' lines in ascending order of the principal moment, -1 for the vertex cells) and
``principal_moment`` (kg m^2; 0 for the vertex cells).
"""
from __future__ import annotations

from pathlib import Path
from typing import List, Sequence

import numpy as np

from ._common import Clump, Props
from .stl import _meshio
from ..mesh import principal_extents

ENGINE = "VTK (ParaView)"


def clump_mesh(clump: Clump, com, moments, axes):
    """The ``meshio.Mesh`` of one clump: spheres, centre of mass and principal axes.

    Parameters
    ----------
    clump : Clump
        The clump's spheres, m.
    com : array_like, shape (3,)
        Its centre of mass, m.
    moments : array_like, shape (3,)
        Its ascending principal moments, kg m^2.
    axes : array_like, shape (3, 3)
        Its principal axes (columns).

    Returns
    -------
    meshio.Mesh
        The points, cells and data the module's docstring lists.
    """
    meshio = _meshio()
    n = len(clump.radii)
    com, axes = np.asarray(com, dtype=np.float64), np.asarray(axes, dtype=np.float64)
    lo, hi = principal_extents(clump.centers, clump.radii, com, axes)
    ends = np.array([[com + lo[k] * axes[:, k], com + hi[k] * axes[:, k]] for k in range(3)]).reshape(6, 3)
    points = np.vstack([clump.centers, com[None], ends])
    radius = np.concatenate([clump.radii, np.zeros(7)])
    kind = np.concatenate([np.zeros(n, int), [1], np.full(6, 2)])
    cells = [("vertex", np.arange(n + 1)[:, None]), ("line", n + 1 + np.arange(6).reshape(3, 2))]
    cell_data = {"axis": [np.full(n + 1, -1), np.arange(3)],
                 "principal_moment": [np.zeros(n + 1), np.asarray(moments, dtype=np.float64)]}
    return meshio.Mesh(points, cells, point_data={"radius": radius, "diameter": 2.0 * radius, "kind": kind},
                       cell_data=cell_data)


def write(clumps: Sequence[Clump], mp, out_dir, density: float, method: str, source: str = "", scale: float = 1.0,
          stem: str = None) -> List[Path]:
    """Write ``NAME.vtu`` per clump (see the module's docstring for its content).

    Parameters
    ----------
    clumps : sequence of Clump
        The clumps, m.
    mp : clumpprops.MassProperties
        Their mass properties (a batch).
    out_dir : str or os.PathLike
        The folder the files go to.
    density : float
        Density, kg/m^3, that `mp` was computed with.
    method : str
        The method `mp` was computed with (not stored).
    source, scale, stem : optional
        Unused: one file per clump, named after the clump.

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    ImportError
        If ``meshio`` is missing.
    """
    meshio = _meshio()
    out_dir = Path(out_dir)
    P = Props(mp)
    written = []
    for k, c in enumerate(clumps):
        path = out_dir / f"{c.name}.vtu"
        meshio.write(path, clump_mesh(c, P.com[k], P.moments[k], P.axes[k]))
        written.append(path)
    return written
