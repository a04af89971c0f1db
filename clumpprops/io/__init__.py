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

import os
import shutil
import tempfile
from pathlib import Path
from typing import Callable, List, Optional, Sequence

from ._common import Clump, ClumpFileError, compute
from .readers import FORMATS, detect_format, read

ENGINES = ("liggghts", "lammps", "deme", "mclump", "yade")

__all__ = ["Clump", "ClumpFileError", "ENGINES", "ExportRefused", "FORMATS", "compute", "detect_format", "export",
           "read"]


def _module(to: str):
    if to not in ENGINES:
        raise ValueError(f"unknown engine {to!r}; choose one of {', '.join(ENGINES)}")
    from importlib import import_module

    return import_module(f".{to}", __name__)


class ExportRefused(ClumpFileError):
    """An export that would write over its input, or over an existing file without ``force``."""


def export(clumps: Sequence[Clump], to: str, out_dir=".", density: float = 1000.0, method: str = "exact",
           source: str = "", scale: float = 1.0, stem: Optional[str] = None, mp=None,
           warn: Optional[Callable[[str], None]] = None, templates: bool = True, force: bool = False) -> List:
    """Write the files engine ``to`` reads for ``clumps`` into ``out_dir``; returns the paths.

    Nothing is written over the input file ``source``, nor over an existing file unless ``force``:
    the files are written to a staging folder first and moved into ``out_dir`` only when none
    would replace the input or (without ``force``) another file; else :class:`ExportRefused`
    names the file and nothing is written.

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
    out = Path(out_dir)
    made_out = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".clumpprops-export-", dir=out))
    try:
        staged = mod.write(clumps, mp, stage, density, method, source=source, scale=scale, stem=stem, **kw)
        targets = [out / Path(p).relative_to(stage) for p in staged]
        _refuse_overwrites(targets, source, force)
        for p, t in zip(staged, targets):
            t.parent.mkdir(parents=True, exist_ok=True)
            os.replace(p, t)
    except BaseException:
        if made_out:
            shutil.rmtree(stage, ignore_errors=True)
            try:
                out.rmdir()
            except OSError:
                pass
        raise
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return targets


def _refuse_overwrites(targets, source, force):
    """Raise :class:`ExportRefused` for the first target that is the input file (always) or that
    exists (unless ``force``)."""
    src = os.path.realpath(source) if source else None
    for t in targets:
        if src and os.path.realpath(t) == src:
            raise ExportRefused("is the input file, which an export never writes over; nothing written: choose "
                                "another --out folder or --name", str(t))
    if not force:
        for t in targets:
            if t.exists():
                raise ExportRefused("exists; nothing written (--force replaces existing output files)", str(t))
