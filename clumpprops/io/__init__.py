"""Exporters and importers: exact sphere clumps for DEM engines (LIGGGHTS, LAMMPS, DEME, MercuryDPM, YADE).

>>> from clumpprops import io as cio
>>> clumps = cio.read("dimer.csv")                      # format from the extension, or fmt="csv"
>>> paths = cio.export(clumps, to="liggghts", out_dir="out", density=1140.0)

One module per engine (:mod:`.liggghts`, :mod:`.lammps`, :mod:`.deme`, :mod:`.mclump`,
:mod:`.yade`), each with ``write(clumps, mp, out_dir, density, method, ...)``; the readers
are in :mod:`.readers`.  Values come from ``clumpprops.mass_properties`` (exact method by
default), in SI units, written with 17 significant digits.  The command line is
``clumpprops export FILE --to ENGINE`` (:mod:`.cli`; docs/engines.md).
"""
from __future__ import annotations

from typing import Callable, List, Optional, Sequence

from ._common import Clump, ClumpFileError, compute
from .readers import FORMATS, detect_format, read

ENGINES = ("liggghts", "lammps", "deme", "mclump", "yade")

__all__ = ["Clump", "ClumpFileError", "ENGINES", "FORMATS", "compute", "detect_format", "export", "read"]


def _module(to: str):
    if to not in ENGINES:
        raise ValueError(f"unknown engine {to!r}; choose one of {', '.join(ENGINES)}")
    from importlib import import_module

    return import_module(f".{to}", __name__)


def export(clumps: Sequence[Clump], to: str, out_dir=".", density: float = 1000.0, method: str = "exact",
           source: str = "", scale: float = 1.0, stem: Optional[str] = None, mp=None,
           warn: Optional[Callable[[str], None]] = None, templates: bool = True) -> List:
    """Write the files engine ``to`` reads for ``clumps`` into ``out_dir``; returns the paths.

    ``mp``: precomputed ``mass_properties`` of the clumps (batch), else computed here with
    ``method`` and ``density``.  ``warn`` receives warnings (DEME float32 precision).
    ``templates=False`` skips the per-clump template files of LAMMPS (``.mol``) and DEME
    (``.csv``; the JSON still holds every clump's spheres): for large batches, where one
    file per clump costs more than everything else.
    """
    mod = _module(to)
    clumps = list(clumps)
    if mp is None:
        mp = compute(clumps, density, method)
    kw = {"warn": warn} if to == "deme" else {}
    if not templates:
        if to not in ("lammps", "deme"):
            raise ValueError(f"templates=False applies to lammps and deme; {to} needs its per-clump files")
        kw["templates"] = False
    return mod.write(clumps, mp, out_dir, density, method, source=source, scale=scale, stem=stem, **kw)
