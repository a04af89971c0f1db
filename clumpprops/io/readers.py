"""Importers: sphere clumps from the files DEM engines and clump tools use.

:func:`read` detects the format by content (:mod:`clumpprops.io.detect`, whose table lists
what each format looks like), or takes it as ``fmt``:

=====================  ==========================================================
format                 reader
=====================  ==========================================================
``csv``                :func:`read_csv`: ``x,y,z,r`` lines, optional header row
``liggghts``           :func:`read_liggghts`: ``x y z r [type]`` lines
``mclump``             :func:`read_mclump`: ``Clump.txt``, the clump folder, ``clumpprops.txt``
``yade``               :func:`read_yade`: textClumps ``x y z r clumpId``
``lammps``             :func:`clumpprops.io.molecule.read_lammps`: molecule file
``liggghts-script``    :func:`clumpprops.io.liggghts_script.read_liggghts_script`
``deme``               :func:`clumpprops.io.readback.read_deme`: ``*_deme.json``
=====================  ==========================================================

Every reader checks each number (a word that is not a number, NaN/inf, a radius <= 0,
the wrong number of columns) and raises :class:`ClumpFileError` naming the file and
line; a file without spheres is an error too.  Numbers are ASCII only (``1_0`` and
non-ASCII digits are not numbers: :mod:`clumpprops._numtext`); a UTF-8 byte order mark at the start
of a file is skipped.  In a ``.mol`` file each atom id appears once per section, every
``Diameters`` and ``Masses`` entry is a number > 0 for an atom of ``Coords``.  ``scale``
multiplies coordinates and radii (0.001 for files in mm).

Speed: each reader parses all its data lines at once with numpy's C reader, which uses
the same number grammar; only if numpy refuses a line, or a value is not finite or not
positive where it must be, the line-by-line validator (``_csv_rows`` in :mod:`clumpprops.io.tables`,
``_mol_rows`` in :mod:`clumpprops.io.molecule`, ...) reads the file again to raise the first error with its line.  A file of 10**6 spheres
reads in seconds, in memory a few times the file's size (benchmarks/bench_io.py
--read-lines).
"""
from __future__ import annotations

import math
import os
from typing import List, Optional

from ._common import Clump, ClumpFileError
from .detect import FORMATS, detect_format, sniff_format
# the table readers live in .tables (the other readers share its helpers); named here as before
from .tables import read_csv, read_liggghts, read_mclump, read_yade

__all__ = ["FORMATS", "detect_format", "read", "sniff_format"]


def _reader(fmt: str):
    """The reader function of a format (the modules of the other formats import this one)."""
    if fmt == "lammps":
        from .molecule import read_lammps
        return read_lammps
    if fmt == "liggghts-script":
        from .liggghts_script import read_liggghts_script
        return read_liggghts_script
    if fmt == "deme":
        from .readback import read_deme
        return read_deme
    return {"csv": read_csv, "liggghts": read_liggghts, "mclump": read_mclump, "yade": read_yade}[fmt]


def read(path, fmt: Optional[str] = None, scale: float = 1.0, diameter: Optional[float] = None) -> List[Clump]:
    """Read the clumps of a file.

    Parameters
    ----------
    path : str or os.PathLike
        The file (or, for ``mclump``, the clump folder).
    fmt : str or None, optional
        One of :data:`FORMATS`; None to detect it from the content with :func:`detect_format`.
    scale : float, optional
        Factor on every coordinate and radius, to make them metres (0.001 for a file in mm).
    diameter : float or None, optional
        ``lammps`` only: the diameter of every atom of a molecule file without a ``Diameters``
        section, in the file's length units (`scale` applies to it too).

    Returns
    -------
    list of Clump
        The clumps in file order, centres and radii in m; one clump for the single-clump
        formats, any number for ``yade`` (textClumps), ``liggghts-script`` (one per template
        fix) and ``deme`` (one per entry).

    Raises
    ------
    ValueError
        If `scale` is not a positive finite number, or `diameter` is given for a format other
        than ``lammps``.
    ClumpFileError
        If `fmt` is unknown or cannot be detected, the file is missing, or a line of it is
        bad (a word that is not a number, NaN or inf, a radius <= 0, the wrong number of
        columns) or it holds no sphere; the message names the file and line.

    Notes
    -----
    Numbers are ASCII only; a UTF-8 byte order mark at the start of the file is skipped.
    In a LAMMPS molecule file each atom id appears once per section, and every
    ``Diameters`` and ``Masses`` entry is a number > 0 for an atom of ``Coords``.
    DEME JSON and MClump folders written by ``clumpprops export`` are read back in the
    source frame (:mod:`clumpprops.io.readback`).
    """
    scale = float(scale)
    if not math.isfinite(scale) or scale <= 0:
        raise ValueError(f"scale must be a positive finite number, got {scale!r}")
    if fmt is None:
        fmt = detect_format(path)
    elif fmt not in FORMATS:
        raise ClumpFileError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}", str(path))
    if not os.path.exists(path):
        raise ClumpFileError("cannot read: No such file or directory", str(path))
    if diameter is not None:
        if fmt != "lammps":
            raise ValueError(f"diameter applies only to LAMMPS molecule files, not to format {fmt!r}")
        return _reader(fmt)(path, scale, diameter=float(diameter))
    return _reader(fmt)(path, scale)
