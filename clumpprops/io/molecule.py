"""LAMMPS molecule files (``molecule`` command): one clump from ``Coords`` and ``Diameters``.

Any file name (``.mol``, ``molecule.data``, ``molecule.vshape``); :mod:`clumpprops.io.detect`
knows the file by its ``N atoms`` header or its ``Coords`` section.  A file without a
``Diameters`` section (LAMMPS then takes the diameter from elsewhere, e.g. ``create_atoms``
or ``set``) is read only with an explicit ``diameter``, in the file's length units, which every
atom gets.
"""
from __future__ import annotations

from typing import List, Optional

import numpy as np

from .._numtext import data_line_indices, fast_table, float_columns, strict_int
from ._common import Clump, ClumpFileError
from .tables import _make as make_clump, _number as number, _read_lines as read_lines, _stem as stem

__all__ = ["read_lammps"]

_MOL_SECTIONS = ("Coords", "Types", "Molecules", "Fragments", "Charges", "Diameters", "Masses", "Bonds", "Angles",
                 "Dihedrals", "Impropers", "Special Bond Counts", "Special Bonds", "Shake Flags", "Shake Atoms",
                 "Shake Bond Types")
# the sections read and checked: their columns after the atom id
_MOL_VALUES = {"Coords": ("x", "y", "z"), "Diameters": ("diameter",), "Masses": ("mass",)}
_MOL_SHAPE = {"Coords": "'id x y z'", "Diameters": "'id diameter'", "Masses": "'id mass'"}


def read_lammps(path, scale: float = 1.0, diameter: Optional[float] = None) -> List[Clump]:
    """One clump from a LAMMPS molecule file.

    Parameters
    ----------
    path : str or os.PathLike
        The molecule file: ``N atoms`` header, ``Coords`` and ``Diameters`` sections
        (radius = diameter / 2).  ``Masses`` entries are checked (a number > 0 per atom) but
        not used; other headers and sections are skipped.
    scale : float, optional
        Factor on coordinates and radii.
    diameter : float or None, optional
        The diameter of every atom, in the file's length units, for a file without a
        ``Diameters`` section; it must be None for a file with one.

    Returns
    -------
    list of Clump
        One clump.

    Raises
    ------
    ClumpFileError
        For a bad line, a missing ``Diameters`` section without `diameter`, or `diameter` given
        for a file that has one; the message names the file and line.
    """
    src, text = str(path), read_lines(path)
    sections = _mol_sections(text)
    natoms = _mol_natoms(text, sections[0][1] if sections else len(text), src)
    has_diameters = any(name == "Diameters" for name, _, _ in sections)
    if diameter is not None and has_diameters:
        line = next(i for name, i, _ in sections if name == "Diameters") + 1
        raise ClumpFileError("the file has a Diameters section; --diameter applies only to files without one",
                             src, line)
    if diameter is not None and not (np.isfinite(diameter) and diameter > 0):
        raise ClumpFileError(f"--diameter must be a number > 0, got {diameter!r}", src)
    fast = _mol_fast(text, sections, natoms, diameter)
    rows, lines = fast if fast is not None else _mol_rows(text, sections, natoms, src, diameter)
    return [make_clump(rows, lines, stem(path), src, scale)]


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


def _mol_fast(text, sections, natoms, diameter=None):
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
    if "Coords" not in tables or ("Diameters" not in tables and diameter is None):
        return None
    ids, xyz, lines = tables["Coords"]
    if (natoms is not None and natoms != len(ids)) or len(ids) == 0:
        return None
    for name in ("Diameters", "Masses"):
        if name in tables and not np.array_equal(tables[name][0], ids):
            return None
    diam = tables["Diameters"][1][:, 0] if diameter is None else np.full(len(ids), float(diameter))
    return np.column_stack([xyz, diam / 2.0]), lines


def _mol_rows(text, sections, natoms, src, diameter=None):
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
            values = [number(w, what, src, lineno) for what, w in zip(_MOL_VALUES[name], words[1:])]
            if name != "Coords" and values[0] <= 0:
                raise ClumpFileError(f"{_MOL_VALUES[name][0]} must be > 0, got {words[1]!r}", src, lineno)
            table[aid] = (values, lineno)
    return _mol_match(entries, natoms, src, len(text), diameter)


def _mol_match(entries, natoms, src, nlines, diameter=None):
    """Rows (x, y, z, r) in atom-id order once every atom has its Coords and Diameters entries."""
    coords, diams = entries.get("Coords", {}), entries.get("Diameters", {})
    if not coords:
        raise ClumpFileError("end of file and no spheres found (no Coords section; empty clump)", src, max(1, nlines))
    if not diams and diameter is None:
        raise ClumpFileError("end of file and no Diameters section: the sphere radii are unknown; pass --diameter D "
                             "(every atom's diameter, in the file's length units)", src, max(1, nlines))
    if not diams:
        diams = {aid: ([float(diameter)], lineno) for aid, (_, lineno) in coords.items()}
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


