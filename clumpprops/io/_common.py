"""Shared pieces of the engine exporters and importers: the batch computation, number text, headers.

The clump record and the file error are :mod:`clumpprops._clumps`' (re-exported here).

Everything is SI: lengths in m, density in kg/m^3, mass in kg, inertia in kg m^2.
Numbers are written with ``repr`` (17 significant digits), so a float64 survives the
round trip through any of the text formats exactly.
"""
from __future__ import annotations

from typing import List, Sequence

import numpy as np

from .. import __version__, mass_properties
from .._clumps import Clump, ClumpFileError

__all__ = ["Clump", "ClumpFileError", "compute", "header_lines", "fnum", "fmt_rows"]


def fnum(x) -> str:
    """Shortest text that reads back as the same float64 (``repr``), never ``-0.0``."""
    x = float(x)
    return repr(x + 0.0) if x != 0 else "0.0"


def fmt_rows(a, sep: str = " ") -> List[str]:
    """Each row of a 2-D array as text, numbers as :func:`fnum` writes them (vectorised)."""
    a = np.asarray(a, dtype=np.float64) + 0.0  # -0.0 -> 0.0
    return [sep.join(map(repr, row)) for row in a.tolist()]


def compute(clumps: Sequence[Clump], density: float, method: str = "exact"):
    """Mass properties of the clumps, in one batch call of :func:`clumpprops.mass_properties`.

    Parameters
    ----------
    clumps : sequence of Clump
        The clumps; at least one.
    density : float
        Density of the clump material, kg/m^3.
    method : str, optional
        The method of :func:`clumpprops.mass_properties` by name; ``"exact"`` (the exact union
        of the spheres) by default.

    Returns
    -------
    clumpprops.MassProperties
        The batch: mass in kg, volume in m^3, centre of mass in m, inertia in kg m^2, one
        entry per clump.

    Raises
    ------
    ValueError
        If `clumps` is empty, or for what :func:`clumpprops.mass_properties` refuses.
    """
    if not clumps:
        raise ValueError("no clumps to export")
    return mass_properties([c.centers for c in clumps], [c.radii for c in clumps], density=density, method=method)


def header_lines(engine: str, density: float, method: str, source: str = "", scale: float = 1.0,
                 extra: Sequence[str] = ()) -> List[str]:
    """Comment lines (without the comment character) every exported file starts with."""
    out = [
        f"written by clumpprops {__version__} for {engine}",
        "units: SI (lengths m, mass kg, inertia kg m^2, density kg/m^3)",
        f"density {fnum(density)} kg/m^3, method {method}"
        + (" (exact union of the spheres)" if method == "exact" else ""),
    ]
    if source:
        out.append(f"source: {source}" + (f", scale {fnum(scale)}" if scale != 1.0 else ""))
    out.extend(extra)
    return out


class Props:
    """Plain per-clump arrays of a MassProperties (one clump or a batch): indexing a
    MassProperties per clump costs ~50 us, these arrays cost nothing."""

    def __init__(self, mp):
        batch = np.ndim(mp.mass) == 1
        lead = (lambda a: np.asarray(a)) if batch else (lambda a: np.asarray(a)[None])
        self.mass = lead(mp.mass)
        self.volume = lead(mp.volume)
        self.com = lead(mp.center_of_mass)
        self.inertia = lead(mp.inertia)
        self.moments = lead(mp.principal_moments)
        self.axes = lead(mp.principal_axes)


def principal_frame(centers, com, axes) -> np.ndarray:
    """Sphere centres in the principal frame: x_p = A^T (x - com), A = principal axes (columns)."""
    return (np.asarray(centers) - com) @ axes
