"""clumpprops: exact mass properties of sphere clumps for DEM (multisphere) simulations.

Implements Parteli's analytic overlap correction (the paper's eqs. 1-7,
``method="pairwise"``), an exact method for unions of spheres with any overlap
pattern (``method="exact"``, the default), and the baselines DEM codes use
(``"sum"``, ``"montecarlo"``, ``"voxel"``).  Geometry only: nothing here imports
YADE; the YADE adapter is :mod:`clumpprops.yade`, imported on demand.

>>> import clumpprops
>>> d = 0.1333
>>> mp = clumpprops.mass_properties([[0, 0, -d/4], [0, 0, d/4]], [d/2, d/2], density=1140)
>>> round(mp.mass, 6)
2.38582
"""
from ._properties import MassProperties, StandardError, concatenate
from .api import DEFAULT_METHOD, METHODS, mass_properties
from .methods import Exact, MonteCarlo, Pairwise, Sum, Voxel
from .pairwise import ClumpGeometryError
from .shape import ShapeDescriptors, bounding_ball, shape_descriptors

__version__ = "0.1.0"

__all__ = [
    "mass_properties",
    "MassProperties",
    "shape_descriptors",
    "ShapeDescriptors",
    "bounding_ball",
    "StandardError",
    "concatenate",
    "Exact",
    "Pairwise",
    "Sum",
    "MonteCarlo",
    "Voxel",
    "ClumpGeometryError",
    "METHODS",
    "DEFAULT_METHOD",
    "__version__",
]
