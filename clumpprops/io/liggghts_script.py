"""LIGGGHTS input scripts: the clump templates of ``fix ... particletemplate/multisphere`` commands.

One clump per such fix, named by the fix ID::

    fix pts1 all particletemplate/multisphere 15485863 atom_type 1 density constant 2500 &
        nspheres 2 ntry 1000000 spheres 0 0 0 0.5  0.6 0 0 0.4  type 1

The spheres are inline (``spheres x1 y1 z1 r1 x2 ...``, ``nspheres`` of them, optionally
followed by ``scale S``) or in a sphere file (``spheres file NAME scale S``, NAME relative to
the script's folder, read as :func:`clumpprops.io.readers.read_liggghts` reads it).  A line
ending in ``&`` continues on the next; ``#`` starts a comment.
"""
from __future__ import annotations

from pathlib import Path
from typing import List

from ._common import Clump, ClumpFileError
from .detect import _TEMPLATE
from .tables import _make, _number, _read_lines, read_liggghts


__all__ = ["read_liggghts_script"]


def _commands(text):
    """(first line, [(word, line)]) of each command, continuation lines (``&``) joined, comments cut."""
    words, first = [], None
    for lineno, raw in enumerate(text, 1):
        line = raw.split("#", 1)[0].rstrip()
        more = line.endswith("&")
        if more:
            line = line[:-1]
        if first is None:
            first = lineno
        words += [(w, lineno) for w in line.split()]
        if not more:
            if words:
                yield first, words
            words, first = [], None
    if words:
        yield first, words


def read_liggghts_script(path, scale: float = 1.0) -> List[Clump]:
    """Every ``particletemplate/multisphere`` clump of a LIGGGHTS input script.

    Parameters
    ----------
    path : str or os.PathLike
        The input script.
    scale : float, optional
        Factor on coordinates and radii (on top of a template's own ``scale``).

    Returns
    -------
    list of Clump
        One clump per template fix, in script order, named by the fix ID.

    Raises
    ------
    ClumpFileError
        If the script has no such fix, or a template lacks ``nspheres`` or ``spheres``, holds a
        word that is not a number (e.g. a ``${variable}``), a radius <= 0, or fewer spheres than
        ``nspheres``; the message names the file and line.
    """
    src, text = str(path), _read_lines(path)
    out = []
    for first, words in _commands(text):
        if _TEMPLATE.match(" ".join(w for w, _ in words[:4])):
            out.append(_template(words, first, Path(path), scale))
    if not out:
        raise ClumpFileError("no 'fix ... particletemplate/multisphere' command", src, max(1, len(text)))
    return out


def _keyword(words, key, src, first):
    for k, (w, _) in enumerate(words):
        if w == key:
            return k
    raise ClumpFileError(f"particletemplate/multisphere without '{key}'", src, first)


def _template(words, first, path: Path, scale: float) -> Clump:
    src, fix_id = str(path), words[1][0]
    k = _keyword(words, "nspheres", src, first)
    if k + 1 >= len(words):
        raise ClumpFileError("'nspheres' without a number", src, words[k][1])
    n = _count(words[k + 1], src)
    k = _keyword(words, "spheres", src, first) + 1
    if k < len(words) and words[k][0] == "file":
        return _file_template(words, k, n, fix_id, path, scale)
    values = words[k:k + 4 * n]
    if len(values) < 4 * n:
        raise ClumpFileError(f"'spheres' lists fewer than nspheres={n} spheres (x y z r each)", src, words[-1][1])
    rows = [[_number(w, name, src, line) for name, (w, line) in zip("xyzr", values[4 * i:4 * i + 4])] for i in range(n)]
    for i, row in enumerate(rows):
        if row[3] <= 0:
            raise ClumpFileError(f"radius must be > 0, got {values[4 * i + 3][0]!r}", src, values[4 * i + 3][1])
    own = _scale(words, k + 4 * n, src)
    return _make(rows, [values[4 * i][1] for i in range(n)], fix_id, src, scale * own)


def _file_template(words, k, n, fix_id, path: Path, scale: float) -> Clump:
    src = str(path)
    if k + 1 >= len(words):
        raise ClumpFileError("'spheres file' without a file name", src, words[k][1])
    name, line = words[k + 1]
    sphere_file = Path(name) if Path(name).is_absolute() else path.parent / name
    if not sphere_file.is_file():
        raise ClumpFileError(f"sphere file {name!r} not found (looked in {str(path.parent) or '.'})", src, line)
    c = read_liggghts(sphere_file, scale * _scale(words, k + 2, src))[0]
    if c.n_spheres < n:
        raise ClumpFileError(f"sphere file {name!r} has {c.n_spheres} spheres, nspheres is {n}", src, line)
    return Clump(c.centers[:n], c.radii[:n], fix_id, c.source, c.lines[:n])


def _scale(words, k, src) -> float:
    """The template's ``scale S`` right at word ``k``, else 1."""
    if k < len(words) and words[k][0] == "scale":
        if k + 1 >= len(words):
            raise ClumpFileError("'scale' without a number", src, words[k][1])
        s = _number(words[k + 1][0], "scale", src, words[k + 1][1])
        if s <= 0:
            raise ClumpFileError(f"scale must be > 0, got {words[k + 1][0]!r}", src, words[k + 1][1])
        return s
    return 1.0


def _count(word_line, src) -> int:
    w, line = word_line
    try:
        n = int(w)
    except ValueError:
        n = 0
    if n <= 0 or str(n) != w.lstrip("+"):
        raise ClumpFileError(f"nspheres must be an integer > 0, got {w!r}", src, line)
    return n
