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
    """An integer option checked against its stated range.

    Parameters
    ----------
    value : int or float
        The value given; a float must be integral (``1e6`` is accepted).
    name : str
        The option's name, for the error message.
    lo, hi : int
        The accepted range, both ends included.

    Returns
    -------
    int
        ``value`` as an int.

    Raises
    ------
    ValueError
        If ``value`` is a bool, not a real number (strings included), not integral, or outside
        [lo, hi]; the message names the problem.
    """
    ok_type = isinstance(value, numbers.Integral) or (isinstance(value, numbers.Real) and float(value).is_integer())
    if isinstance(value, bool) or not ok_type:
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")
    v = int(value)
    if v < lo:
        raise ValueError(f"{name} must be >= {lo}, got {value!r}")
    if v > hi:
        raise ValueError(f"{name} is too large: at most {hi:g} (a stated limit of time and memory), got {value!r}")
    return v


class _NoOptions:
    """A method that takes no options (the base of :class:`Exact`, :class:`Pairwise`, :class:`Sum`)."""

    def options(self) -> dict:
        """The method's keyword options for :func:`clumpprops.mass_properties`.

        Returns
        -------
        dict
            Empty: this method takes no options.
        """
        return {}


@dataclass(frozen=True)
class Exact(_NoOptions):
    """The exact method: the union of the spheres, any overlap pattern.

    Computed by the compiled exact core (docs/exact_method.md); round-off accurate.  The same as
    ``method="exact"``, the default.
    """

    name = "exact"


@dataclass(frozen=True)
class Pairwise(_NoOptions):
    """The pairwise overlap correction of the paper (its equations 1-7).

    The same as ``method="pairwise"``.  Exact where no point lies in three spheres;
    :func:`clumpprops.mass_properties` raises :class:`~clumpprops.ClumpGeometryError` where
    three spheres share a region.
    """

    name = "pairwise"


@dataclass(frozen=True)
class Sum(_NoOptions):
    """The summed spheres, overlaps counted twice.

    The same as ``method="sum"``: what YADE's ``appendClumped`` (discretization 0) and LAMMPS'
    ``fix rigid`` compute.
    """

    name = "sum"


@dataclass(frozen=True)
class MonteCarlo:
    """Monte Carlo estimate: uniform samples in each clump's bounding box.

    The same as ``method="montecarlo"`` with these options.  The result has a
    :class:`~clumpprops.StandardError`.

    Parameters
    ----------
    n_samples : int, optional
        Samples per clump, 100 to ``MAX_SAMPLES`` (10^9).
    seed : int or None, optional
        Seed of numpy's random generator; None draws fresh entropy.

    Raises
    ------
    ValueError
        If ``n_samples`` is not an integer in [100, 10^9].
    """

    n_samples: int = 1_000_000
    seed: Optional[int] = None
    name = "montecarlo"

    def __post_init__(self):
        check_count(self.n_samples, "n_samples", 100, MAX_SAMPLES)

    def options(self) -> dict:
        """The method's keyword options for :func:`clumpprops.mass_properties`.

        Returns
        -------
        dict
            The fields of this object by name.
        """
        return asdict(self)


@dataclass(frozen=True)
class Voxel:
    """YADE 2023.02a's regular-grid scheme (``O.bodies.clump(ids, discretization)``).

    The same as ``method="voxel"`` with this option.

    Parameters
    ----------
    discretization : int, optional
        Cells along the smallest extent of the clump's bounding box, 1 to
        ``MAX_DISCRETIZATION`` (1000).

    Raises
    ------
    ValueError
        If ``discretization`` is not an integer in [1, 1000].  A grid of more than
        ``MAX_VOXEL_CELLS`` (10^9) cells for one clump is refused with a ValueError when the
        properties are computed.
    """

    discretization: int = 10
    name = "voxel"

    def __post_init__(self):
        check_count(self.discretization, "discretization", 1, MAX_DISCRETIZATION)

    def options(self) -> dict:
        """The method's keyword options for :func:`clumpprops.mass_properties`.

        Returns
        -------
        dict
            The fields of this object by name.
        """
        return asdict(self)


BY_NAME = {"exact": Exact, "pairwise": Pairwise, "sum": Sum, "montecarlo": MonteCarlo, "voxel": Voxel}
