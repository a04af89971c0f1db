"""Importers: sphere clumps from the files DEM engines and clump tools use.

==========  =====================================================  ==========================
format      file                                                    detected from
==========  =====================================================  ==========================
``csv``     ``x,y,z,r`` per line, optional header row (one clump)   ``.csv``
``liggghts``  LIGGGHTS sphere file ``x y z r`` (``#`` comments;       ``.multisphere``, ``.ms``,
            an optional 5th column, the atom type, is ignored)       ``.spheres``
``mclump``  MercuryDPM MClump ``Clump.txt`` (``x,y,z,r``), or the   a file named ``Clump.txt``,
            clump folder holding ``Clump/Clump.txt``                 a directory
``yade``    YADE ``ymport.textClumps`` (``x y z r clumpId``)         ``.txt`` (other names)
``lammps``  LAMMPS molecule file with ``Coords`` and ``Diameters``   ``.mol``, ``.molecule``
==========  =====================================================  ==========================

Every reader checks each number (a word that is not a number, NaN/inf, a radius <= 0,
the wrong number of columns) and raises :class:`ClumpFileError` naming the file and
line; a file without spheres is an error too.  ``scale`` multiplies coordinates and
radii (0.001 for files in mm).
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import List, Optional

import numpy as np

from ._common import Clump, ClumpFileError

__all__ = ["FORMATS", "detect_format", "read"]

FORMATS = ("csv", "liggghts", "mclump", "yade", "lammps")
_EXT = {
    ".csv": "csv",
    ".multisphere": "liggghts",
    ".ms": "liggghts",
    ".spheres": "liggghts",
    ".txt": "yade",
    ".mol": "lammps",
    ".molecule": "lammps",
}
_NAMES = ("x", "y", "z", "r")


def detect_format(path) -> str:
    """The format of ``path`` from its name (see the module table); ClumpFileError if unknown."""
    p = Path(path)
    if p.is_dir() or p.name == "Clump.txt":
        return "mclump"
    fmt = _EXT.get(p.suffix.lower())
    if fmt is None:
        raise ClumpFileError(
            f"unknown format (extension {p.suffix or 'none'!r}); name it {', '.join(sorted(_EXT))} "
            f"or pass --from {{{','.join(FORMATS)}}}",
            str(path),
        )
    return fmt


def _stem(path) -> str:
    p = Path(path)
    if p.is_dir():
        return p.resolve().name
    if p.name == "Clump.txt":  # <name>/Clump/Clump.txt
        par = p.resolve().parent
        return par.parent.name if par.name == "Clump" else par.name
    return p.stem


def _read_lines(path) -> List[str]:
    try:
        with open(path, "r", encoding="utf-8") as f:
            return f.read().splitlines()
    except UnicodeDecodeError as exc:
        raise ClumpFileError(f"not a text file ({exc.reason})", str(path)) from None
    except OSError as exc:
        raise ClumpFileError(f"cannot read: {exc.strerror or exc}", str(path)) from None


def _sphere(words, source, lineno, names=_NAMES):
    row = []
    for name, w in zip(names, words):
        try:
            v = float(w)
        except ValueError:
            raise ClumpFileError(f"{name} is not a number: {w!r}", source, lineno) from None
        if not math.isfinite(v):
            raise ClumpFileError(f"{name} is not finite: {w!r}", source, lineno)
        row.append(v)
    if row[3] <= 0:
        raise ClumpFileError(f"radius must be > 0, got {words[3]!r}", source, lineno)
    return row


def _make(rows, lines, name, source, scale, nlines=None) -> Clump:
    if not rows:
        where = max(1, nlines) if nlines is not None else None
        raise ClumpFileError("end of file and no spheres found (empty clump)", source, where)
    a = np.array(rows, dtype=np.float64) * scale
    return Clump(centers=a[:, :3], radii=a[:, 3], name=name, source=source, lines=tuple(lines))


def read_csv(path, scale: float = 1.0) -> List[Clump]:
    """One clump from ``x,y,z,r`` lines; a first row of column names (x,y,z,r) is optional,
    blank lines and lines starting with ``#`` are skipped."""
    src = str(path)
    rows, lines = [], []
    first = True
    text = _read_lines(path)
    for lineno, line in enumerate(text, 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        words = [w.strip() for w in s.split(",")]
        if first:
            first = False
            if [w.lower() for w in words] == list(_NAMES):
                continue
            if any(_is_name(w) for w in words):
                raise ClumpFileError(f"header must be 'x,y,z,r', got {s!r}", src, lineno)
        if len(words) != 4:
            raise ClumpFileError(f"expected 4 comma-separated columns x,y,z,r, got {len(words)}: {s!r}", src, lineno)
        rows.append(_sphere(words, src, lineno))
        lines.append(lineno)
    return [_make(rows, lines, _stem(path), src, scale, len(text))]


def _is_name(w: str) -> bool:
    try:
        float(w)
        return False
    except ValueError:
        return w.lower() not in ("nan", "inf", "-inf", "+inf", "infinity") and w[:1].isalpha()


def read_liggghts(path, scale: float = 1.0) -> List[Clump]:
    """One clump from a LIGGGHTS ``particletemplate/multisphere`` sphere file ``x y z r [type]``."""
    src = str(path)
    rows, lines = [], []
    text = _read_lines(path)
    for lineno, line in enumerate(text, 1):
        words = line.split("#", 1)[0].split()
        if not words:
            continue
        if len(words) not in (4, 5):
            raise ClumpFileError(f"expected 4 columns 'x y z r' (or 5 with an atom type), got {len(words)}: {line.strip()!r}", src, lineno)
        if len(words) == 5:
            try:
                int(words[4])
            except ValueError:
                raise ClumpFileError(f"5th column (atom type) must be an integer, got {words[4]!r}", src, lineno) from None
        rows.append(_sphere(words, src, lineno))
        lines.append(lineno)
    return [_make(rows, lines, _stem(path), src, scale, len(text))]


def read_mclump(path, scale: float = 1.0) -> List[Clump]:
    """One clump from MClump's ``Clump.txt`` (``x,y,z,r`` per line), given the file or its clump folder."""
    p = Path(path)
    if p.is_dir():
        cand = [p / "Clump" / "Clump.txt", p / "Clump.txt"]
        found = [c for c in cand if c.is_file()]
        if not found:
            raise ClumpFileError("folder has no Clump/Clump.txt (MClump layout)", str(path))
        p = found[0]
    src = str(p)
    rows, lines = [], []
    text = _read_lines(p)
    for lineno, line in enumerate(text, 1):
        s = line.strip()
        if not s:
            continue
        words = [w.strip() for w in s.split(",")]
        if len(words) != 4:
            raise ClumpFileError(f"expected 4 comma-separated columns x,y,z,r, got {len(words)}: {s!r}", src, lineno)
        rows.append(_sphere(words, src, lineno))
        lines.append(lineno)
    return [_make(rows, lines, _stem(path), src, scale, len(text))]


def read_yade(path, scale: float = 1.0) -> List[Clump]:
    """All clumps of a YADE ``textClumps`` file (``clumpprops.textclumps`` rules: consecutive
    lines with one clumpId form a clump)."""
    from ..textclumps import TextClumpsError, read_text_clumps

    try:
        tcs = read_text_clumps(path, scale=scale)
    except TextClumpsError as exc:
        lineno = exc.lineno
        if lineno is None and "no spheres" in exc.reason:  # point at the end of the file
            lineno = max(1, len(_read_lines(path)))
            raise ClumpFileError("end of file and no spheres found (empty clump)", exc.source, lineno) from None
        raise ClumpFileError(exc.reason, exc.source, lineno) from None
    except OSError as exc:
        raise ClumpFileError(f"cannot read: {exc.strerror or exc}", str(path)) from None
    stem = _stem(path)
    out, used = [], set()
    for t in tcs:
        name = f"{stem}_{t.clump_id}" if len(tcs) > 1 else stem
        if name in used:  # an id that comes back after other ids starts a new clump (as in YADE)
            name = f"{name}_line{t.lines[0]}"
        used.add(name)
        out.append(Clump(t.centers, t.radii, name, str(path), tuple(t.lines)))
    return out


_MOL_SECTIONS = ("Coords", "Types", "Molecules", "Fragments", "Charges", "Diameters", "Masses", "Bonds", "Angles",
                 "Dihedrals", "Impropers", "Special Bond Counts", "Special Bonds", "Shake Flags", "Shake Atoms",
                 "Shake Bond Types")


def read_lammps(path, scale: float = 1.0) -> List[Clump]:
    """One clump from a LAMMPS molecule file: ``N atoms`` header, ``Coords`` and ``Diameters``
    sections (radius = diameter / 2).  Other headers and sections are skipped."""
    src = str(path)
    text = _read_lines(path)
    natoms = None
    coords, diams = {}, {}
    coord_line, diam_line = {}, {}
    section = None
    for lineno, raw in enumerate(text, 1):
        if lineno == 1:
            continue  # the title line
        words = raw.split("#", 1)[0].split()
        if not words:
            continue
        joined = " ".join(words)
        if joined in _MOL_SECTIONS:
            section = joined
            continue
        if section is None:  # header: "value(s) keyword"
            if words[-1] == "atoms" and len(words) == 2:
                try:
                    natoms = int(words[0])
                except ValueError:
                    raise ClumpFileError(f"number of atoms must be an integer, got {words[0]!r}", src, lineno) from None
            continue
        if section == "Coords":
            if len(words) != 4:
                raise ClumpFileError(f"Coords line must be 'id x y z', got {len(words)} columns: {raw.strip()!r}", src, lineno)
            coords[_atom_id(words[0], src, lineno)] = words[1:4]
            coord_line[_atom_id(words[0], src, lineno)] = lineno
        elif section == "Diameters":
            if len(words) != 2:
                raise ClumpFileError(f"Diameters line must be 'id diameter', got {len(words)} columns: {raw.strip()!r}", src, lineno)
            diams[_atom_id(words[0], src, lineno)] = words[1]
            diam_line[_atom_id(words[0], src, lineno)] = lineno
    if not coords:
        raise ClumpFileError("end of file and no spheres found (no Coords section; empty clump)", src, max(1, len(text)))
    if not diams:
        raise ClumpFileError("end of file and no Diameters section: the sphere radii are unknown", src, max(1, len(text)))
    if natoms is not None and natoms != len(coords):
        raise ClumpFileError(f"header says {natoms} atoms, Coords has {len(coords)}", src)
    rows, lines = [], []
    for aid in sorted(coords):
        if aid not in diams:
            raise ClumpFileError(f"atom {aid} has no diameter in the Diameters section", src, coord_line[aid])
        try:
            d = float(diams[aid])
        except ValueError:
            raise ClumpFileError(f"diameter is not a number: {diams[aid]!r}", src, diam_line[aid]) from None
        if not math.isfinite(d):
            raise ClumpFileError(f"diameter is not finite: {diams[aid]!r}", src, diam_line[aid])
        if d <= 0:
            raise ClumpFileError(f"diameter must be > 0, got {diams[aid]!r}", src, diam_line[aid])
        rows.append(_sphere(coords[aid] + [repr(d / 2.0)], src, coord_line[aid]))
        lines.append(coord_line[aid])
    return [_make(rows, lines, _stem(path), src, scale)]


def _atom_id(w, src, lineno) -> int:
    try:
        return int(w)
    except ValueError:
        raise ClumpFileError(f"atom id must be an integer, got {w!r}", src, lineno) from None


_READERS = {"csv": read_csv, "liggghts": read_liggghts, "mclump": read_mclump, "yade": read_yade, "lammps": read_lammps}


def read(path, fmt: Optional[str] = None, scale: float = 1.0) -> List[Clump]:
    """Clumps from ``path``; ``fmt`` one of :data:`FORMATS` or None to detect it from the name."""
    scale = float(scale)
    if not math.isfinite(scale) or scale <= 0:
        raise ValueError(f"scale must be a positive finite number, got {scale!r}")
    if fmt is None:
        fmt = detect_format(path)
    elif fmt not in _READERS:
        raise ClumpFileError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}", str(path))
    if not os.path.exists(path):
        raise ClumpFileError("cannot read: No such file or directory", str(path))
    return _READERS[fmt](path, scale)
