"""Typed method options for :func:`clumpprops.mass_properties`.

``method=`` takes a name (``"exact"``, ``"pairwise"``, ``"sum"``, ``"montecarlo"``,
``"voxel"``, with options as keywords) or one of these immutable objects, which carry
their options and are checked when they are made::

    mass_properties(c, r, method=MonteCarlo(n_samples=10**5, seed=1))
    mass_properties(c, r, method="montecarlo", n_samples=10**5, seed=1)   # the same
"""
from __future__ import annotations

import numbers
from dataclasses import asdict, dataclass
from typing import Optional

# stated limits of the baselines, beyond which they refuse (ValueError) rather than run for
# hours or exhaust memory: Monte Carlo samples per clump, and the voxel grid (its edge count
# along the smallest extent, and its cells per clump)
MAX_SAMPLES = 10**9
MAX_DISCRETIZATION = 1000
MAX_VOXEL_CELLS = 10**9


def check_count(value, name, lo, hi) -> int:
    """value as an int in [lo, hi], or ValueError naming the problem (booleans, strings and
    non-integral numbers included)."""
    ok_type = isinstance(value, numbers.Integral) or (isinstance(value, numbers.Real) and float(value).is_integer())
    if isinstance(value, bool) or not ok_type:
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")
    v = int(value)
    if v < lo:
        raise ValueError(f"{name} must be >= {lo}, got {value!r}")
    if v > hi:
        raise ValueError(f"{name} is too large: at most {hi:g} (a stated limit of time and memory), got {value!r}")
    return v


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
    """Uniform samples in each clump's bounding box; sets ``standard_error``.

    ``n_samples`` per clump, 100 to ``MAX_SAMPLES`` (10^9)."""

    n_samples: int = 1_000_000
    seed: Optional[int] = None
    name = "montecarlo"

    def __post_init__(self):
        check_count(self.n_samples, "n_samples", 100, MAX_SAMPLES)

    def options(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Voxel:
    """YADE 2023.02a's regular-grid scheme (``O.bodies.clump(ids, discretization)``).

    ``discretization`` 1 to ``MAX_DISCRETIZATION`` (1000) cells along the smallest extent;
    a grid beyond ``MAX_VOXEL_CELLS`` (10^9) cells per clump is refused too."""

    discretization: int = 10
    name = "voxel"

    def __post_init__(self):
        check_count(self.discretization, "discretization", 1, MAX_DISCRETIZATION)

    def options(self) -> dict:
        return asdict(self)


BY_NAME = {"exact": Exact, "pairwise": Pairwise, "sum": Sum, "montecarlo": MonteCarlo, "voxel": Voxel}
