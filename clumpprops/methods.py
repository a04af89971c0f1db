"""Typed method options for :func:`clumpprops.mass_properties`.

``method=`` takes a name (``"exact"``, ``"pairwise"``, ``"sum"``, ``"montecarlo"``,
``"voxel"``, with options as keywords) or one of these immutable objects, which carry
their options and are checked when they are made::

    mass_properties(c, r, method=MonteCarlo(n_samples=10**5, seed=1))
    mass_properties(c, r, method="montecarlo", n_samples=10**5, seed=1)   # the same
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Optional


@dataclass(frozen=True)
class Exact:
    """The union of the spheres, any overlap pattern (the compiled exact core)."""

    name = "exact"

    def options(self) -> dict:
        return {}


@dataclass(frozen=True)
class Pairwise:
    """The paper's eqs. (1)-(7); ClumpGeometryError where three spheres share a region."""

    name = "pairwise"

    def options(self) -> dict:
        return {}


@dataclass(frozen=True)
class Sum:
    """Overlaps counted twice (YADE appendClumped, LAMMPS fix rigid)."""

    name = "sum"

    def options(self) -> dict:
        return {}


@dataclass(frozen=True)
class MonteCarlo:
    """Uniform samples in each clump's bounding box; sets ``standard_error``."""

    n_samples: int = 1_000_000
    seed: Optional[int] = None
    name = "montecarlo"

    def __post_init__(self):
        if isinstance(self.n_samples, bool) or int(self.n_samples) != self.n_samples or self.n_samples < 100:
            raise ValueError(f"n_samples must be an integer >= 100, got {self.n_samples!r}")

    def options(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Voxel:
    """YADE 2023.02a's regular-grid scheme (``O.bodies.clump(ids, discretization)``)."""

    discretization: int = 10
    name = "voxel"

    def __post_init__(self):
        d = self.discretization
        if isinstance(d, bool) or int(d) != d or d < 1:
            raise ValueError(f"discretization must be an integer >= 1, got {d!r}")

    def options(self) -> dict:
        return asdict(self)


BY_NAME = {"exact": Exact, "pairwise": Pairwise, "sum": Sum, "montecarlo": MonteCarlo, "voxel": Voxel}
