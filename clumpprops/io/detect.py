"""Which format a clump file is in, from its content (its name decides only where the content shows none).

===================  ================================================  =========================================
format               file                                              detected from the content
===================  ================================================  =========================================
``csv``              ``x,y,z,r`` per line, optional header row         a data line with commas
                     (CLUMP's and MClump's tables, any name)
``liggghts``         LIGGGHTS sphere file ``x y z r [type]``           four whitespace-separated numbers
                     (any name, e.g. ``stone1.test``)                  (or five, named ``.multisphere``)
``yade``             YADE ``ymport.textClumps`` ``x y z r clumpId``    five columns, the fifth an integer
``lammps``           LAMMPS molecule file (any name: ``.mol``,         an ``N atoms`` header line or a
                     ``molecule.data``, ``molecule.vshape``)           ``Coords`` section
``liggghts-script``  LIGGGHTS input script with template fixes         a ``particletemplate/multisphere``
                     (``particletemplate/multisphere ... spheres``)    command
``deme``             the ``*_deme.json`` ``clumpprops export`` writes  a JSON object (``clumps``)
``mclump``           MClump's ``Clump.txt``, its clump folder, or the  a folder, a file named ``Clump.txt``,
                     ``clumpprops.txt`` ``clumpprops export`` writes   the first line of that ``clumpprops.txt``
===================  ================================================  =========================================
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import List, Optional

from .._numtext import strip_bom
from ._common import ClumpFileError

#: The formats :func:`clumpprops.io.read` reads, as its ``fmt`` argument.
FORMATS = ("csv", "liggghts", "mclump", "yade", "lammps", "liggghts-script", "deme")
_EXT = {
    ".csv": "csv",
    ".multisphere": "liggghts",
    ".ms": "liggghts",
    ".spheres": "liggghts",
    ".txt": "yade",
    ".mol": "lammps",
    ".molecule": "lammps",
    ".json": "deme",
}
_TEMPLATE = re.compile(r"^\s*fix\s+\S+\s+\S+\s+particletemplate/multisphere\b")
MCLUMP_MARK = "for MercuryDPM (MClump folder layout)"


def _head(path, n_lines) -> List[str]:
    try:
        with open(path, "r", encoding="utf-8", errors="replace") as f:
            return strip_bom([line for _, line in zip(range(n_lines), f)])
    except OSError:
        return []


def sniff_format(path, n_lines=50) -> Optional[str]:
    """The format the first lines of ``path`` show, or None where they show none.

    Parameters
    ----------
    path : str or os.PathLike
        A file.
    n_lines : int, optional
        How many lines to look at (a LIGGGHTS script is searched whole for its template command).

    Returns
    -------
    str or None
        ``deme`` for a JSON object, ``mclump`` for the ``clumpprops.txt`` of an MClump export,
        ``lammps`` for a molecule file (an ``N atoms`` header line or a ``Coords`` section), ``csv``
        for comma-separated numbers (CLUMP's and MClump's tables), ``yade`` for five
        whitespace-separated columns whose fifth is an integer (textClumps' clump id),
        ``liggghts`` for four (``x y z r``), ``liggghts-script`` for an input script with a
        ``particletemplate/multisphere`` command; None otherwise.
    """
    head = _head(path, n_lines)
    if head and head[0].lstrip().startswith("{"):
        return "deme"
    if head and MCLUMP_MARK in head[0]:
        return "mclump"
    words_seen = []
    for line in head:
        s = line.split("#", 1)[0].strip()
        if not s:
            continue
        if re.fullmatch(r"\d+\s+atoms", s) or s == "Coords":
            return "lammps"
        words_seen.append(s)
    data = [s for s in words_seen if s[:1] in "+-.0123456789"]
    if any(_TEMPLATE.match(s) for s in words_seen) or (not data and _has_template(path)):
        return "liggghts-script"
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


def _has_template(path) -> bool:
    try:
        with open(path, "r", encoding="utf-8", errors="replace") as f:
            return any(_TEMPLATE.match(line) for line in f)
    except OSError:
        return False


def detect_format(path) -> str:
    """The format of a clump file, from its content (else its name).

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
    The content decides (see the module's table): a CLUMP comma table named ``.txt`` is ``csv``,
    a LAMMPS molecule file named ``molecule.data`` is ``lammps``, a four-column list named
    ``stone1.test`` is ``liggghts``.  Only where the first lines show no format does the name
    decide (``.csv``, ``.multisphere``/``.ms``/``.spheres``, ``.txt``, ``.mol``/``.molecule``,
    ``.json``).  A five-column file named like a LIGGGHTS sphere file stays ``liggghts`` (its
    fifth column is the atom type), and a four-column whitespace file named ``.txt`` is an
    ``x y z r`` list (``liggghts``: CLUMP's and ``clumpprops fit``'s whitespace tables; a textClumps
    file starts with five columns; ``fmt="yade"`` reads it as textClumps).  A folder, and a file named ``Clump.txt``, are ``mclump``.
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
