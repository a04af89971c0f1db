"""STL: a watertight triangulation of each clump's union surface, for viewers and CAD.

One binary STL file per clump, ``NAME.stl``, in metres (STL itself carries no unit), in the
input frame.  The surface is :func:`clumpprops.mesh.union_mesh`'s boolean union of sphere
polyhedra (``manifold3d``), within the relative `tolerance` of the exact volume and area (the
rule is in :mod:`clumpprops.mesh`); the file is written by ``meshio``.  Both are optional
dependencies: ``pip install clumpprops[mesh]``.
"""
from __future__ import annotations

from pathlib import Path
from typing import List, Sequence

from ._common import Clump
from ..mesh import DEFAULT_TOLERANCE, union_mesh

ENGINE = "STL (union surface)"


def _meshio():
    """The ``meshio`` module, or an ImportError naming the extra that installs it."""
    try:
        import meshio
    except ImportError:
        raise ImportError("STL and VTK export need meshio: pip install clumpprops[mesh]") from None
    return meshio


def write(clumps: Sequence[Clump], mp, out_dir, density: float, method: str, source: str = "", scale: float = 1.0,
          stem: str = None, tolerance: float = DEFAULT_TOLERANCE) -> List[Path]:
    """Write ``NAME.stl`` per clump: the union surface within `tolerance` of the exact volume.

    Parameters
    ----------
    clumps : sequence of Clump
        The clumps, in metres.
    mp : clumpprops.MassProperties
        Their mass properties (unused: the mesh is checked against the exact volume and area).
    out_dir : str or os.PathLike
        The folder the files go to.
    density : float
        Unused (STL holds geometry only); kept for the common writer signature.
    method : str
        Unused; the surface is the union's whatever the method.
    source, scale, stem : optional
        Unused; an STL file has no room for a header the readers keep.
    tolerance : float, optional
        Relative tolerance on the mesh's volume and area.

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    ImportError
        If ``manifold3d`` or ``meshio`` is missing.
    """
    meshio = _meshio()
    out_dir = Path(out_dir)
    written = []
    for c in clumps:
        m = union_mesh(c.centers, c.radii, tolerance)
        path = out_dir / f"{c.name}.stl"
        meshio.write(path, meshio.Mesh(m.vertices, [("triangle", m.faces)]), file_format="stl", binary=True)
        written.append(path)
    return written
