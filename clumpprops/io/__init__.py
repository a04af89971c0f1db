"""Exporters and importers: exact sphere clumps for DEM engines (LIGGGHTS, LAMMPS, DEME, MercuryDPM, YADE)
and for viewers (``vtk`` for ParaView, ``stl``: the union's surface; docs/visualise.md).

:func:`read` detects the format from the file's content (:func:`detect_format`; the name
decides only where the content shows none), or takes it as ``fmt="csv"``, ...:

===================  =====================================================  ===========================================
format               file                                                   detected from
===================  =====================================================  ===========================================
``csv``              ``x,y,z,r`` table (CLUMP, MClump; any name)             a data line with commas
``liggghts``         ``x y z r`` sphere list (any name)                     four whitespace-separated numbers
``yade``             textClumps ``x y z r clumpId``                          five columns, the fifth an integer
``lammps``           molecule file (``diameter=`` without ``Diameters``)     an ``N atoms`` line or a ``Coords`` section
``liggghts-script``  input script, one clump per template fix                a ``particletemplate/multisphere`` command
``deme``             the exported ``*_deme.json`` (source frame)             a JSON object
``mclump``           ``Clump.txt``, its folder, the exported                 a folder, ``Clump.txt``, that file's
                     ``clumpprops.txt`` (source frame)                       first line
===================  =====================================================  ===========================================

:func:`export` writes the files one engine reads, values in SI units:

>>> from clumpprops import io as cio
>>> clumps = cio.read("dimer.csv")
>>> paths = cio.export(clumps, to="liggghts", out_dir="out", density=1140.0)

One module per engine (``clumpprops.io.liggghts``, ``.lammps``, ``.deme``, ``.mclump``,
``.yade``), each with ``write(clumps, mp, out_dir, density, method, ...)``; the readers
are in ``clumpprops.io.readers``.  Values come from :func:`clumpprops.mass_properties`
(exact method by default), in SI units, written with 17 significant digits.  The command line
is ``clumpprops export FILE --to ENGINE`` (``clumpprops.io.cli``; docs/engines.md).
"""
from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from typing import Callable, List, Optional, Sequence

from ._common import Clump, ClumpFileError, compute
from .readers import FORMATS, detect_format, read

#: The engines :func:`export` writes for, as its ``to`` argument.
ENGINES = ("liggghts", "lammps", "deme", "mclump", "yade", "vtk", "stl")

__all__ = ["Clump", "ClumpFileError", "ENGINES", "ExportRefused", "FORMATS", "compute", "detect_format", "export",
           "read"]


def _module(to: str):
    if to not in ENGINES:
        raise ValueError(f"unknown engine {to!r}; choose one of {', '.join(ENGINES)}")
    from importlib import import_module

    return import_module(f".{to}", __name__)


class ExportRefused(ClumpFileError):
    """An export that would write over its input, or over an existing file without ``force``.

    A :class:`ClumpFileError` whose `source` is the file that would be replaced.

    Parameters
    ----------
    reason : str
        Why nothing was written.
    source : str, optional
        The file the export would have written over.
    lineno : int or None, optional
        Always None for an export.
    """


def export(clumps: Sequence[Clump], to: str, out_dir=".", density: float = 1000.0, method: str = "exact",
           source: str = "", scale: float = 1.0, stem: Optional[str] = None, mp=None,
           warn: Optional[Callable[[str], None]] = None, templates: bool = True, force: bool = False,
           deck: bool = False, velocity=(0.0, 0.0, 0.0), spin=(0.0, 0.0, 0.0), steps: int = 1000,
           dt: Optional[float] = None, tolerance: float = 1e-3) -> List:
    """Write the files DEM engine `to` reads for `clumps` into `out_dir`.

    Parameters
    ----------
    clumps : sequence of Clump
        The clumps to export; at least one.
    to : str
        The engine, one of :data:`ENGINES`.
    out_dir : str or os.PathLike, optional
        The folder the files go to; made if missing.  The current folder by default.
    density : float, optional
        Density of the clump material, kg/m^3.
    method : str, optional
        The method of :func:`clumpprops.mass_properties` by name; ``"exact"`` by default.
    source : str, optional
        The input file the clumps came from: named in the files' headers, and never written
        over.
    scale : float, optional
        The factor the reader applied to the input's lengths, named in the headers (1.0: none).
    stem : str or None, optional
        The stem of the output file names; None for the clump's name if there is one
        clump, else ``"clumps"``.  ``mclump`` ignores it: one folder per clump, named
        after the clump.
    mp : clumpprops.MassProperties or None, optional
        Precomputed mass properties of the clumps (a batch, as :func:`compute` returns);
        None to compute them here with `method` and `density`.
    warn : callable or None, optional
        Receives each warning as a string (DEME's float32 precision); None to drop them.
    templates : bool, optional
        False skips the per-clump template files of LAMMPS (``.mol``) and DEME (``.csv``;
        DEME's JSON still holds every clump's spheres): for large batches, where one file
        per clump costs more than everything else.
    force : bool, optional
        True replaces existing output files (never the input file `source`).
    deck : bool, optional
        True also writes a runnable input deck (``liggghts``, ``lammps``, ``yade``): the
        clumps in an empty box without gravity, run for `steps` steps; see
        :mod:`clumpprops.io.decks`.
    velocity, spin : sequence of 3 float, optional
        With `deck`: every clump's initial velocity (m/s) and angular velocity (rad/s, space
        frame).
    steps : int, optional
        With `deck`: the number of steps the deck runs (at least 2).
    dt : float or None, optional
        With `deck`: the timestep in s; None for :func:`clumpprops.io.decks.default_dt`.
    tolerance : float, optional
        With ``to="stl"``: relative tolerance on the mesh's volume and area (:mod:`clumpprops.mesh`).

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    ValueError
        If `to` is not one of :data:`ENGINES`, `clumps` is empty, `templates` is False
        for an engine other than ``lammps`` and ``deme``, `deck` is True for an engine
        without a deck, or a clump has one sphere and `to` is ``lammps``.
    ExportRefused
        If a file would replace `source`, or (without `force`) an existing file; then
        nothing is written.

    Notes
    -----
    The files are written to a staging folder inside `out_dir` first, and moved into
    `out_dir` only when none would replace the input or (without `force`) another file.
    Values are in SI units, with 17 significant digits.
    """
    mod = _module(to)
    clumps = list(clumps)
    if mp is None:
        mp = compute(clumps, density, method)
    kw = {"warn": warn} if to == "deme" else {"tolerance": tolerance} if to == "stl" else {}
    if not templates:
        if to not in ("lammps", "deme"):
            raise ValueError(f"templates=False applies to lammps and deme; {to} needs its per-clump files")
        kw["templates"] = False
    if deck:
        from . import decks

        if to not in decks.DECK_ENGINES:
            raise ValueError(f"deck=True applies to {', '.join(decks.DECK_ENGINES)}; {to} has documented snippets "
                             "in docs/engines.md")
        if to == "lammps":
            kw.update(velocity=velocity, spin=spin)
    out = Path(out_dir)
    made_out = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".clumpprops-export-", dir=out))
    try:
        staged = mod.write(clumps, mp, stage, density, method, source=source, scale=scale, stem=stem, **kw)
        if deck:
            staged += decks.write(to, clumps, mp, stage, stem or (clumps[0].name if len(clumps) == 1 else "clumps"),
                                  density, method, velocity, spin, steps, dt, source=source, scale=scale)
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
