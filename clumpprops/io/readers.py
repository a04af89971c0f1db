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
line; a file without spheres is an error too.  Numbers are ASCII only (``1_0`` and
non-ASCII digits are not numbers: :mod:`clumpprops._numtext`); a UTF-8 byte order mark at the start
of a file is skipped.  In a ``.mol`` file each atom id appears once per section, every
``Diameters`` and ``Masses`` entry is a number > 0 for an atom of ``Coords``.  ``scale``
multiplies coordinates and radii (0.001 for files in mm).

Speed: each reader parses all its data lines at once with numpy's C reader, which uses
the same number grammar; only if numpy refuses a line, or a value is not finite or not
positive where it must be, the line-by-line validator (``_csv_rows``, ``_mol_rows``, ...)
reads the file again to raise the first error with its line.  A file of 10**6 spheres
reads in seconds, in memory a few times the file's size (benchmarks/bench_io.py
--read-lines).
"""
from __future__ import annotations

import contextlib
import gc
import math
import os
import re
from pathlib import Path
from typing import List, Optional

import numpy as np

from ._common import Clump, ClumpFileError
from .._numtext import data_line_indices, fast_table, float_columns, is_float, strict_float, strict_int, strip_bom

__all__ = ["FORMATS", "detect_format", "read"]

#: The formats :func:`read` reads, as its ``fmt`` argument.
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


def sniff_format(path, n_lines=50) -> Optional[str]:
    """The format the first data lines of ``path`` show, or None where they show none:
    ``lammps`` for a molecule file (an ``N atoms`` header line or a ``Coords`` section), ``csv``
    for comma-separated numbers (CLUMP's and MClump's tables), ``yade`` for five whitespace-separated
    columns whose fifth is an integer (textClumps' clump id), ``liggghts`` for four (``x y z r``)."""
    try:
        with open(path, "r", encoding="utf-8", errors="replace") as f:
            head = [line for _, line in zip(range(n_lines), f)]
    except OSError:
        return None
    words_seen = []
    for line in strip_bom(head):
        s = line.split("#", 1)[0].strip()
        if not s:
            continue
        if re.fullmatch(r"\d+\s+atoms", s) or s == "Coords":
            return "lammps"
        words_seen.append(s)
    data = [s for s in words_seen if s[:1] in "+-.0123456789"]
    if not data:
        return None
    first = data[0]
    if "," in first:
        return "csv"
    cols = first.split()
    if len(cols) == 5 and re.fullmatch(r"[+-]?\d+", cols[4]):
        return "yade"
    if len(cols) == 4:
        return "liggghts"
    return None


def detect_format(path) -> str:
    """The format of a clump file, from its content or its name.

    Parameters
    ----------
    path : str or os.PathLike
        The file, or an MClump clump folder.

    Returns
    -------
    str
        One of :data:`FORMATS`.

    Raises
    ------
    ClumpFileError
        If neither the content nor the name shows a format.

    Notes
    -----
    The content decides where it shows a format (a CLUMP comma table named ``.txt``, a LAMMPS
    molecule file named ``molecule.data``); else the name does, as in this table:

    ============  ===================================================
    format        detected from
    ============  ===================================================
    ``csv``       ``.csv``
    ``liggghts``  ``.multisphere``, ``.ms``, ``.spheres``
    ``mclump``    a file named ``Clump.txt``, a directory
    ``yade``      ``.txt`` (other names)
    ``lammps``    ``.mol``, ``.molecule``
    ============  ===================================================

    A five-column file named like a LIGGGHTS sphere file stays ``liggghts`` (its fifth column
    is the atom type).
    """
    p = Path(path)
    if p.is_dir() or p.name == "Clump.txt":
        return "mclump"
    by_name = _EXT.get(p.suffix.lower())
    by_content = sniff_format(p) if p.is_file() else None
    if by_content == "yade" and by_name == "liggghts":
        return by_name
    fmt = by_content or by_name
    if fmt is None:
        raise ClumpFileError(
            f"unknown format (extension {p.suffix or 'none'!r}, and its first lines show none); name it "
            f"{', '.join(sorted(_EXT))} or pass --from {{{','.join(FORMATS)}}}",
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
    """The file's lines (a UTF-8 byte order mark at the start removed)."""
    try:
        with open(path, "r", encoding="utf-8") as f:
            return strip_bom(f.read().splitlines())
    except UnicodeDecodeError as exc:
        raise ClumpFileError(f"not a text file ({exc.reason})", str(path)) from None
    except OSError as exc:
        raise ClumpFileError(f"cannot read: {exc.strerror or exc}", str(path)) from None


def _number(word, what, source, lineno) -> float:
    """A finite number (strict ASCII grammar, :mod:`clumpprops._numtext`) or one ClumpFileError naming the line."""
    try:
        v = strict_float(word)
    except ValueError:
        raise ClumpFileError(f"{what} is not a number: {word!r}", source, lineno) from None
    if not math.isfinite(v):
        raise ClumpFileError(f"{what} is not finite: {word!r}", source, lineno)
    return v


def _sphere(words, source, lineno, names=_NAMES):
    row = [_number(w, name, source, lineno) for name, w in zip(names, words)]
    if row[3] <= 0:
        raise ClumpFileError(f"radius must be > 0, got {words[3]!r}", source, lineno)
    return row


def _make(rows, lines, name, source, scale, nlines=None) -> Clump:
    if len(rows) == 0:
        where = max(1, nlines) if nlines is not None else None
        raise ClumpFileError("end of file and no spheres found (empty clump)", source, where)
    a = np.asarray(rows, dtype=np.float64).reshape(-1, 4) * scale
    return Clump(centers=a[:, :3], radii=a[:, 3], name=name, source=source, lines=tuple(np.asarray(lines).tolist()))


_XYZR = np.dtype([(n, "f8") for n in _NAMES])
_XYZR_TYPE = np.dtype([(n, "f8") for n in _NAMES] + [("type", "i8")])


def _fast_spheres(text, keep, dtype=_XYZR, **table):
    """(rows (n, 4), 1-based line numbers) of the lines ``keep`` parsed at once by numpy, or None
    if any line is refused or holds a non-finite value or a radius <= 0 (the caller's
    line-by-line validator then raises the first error with its line)."""
    rows = fast_table([text[i] for i in keep], dtype, **table)
    if rows is None:
        return None
    a = float_columns(rows, _NAMES)
    if not (np.isfinite(a).all() and (a[:, 3] > 0).all()):
        return None
    return a, np.asarray(keep, dtype=np.int64) + 1


def read_csv(path, scale: float = 1.0) -> List[Clump]:
    """One clump from ``x,y,z,r`` lines; a first row of column names (x,y,z,r) is optional,
    blank lines and lines starting with ``#`` are skipped."""
    src, text = str(path), _read_lines(path)
    keep = data_line_indices(text)
    if keep and [w.strip().lower() for w in text[keep[0]].split(",")] == list(_NAMES):
        keep = keep[1:]
    fast = _fast_spheres(text, keep, delimiter=",")
    rows, lines = fast if fast is not None else _csv_rows(text, src)
    return [_make(rows, lines, _stem(path), src, scale, len(text))]


def _csv_rows(text, src):
    """The line-by-line CSV validator: rows and line numbers, or the first error with its line."""
    rows, lines = [], []
    first = True
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
    return rows, lines


def _is_name(w: str) -> bool:
    return not is_float(w) and w.lower() not in ("nan", "inf", "-inf", "+inf", "infinity") and w[:1].isalpha()


def read_liggghts(path, scale: float = 1.0) -> List[Clump]:
    """One clump from a LIGGGHTS ``particletemplate/multisphere`` sphere file ``x y z r [type]``."""
    src, text = str(path), _read_lines(path)
    keep = data_line_indices(text)
    fast = None
    if keep:
        five = len(text[keep[0]].split("#", 1)[0].split()) == 5
        fast = _fast_spheres(text, keep, _XYZR_TYPE if five else _XYZR, comments="#")
    rows, lines = fast if fast is not None else _liggghts_rows(text, src)
    return [_make(rows, lines, _stem(path), src, scale, len(text))]


def _liggghts_rows(text, src):
    """The line-by-line LIGGGHTS validator: rows and line numbers, or the first error with its line."""
    rows, lines = [], []
    for lineno, line in enumerate(text, 1):
        words = line.split("#", 1)[0].split()
        if not words:
            continue
        if len(words) not in (4, 5):
            raise ClumpFileError(f"expected 4 columns 'x y z r' (or 5 with an atom type), got {len(words)}: {line.strip()!r}", src, lineno)
        if len(words) == 5:
            try:
                strict_int(words[4])
            except ValueError:
                raise ClumpFileError(f"5th column (atom type) must be an integer, got {words[4]!r}", src, lineno) from None
        rows.append(_sphere(words, src, lineno))
        lines.append(lineno)
    return rows, lines


def read_mclump(path, scale: float = 1.0) -> List[Clump]:
    """One clump from MClump's ``Clump.txt`` (``x,y,z,r`` per line), given the file or its clump folder."""
    p = Path(path)
    if p.is_dir():
        cand = [p / "Clump" / "Clump.txt", p / "Clump.txt"]
        found = [c for c in cand if c.is_file()]
        if not found:
            raise ClumpFileError("folder has no Clump/Clump.txt (MClump layout)", str(path))
        p = found[0]
    src, text = str(p), _read_lines(p)
    fast = _fast_spheres(text, data_line_indices(text, comment=None), delimiter=",")
    rows, lines = fast if fast is not None else _mclump_rows(text, src)
    return [_make(rows, lines, _stem(path), src, scale, len(text))]


def _mclump_rows(text, src):
    """The line-by-line MClump validator: rows and line numbers, or the first error with its line."""
    rows, lines = [], []
    for lineno, line in enumerate(text, 1):
        s = line.strip()
        if not s:
            continue
        words = [w.strip() for w in s.split(",")]
        if len(words) != 4:
            raise ClumpFileError(f"expected 4 comma-separated columns x,y,z,r, got {len(words)}: {s!r}", src, lineno)
        rows.append(_sphere(words, src, lineno))
        lines.append(lineno)
    return rows, lines


def read_yade(path, scale: float = 1.0) -> List[Clump]:
    """All clumps of a YADE ``textClumps`` file (``clumpprops.textclumps`` rules: consecutive
    lines with one clumpId form a clump)."""
    from ..textclumps import read_text_clumps

    try:
        tcs = read_text_clumps(path, scale=scale)
    except ClumpFileError as exc:
        if exc.lineno is None and "no spheres" in exc.reason:  # point at the end of the file, as every reader does
            lineno = max(1, len(_read_lines(path)))
            raise ClumpFileError("end of file and no spheres found (empty clump)", exc.source, lineno) from None
        raise
    except OSError as exc:
        raise ClumpFileError(f"cannot read: {exc.strerror or exc}", str(path)) from None
    with _gc_paused():  # 10**5..10**6 new objects, none in a cycle: the collector would only rescan them
        return _clumps_of(tcs, _stem(path), str(path))


def _clumps_of(tcs, stem, src) -> List[Clump]:
    """One Clump per clump of a parsed textClumps file, named STEM_ID (STEM_ID_lineN for a repeated id)."""
    starts, ids, lines = tcs.starts.tolist(), tcs.ids.tolist(), tcs.lines.tolist()
    repeated = tcs.repeated.tolist()
    out, used = [], set()
    for k, cid in enumerate(ids):
        a, b = starts[k], starts[k + 1]
        name = f"{stem}_{cid}" if len(ids) > 1 else stem
        if name in used:  # an id that comes back after other ids starts a new clump (as in YADE)
            name = f"{name}_line{lines[a]}"
        used.add(name)
        out.append(Clump(tcs.centers[a:b], tcs.radii[a:b], name, src, tuple(lines[a:b]), cid, repeated[k]))
    return out


@contextlib.contextmanager
def _gc_paused():
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


_MOL_SECTIONS = ("Coords", "Types", "Molecules", "Fragments", "Charges", "Diameters", "Masses", "Bonds", "Angles",
                 "Dihedrals", "Impropers", "Special Bond Counts", "Special Bonds", "Shake Flags", "Shake Atoms",
                 "Shake Bond Types")
# the sections read and checked: their columns after the atom id
_MOL_VALUES = {"Coords": ("x", "y", "z"), "Diameters": ("diameter",), "Masses": ("mass",)}
_MOL_SHAPE = {"Coords": "'id x y z'", "Diameters": "'id diameter'", "Masses": "'id mass'"}


def read_lammps(path, scale: float = 1.0) -> List[Clump]:
    """One clump from a LAMMPS molecule file: ``N atoms`` header, ``Coords`` and ``Diameters``
    sections (radius = diameter / 2).  ``Masses`` entries are checked (a number > 0 per atom)
    but not used; other headers and sections are skipped."""
    src, text = str(path), _read_lines(path)
    sections = _mol_sections(text)
    natoms = _mol_natoms(text, sections[0][1] if sections else len(text), src)
    fast = _mol_fast(text, sections, natoms)
    rows, lines = fast if fast is not None else _mol_rows(text, sections, natoms, src)
    return [_make(rows, lines, _stem(path), src, scale)]


def _mol_sections(text):
    """[(name, index of its keyword line, index of the next section's line or the end)] in file order."""
    found = []
    for i in range(1, len(text)):  # line 1 is the title
        line = text[i]
        if line.lstrip()[:1].isalpha():
            joined = " ".join(line.split("#", 1)[0].split())
            if joined in _MOL_SECTIONS:
                found.append((joined, i))
    ends = [i for _, i in found[1:]] + [len(text)]
    return [(name, i, end) for (name, i), end in zip(found, ends)]


def _mol_natoms(text, end, src) -> Optional[int]:
    """The ``N atoms`` header value (lines 2 .. the first section), None if absent."""
    natoms = None
    for lineno in range(2, end + 1):
        words = text[lineno - 1].split("#", 1)[0].split()
        if len(words) == 2 and words[1] == "atoms":
            try:
                natoms = strict_int(words[0])
            except ValueError:
                raise ClumpFileError(f"number of atoms must be an integer, got {words[0]!r}", src, lineno) from None
    return natoms


def _mol_fast(text, sections, natoms):
    """(rows, lines) from the Coords, Diameters and Masses sections parsed at once by numpy, or None
    if anything needs the line-by-line validator (which words the error with its line)."""
    tables = {}
    for name, start, end in sections:
        if name in _MOL_VALUES:
            if name in tables:
                return None
            keep = [start + 1 + i for i in data_line_indices(text[start + 1:end])]
            dtype = np.dtype([("id", "i8")] + [(c, "f8") for c in _MOL_VALUES[name]])
            rows = fast_table([text[i] for i in keep], dtype, comments="#")
            if rows is None or len(np.unique(rows["id"])) != len(rows):
                return None
            values = float_columns(rows, _MOL_VALUES[name])
            if not np.isfinite(values).all() or (name != "Coords" and not (values > 0).all()):
                return None
            order = np.argsort(rows["id"])
            tables[name] = (rows["id"][order], values[order], np.asarray(keep, dtype=np.int64)[order] + 1)
    if "Coords" not in tables or "Diameters" not in tables:
        return None
    ids, xyz, lines = tables["Coords"]
    if (natoms is not None and natoms != len(ids)) or len(ids) == 0:
        return None
    for name in ("Diameters", "Masses"):
        if name in tables and not np.array_equal(tables[name][0], ids):
            return None
    return np.column_stack([xyz, tables["Diameters"][1][:, 0] / 2.0]), lines


def _mol_rows(text, sections, natoms, src):
    """The line-by-line molecule-file validator: rows and line numbers, or the first error with its line."""
    entries = {}  # section -> {atom id: (values, line)}
    for name, start, end in sections:
        if name not in _MOL_VALUES:
            continue
        table = entries.setdefault(name, {})
        for lineno in range(start + 2, end + 1):
            raw = text[lineno - 1]
            words = raw.split("#", 1)[0].split()
            if not words:
                continue
            if len(words) != 1 + len(_MOL_VALUES[name]):
                raise ClumpFileError(f"{name} line must be {_MOL_SHAPE[name]}, got {len(words)} columns: {raw.strip()!r}",
                                     src, lineno)
            aid = _atom_id(words[0], src, lineno)
            if aid in table:
                raise ClumpFileError(f"atom id {aid} appears twice in {name} (first on line {table[aid][1]})", src, lineno)
            values = [_number(w, what, src, lineno) for what, w in zip(_MOL_VALUES[name], words[1:])]
            if name != "Coords" and values[0] <= 0:
                raise ClumpFileError(f"{_MOL_VALUES[name][0]} must be > 0, got {words[1]!r}", src, lineno)
            table[aid] = (values, lineno)
    return _mol_match(entries, natoms, src, len(text))


def _mol_match(entries, natoms, src, nlines):
    """Rows (x, y, z, r) in atom-id order once every atom has its Coords and Diameters entries."""
    coords, diams = entries.get("Coords", {}), entries.get("Diameters", {})
    if not coords:
        raise ClumpFileError("end of file and no spheres found (no Coords section; empty clump)", src, max(1, nlines))
    if not diams:
        raise ClumpFileError("end of file and no Diameters section: the sphere radii are unknown", src, max(1, nlines))
    if natoms is not None and natoms != len(coords):
        raise ClumpFileError(f"header says {natoms} atoms, Coords has {len(coords)}", src)
    for name in ("Diameters", "Masses"):
        for aid, (_, lineno) in entries.get(name, {}).items():
            if aid not in coords:
                raise ClumpFileError(f"atom {aid} of the {name} section is not in Coords", src, lineno)
    rows, lines = [], []
    for aid in sorted(coords):
        if aid not in diams:
            raise ClumpFileError(f"atom {aid} has no diameter in the Diameters section", src, coords[aid][1])
        if "Masses" in entries and aid not in entries["Masses"]:
            raise ClumpFileError(f"atom {aid} has no mass in the Masses section", src, coords[aid][1])
        rows.append(coords[aid][0] + [diams[aid][0][0] / 2.0])
        lines.append(coords[aid][1])
    return rows, lines


def _atom_id(w, src, lineno) -> int:
    try:
        return strict_int(w)
    except ValueError:
        raise ClumpFileError(f"atom id must be an integer, got {w!r}", src, lineno) from None


_READERS = {"csv": read_csv, "liggghts": read_liggghts, "mclump": read_mclump, "yade": read_yade, "lammps": read_lammps}


def read(path, fmt: Optional[str] = None, scale: float = 1.0) -> List[Clump]:
    """Read the clumps of a file.

    Parameters
    ----------
    path : str or os.PathLike
        The file (or, for ``mclump``, the clump folder).
    fmt : str or None, optional
        One of :data:`FORMATS`; None to detect it with :func:`detect_format`.
    scale : float, optional
        Factor on every coordinate and radius, to make them metres (0.001 for a file in mm).

    Returns
    -------
    list of Clump
        The clumps in file order, centres and radii in m; one clump for every format but
        ``yade`` (textClumps), which holds any number.

    Raises
    ------
    ValueError
        If `scale` is not a positive finite number.
    ClumpFileError
        If `fmt` is unknown or cannot be detected, the file is missing, or a line of it is
        bad (a word that is not a number, NaN or inf, a radius <= 0, the wrong number of
        columns) or it holds no sphere; the message names the file and line.

    Notes
    -----
    Numbers are ASCII only; a UTF-8 byte order mark at the start of the file is skipped.
    In a LAMMPS molecule file each atom id appears once per section, and every
    ``Diameters`` and ``Masses`` entry is a number > 0 for an atom of ``Coords``.
    """
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
